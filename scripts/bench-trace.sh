#!/usr/bin/env bash
# Dicing and ray-query benchmark (issue 4): patch table, dicing and BVH build times, bytes per
# triangle, closest-hit rays/s for coherent (camera) and incoherent rays, on catmark_car at
# rates 4 and 16 and generated grids (316 x 316 = 99,856 faces at rate 4; 79 x 79 at rate 16,
# the same 3.2 M triangles, since the 316 grid at rate 16 would be 51 M), 1 and 2 threads.
# Prints a markdown table; the JSON lines of `limitray bench-trace` go to stderr.
#
# Usage: bash scripts/bench-trace.sh > table.md 2> raw.jsonl
# Environment: RAYS (default 1000000), REPS (5), THREADS ("1 2"), CONFIGS ("car:4 car:16 316:4 79:16").
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
RAYS="${RAYS:-1000000}"
REPS="${REPS:-5}"
CONFIGS="${CONFIGS:-car:4 car:16 316:4 79:16}"
THREADS="${THREADS:-1 2}"
CAR="$ROOT/../shared/models/opensubdiv/catmark_car.obj"
cargo build --release --quiet
BIN="$ROOT/target/release/limitray"
echo "| mesh | rate | threads | triangles | table ms | dice ms | BVH ms | bytes/triangle | coherent Mrays/s | incoherent Mrays/s | incoherent any-hit Mrays/s |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for config in $CONFIGS; do
    mesh="${config%%:*}"
    rate="${config##*:}"
    for t in $THREADS; do
        if [[ $mesh == car ]]; then args=("$CAR"); name=catmark_car; else args=(--grid "$mesh"); name="grid $mesh"; fi
        json="$("$BIN" bench-trace "${args[@]}" --rate "$rate" --rays "$RAYS" --threads "$t" --reps "$REPS")"
        echo "$json" >&2
        python3 -c '
import json, sys
j = json.loads(sys.argv[3])
cols = [sys.argv[1], sys.argv[2], j["threads"], format(j["triangles"], ","), round(j["table_ms"]),
        round(j["dice_ms"]), round(j["grid_ms"]), round(j["bytes_per_triangle"]),
        "%.2f" % j["coherent_mrays_per_s"], "%.2f" % j["incoherent_mrays_per_s"],
        "%.2f" % j["incoherent_anyhit_mrays_per_s"]]
print("| " + " | ".join(str(c) for c in cols) + " |")
' "$name" "$rate" "$json"
    done
done
