#!/usr/bin/env bash
# Differential soak test against OpenSubdiv Far: N random meshes (default 100000) through
# tests/osd_oracle.rs's `soak` test, in chunks of 2000, printing the worst differences and
# every failing mesh shrunk to a minimal one (also written to target/oracle-failures/).
#
# Usage: bash scripts/soak-osd.sh [N] [FIRST_SEED]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
N="${1:-100000}"
FIRST="${2:-1000000}"
bash scripts/setup-osd.sh >/dev/null
LIMITRAY_ORACLE_MESHES="$N" LIMITRAY_ORACLE_SEED="$FIRST" \
    cargo test --test osd_oracle soak -- --ignored --exact --nocapture
