#!/bin/sh
# Regenerates the PNG renders of the bundled scenes in docs/ (and their EXRs in target/docs/).
#
#     scripts/render-docs.sh [SPP]
#
# SPP overrides every scene's samples per pixel (default: the scenes' own settings).
set -eu
cd "$(dirname "$0")/.."
cargo build --release --quiet
mkdir -p docs target/docs
for scene in default organic hardsurface loop detail; do
    if [ $# -ge 1 ]; then spp="--spp $1"; else spp=""; fi
    # shellcheck disable=SC2086
    ./target/release/limitray render "scenes/$scene.toml" \
        -o "target/docs/$scene.exr" --png "docs/$scene.png" \
        --levels-png "docs/${scene}_levels.png" $spp
done
