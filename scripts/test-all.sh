#!/usr/bin/env bash
# Every test of the project on a fresh machine (Debian 12, as root): installs the references
# and tools the tests need, then runs the whole suite with the `embree` feature.
#   - OpenSubdiv 3.5 (Debian's libosd-dev) and its small reference program: scripts/setup-osd.sh
#   - Embree 4.4 from PyPI's embreex wheel (pinned by hash):                 scripts/setup-embree.sh
#   - Vulkan loader and Mesa's lavapipe for the GPU tests:                   scripts/setup-lavapipe.sh
# Tests that read ../shared skip with a note when it is absent; under CI=true the GPU and
# Embree tests fail rather than skip when their library or adapter is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-osd.sh
bash scripts/setup-embree.sh
if [ -f scripts/setup-lavapipe.sh ]; then
    bash scripts/setup-lavapipe.sh
fi
export NODEVICE_SELECT=1
cargo test --features embree "$@"

# The EXR through an independent reader: the reference OpenEXR library's Python module.
python3 -m pip install --quiet --disable-pip-version-check OpenEXR
# `cargo test` built the binary (test profile, optimised) for the CLI tests.
target/debug/limitray render scenes/default.toml -o target/check-default.exr \
    --res 64x36 --spp 2 --quiet
python3 scripts/check-exr.py target/check-default.exr

# The Python package (python/, PyO3 + maturin) in a venv under target/, and its pytest suite.
bash scripts/test-python.sh
