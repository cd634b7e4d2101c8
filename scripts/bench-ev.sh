#!/usr/bin/env bash
# Evaluation cost near extraordinary vertices (issue 12): `limitray bench-eval --near
# centre|ev` on scenes/meshes/blob.obj and on generated valence-n stars (n = 3, 5..12: the
# disc of `limitray::mesh::generate::star(n, 4)`, written by examples/star.rs), one thread.
# Prints a markdown table: evaluations per second at face centres and within 2^-10 of an
# extraordinary corner, and their cost ratio (ev / centre); each the best of RUNS (default 3)
# runs.
#
# Usage:
#   bash scripts/bench-ev.sh [LIMITRAY_BINARY] [EV_SAMPLES]
# LIMITRAY_BINARY defaults to target/release/limitray (cargo build --release); EV_SAMPLES
# (default 20000) is the number of near-EV queries per repetition (centre queries: 100000).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BIN="${1:-${CARGO_TARGET_DIR:-$ROOT/target}/release/limitray}"
EV_SAMPLES="${2:-20000}"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

# The stars of generate::star(n, r), written by examples/star.rs.
cargo build --quiet --release --no-default-features --example star --manifest-path "$ROOT/Cargo.toml"
STAR="${CARGO_TARGET_DIR:-$ROOT/target}/release/examples/star"
star() { "$STAR" "$1" "$2"; }

MESHES=("$ROOT/scenes/meshes/blob.obj")
for n in 3 5 6 7 8 9 10 11 12; do
    star "$n" 4 >"$TMP/star$n.obj"
    MESHES+=("$TMP/star$n.obj")
done

field() { python3 -c "import json,sys; print(json.loads(sys.argv[1])[sys.argv[2]])" "$1" "$2"; }

# Best of RUNS runs (each the median of bench-eval's repetitions), alternating centre and
# ev runs, so that load from other processes hurts both alike.
RUNS="${RUNS:-3}"
echo "| mesh | centre evals/s | ev evals/s | ratio ev/centre |"
echo "|---|---:|---:|---:|"
for m in "${MESHES[@]}"; do
    ce=0
    ee=0
    for _ in $(seq "$RUNS"); do
        c="$(field "$("$BIN" bench-eval "$m" --threads 1 --near centre --samples 100000)" evals_per_s)"
        e="$(field "$("$BIN" bench-eval "$m" --threads 1 --near ev --samples "$EV_SAMPLES")" evals_per_s)"
        ce="$(python3 -c "print(max($ce, $c))")"
        ee="$(python3 -c "print(max($ee, $e))")"
    done
    ratio="$(python3 -c "print(f'{$ce / $ee:.2f}')")"
    echo "| $(basename "$m" .obj) | $(printf %.0f "$ce") | $(printf %.0f "$ee") | $ratio |"
done
