#!/usr/bin/env bash
# Compare limitray's table-driven refinement with OpenSubdiv's (Far, CPU, single-threaded).
#
# Builds limitray (release) and the OpenSubdiv reference program (scripts/setup-osd.sh), then
# for each case runs `limitray bench-refine` with 1 and 2 threads and
# target/osd/osd_refine_bench in the same run, and prints two markdown tables (table build,
# apply) on stdout. The raw JSON lines go to stderr, prefixed with `json:`.
#
# Cases: catmark_car.obj at level 4 (skipped with a warning when the shared models are
# missing) and the 317 x 317 grid (100,489 quads) at level 2.
#
# Usage:
#   bash scripts/bench-refine.sh                  # REPS=5 repetitions, medians
#   REPS=9 CAR=path/to/catmark_car.obj bash scripts/bench-refine.sh
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
REPS="${REPS:-5}"
CAR="${CAR:-$ROOT/../shared/models/opensubdiv/catmark_car.obj}"

cargo build --release >&2
OSD="$(bash scripts/setup-osd.sh | tail -n 1)"
LIMITRAY="$ROOT/target/release/limitray"

TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

# run_case NAME LEVEL LIMITRAY-MESH-ARGS... -- OSD-MESH-ARGS...
run_case() {
    local name="$1" level="$2"
    shift 2
    local ours=() osd=()
    while [[ $# -gt 0 && "$1" != "--" ]]; do ours+=("$1"); shift; done
    shift
    osd=("$@")
    echo "bench-refine: $name level $level" >&2
    for t in 1 2; do
        "$LIMITRAY" bench-refine "${ours[@]}" --level "$level" --threads "$t" --reps "$REPS" \
            >"$TMP/$name.t$t.json"
        echo "json: $(cat "$TMP/$name.t$t.json")" >&2
    done
    "$OSD" "${osd[@]}" "$level" --reps "$REPS" >"$TMP/$name.osd.json"
    echo "json: $(cat "$TMP/$name.osd.json")" >&2
    echo "$name" >>"$TMP/cases"
}

: >"$TMP/cases"
if [[ -f "$CAR" ]]; then
    run_case car 4 "$CAR" -- "$CAR"
else
    echo "bench-refine: $CAR not found, skipping the car" >&2
fi
run_case grid 2 --grid 317 -- --grid 317

python3 - "$TMP" <<'EOF'
import json, sys, os

tmp = sys.argv[1]
names = open(os.path.join(tmp, "cases")).read().split()

def load(name, suffix):
    with open(os.path.join(tmp, f"{name}.{suffix}.json")) as f:
        return json.loads(f.read())

def mvps(x):
    return f"{x / 1e6:.1f}"

rows_build, rows_apply = [], []
for name in names:
    t1, t2, osd = load(name, "t1"), load(name, "t2"), load(name, "osd")
    if t1["refined_vertices"] != osd["refined_vertices"]:
        sys.exit(f"{name}: refined vertex counts differ: "
                 f"{t1['refined_vertices']} vs {osd['refined_vertices']}")
    head = [str(t1["mesh"]), str(t1["level"]), f"{t1['refined_vertices']:,}"]
    ob = osd["table_build_ms"]
    rows_build.append(head + [
        f"{t1['table_build_ms']:.1f}", f"{t2['table_build_ms']:.1f}",
        f"{ob:.1f}", f"{osd['topology_refine_ms']:.1f}", f"{osd['refiner_create_ms']:.1f}",
        f"{t1['table_build_ms'] / ob:.2f}", f"{t2['table_build_ms'] / ob:.2f}",
    ])
    sv, pv = osd["vertices_per_s"], osd["primvar_vertices_per_s"]
    rows_apply.append(head + [
        mvps(t1["vertices_per_s"]), mvps(t2["vertices_per_s"]), mvps(sv), mvps(pv),
        f"{t1['vertices_per_s'] / sv:.2f}", f"{t2['vertices_per_s'] / sv:.2f}",
        f"{t1['vertices_per_s'] / pv:.2f}", f"{t2['vertices_per_s'] / pv:.2f}",
    ])

def table(header, rows):
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---" if i < 1 else "---:" for i in range(len(header))) + "|")
    for r in rows:
        print("| " + " | ".join(r) + " |")

print("Table build (ms, median; lower is better; ratio = ours / OSD table build)\n")
table(["mesh", "level", "refined vertices", "limitray 1T", "limitray 2T",
       "OSD table build", "OSD topology refine", "OSD refiner create",
       "ratio 1T", "ratio 2T"], rows_build)
print()
print("Apply (million refined vertices/s, median; higher is better; ratio = ours / OSD)\n")
table(["mesh", "level", "refined vertices", "limitray 1T", "limitray 2T",
       "OSD stencils", "OSD PrimvarRefiner", "1T / stencils", "2T / stencils",
       "1T / Primvar", "2T / Primvar"], rows_apply)
EOF
