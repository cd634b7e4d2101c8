#!/usr/bin/env bash
# Side-by-side benchmark against Embree 4.4 (issues 5 and 14): limitray's grid core, its
# triangle BVH, Embree on the same triangles, Embree subdivision geometry at the same rate (and
# Embree's robust triangles, and limitray's reference intersector). By default, issue 14's four
# meshes: catmark_car at rates 16 and 64, scenes/meshes/blob.obj at rate 16 and the generated
# 316 x 316 grid (99,856 faces) at rate 4, 1 and 2 threads; about 12 minutes with RAYS=300000
# REPS=3 on 2 cores. The engines together take ~500 bytes per triangle: about 6.5 GB for the car
# at rate 64 (12.9 M triangles); the 316 grid at rate 16 (51 M triangles, about 25 GB) does not
# fit a 23 GB machine, so use 79:16 for 3.2 M triangles at rate 16.
# Prints a markdown table on stdout, then a second one of limitray ÷ Embree ratios paired by
# round (`limitray bench` interleaves the engines round by round: each round's ratio compares
# measurements taken seconds apart; their median, and their range); the JSON lines of
# `limitray bench` go to stderr.
#
# Usage: bash scripts/setup-embree.sh && bash scripts/bench-embree.sh > table.md 2> raw.jsonl
# Environment: RAYS (default 1000000), REPS (3), THREADS ("1 2"),
#              CONFIGS ("car:16 blob:16 car:64 316:4": mesh (car, blob or grid size) and rate),
#              FLAGS (extra `limitray bench` flags, e.g. --no-shading-normals).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
RAYS="${RAYS:-1000000}"
REPS="${REPS:-3}"
CONFIGS="${CONFIGS:-car:16 blob:16 car:64 316:4}"
THREADS="${THREADS:-1 2}"
read -r -a FLAGS <<< "${FLAGS:-}"
CAR="$ROOT/../shared/models/opensubdiv/catmark_car.obj"
bash scripts/setup-embree.sh
cargo build --release --features embree --quiet
BIN="$ROOT/target/release/limitray"
PAIRED="$(mktemp)"
trap 'rm -f "$PAIRED"' EXIT

echo "| mesh | rate | threads | triangles | engine | build ms | coherent Mrays/s | incoherent Mrays/s | any-hit Mrays/s | bytes/triangle | build ×limitray | coherent ×limitray | incoherent ×limitray | any-hit ×limitray | leaks in place | leaks far |"
echo "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for config in $CONFIGS; do
    mesh="${config%%:*}"
    rate="${config##*:}"
    for t in $THREADS; do
        if [[ $mesh == car ]]; then
            args=("$CAR")
        elif [[ $mesh == blob ]]; then
            args=("$ROOT/scenes/meshes/blob.obj")
        else
            args=(--grid "$mesh")
        fi
        json="$("$BIN" bench "${args[@]}" --rate "$rate" --rays "$RAYS" --threads "$t" --reps "$REPS" --json "${FLAGS[@]}")"
        echo "$json" >&2
        python3 - "$mesh" "$json" "$PAIRED" <<'PY'
import json, statistics, sys
mesh = sys.argv[1]
rows = [json.loads(l) for l in sys.argv[2].splitlines() if l.strip()]
by = {e["engine"]: e for e in rows}
# Paired ratios: limitray's repetition r against the Embree engine's repetition r (the same
# round), for build time (limitray ÷ Embree: lower is faster) and rays (limitray ÷ Embree).
def paired(peer, key):
    a, b = by["limitray"]["samples"][key], by[peer]["samples"][key]
    r = [x / y for x, y in zip(a, b)]
    return "%.2f (%.2f–%.2f)" % (statistics.median(r), min(r), max(r))
e = rows[0]
name = {"car": "catmark_car", "blob": "blob.obj"}.get(mesh) or "grid %s" % mesh
with open(sys.argv[3], "a") as f:
    f.write("| %s r%d | %d | %s | %s | %s | %s | %s |\n" % (
        name, e["rate"], e["threads"],
        paired("embree-subdiv", "build_ms"), paired("embree-subdiv", "incoherent_mrays_s"),
        paired("embree-subdiv", "coherent_mrays_s"), paired("embree-subdiv", "anyhit_mrays_s"),
        paired("embree-triangles", "incoherent_mrays_s")))
base = rows[0]
for e in rows:
    name = {"car": "catmark_car", "blob": "blob.obj"}.get(mesh) or "grid %s (%d faces)" % (mesh, e["faces"])
    bpt = "%.1f" % e["bytes_per_triangle"] if e["bytes_per_triangle"] is not None else "-"
    # The reference intersector's far leaks that miss the limit surface itself (its rays aim
    # at f32 points of the far diced mesh, off the surface): `far_misses_off_surface`.
    off = e.get("far_misses_off_surface")
    far = "%d / %d" % (e["leaks_far"], e["leak_rays"]) + ("" if off is None else " (%d off the surface)" % off)
    print("| %s | %d | %d | %d | %s | %.1f | %.2f | %.2f | %.2f | %s | %.3f | %.2f | %.2f | %.2f | %d / %d | %s |" % (
        name, e["rate"], e["threads"], e["triangles"], e["engine"], e["build_ms"],
        e["coherent_mrays_s"], e["incoherent_mrays_s"], e["anyhit_mrays_s"], bpt,
        e["build_ms"] / base["build_ms"], e["coherent_mrays_s"] / base["coherent_mrays_s"],
        e["incoherent_mrays_s"] / base["incoherent_mrays_s"],
        e["anyhit_mrays_s"] / base["anyhit_mrays_s"],
        e["leaks"], e["leak_rays"], far))
PY
    done
done
echo
echo "Limitray ÷ Embree, paired by round: median of the rounds' ratios (lowest–highest)."
echo
echo "| mesh | threads | build ÷ subdiv | incoherent ÷ subdiv | coherent ÷ subdiv | any-hit ÷ subdiv | incoherent ÷ triangles |"
echo "|---|---:|---:|---:|---:|---:|---:|"
cat "$PAIRED"
