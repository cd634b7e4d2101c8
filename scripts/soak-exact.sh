#!/usr/bin/env bash
# Soak the reference intersector (issue 17): tests/exact.rs with N rays per closed corpus shape
# (27 shapes) and N/6 per random creased mesh (150 meshes). N = 30000 traces about 1.56
# million rays. Prints each shape's statistics and the totals.
#
# (The test profile is optimised, opt-level 3.)
#
# Usage: bash scripts/soak-exact.sh [N]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
LIMITRAY_EXACT_RAYS="${1:-30000}" cargo test --test exact -- --nocapture --test-threads 1
