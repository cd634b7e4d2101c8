#!/usr/bin/env bash
# Reproduces paper 000's Figure 2 (memory against sharpness on the Car model) with
# `limitray stats`: for every sharpness S, all creases of catmark_car.obj are set to S and the
# patch table is built with single-crease patches (paper 000) and with subdivision only
# (`--no-single-crease`, feature-adaptive subdivision as in [NLMD12]), both at the default
# maximum level 10. Prints markdown tables on stdout; the raw JSON goes to stderr, prefixed
# with `json:`.
#
# Subdivision only isolates a crease of sharpness S down to level ceil(S); with S <= max level
# that is complete (no end caps beyond the extraordinary vertices', which the "end caps"
# column shows: it stays at its S = 0 value). At S > max level the subdivision-only table is
# capped: isolation stops at the max level and the crease faces left there become (exact,
# on-demand) end caps. The default max level 10 covers every semi-sharp S (sharpness >= 10 is
# infinitely sharp and needs no isolation); with a smaller MAX_LEVEL and some S in
# (MAX_LEVEL, 10), the subdivision-only variant is also run at --max-level ceil(S), the level
# that isolates the crease completely (extra columns). A second table repeats the sweep at
# --max-level CAP_LEVEL (default 4) to show the capping.
#
# Usage:
#   bash scripts/figure2.sh
#   REPS=5 SHARPNESS="0 2 4 6 8 12" MAX_LEVEL=10 CAP_LEVEL=4 MESH=path.obj bash scripts/figure2.sh
#
# build ms = the median over REPS runs of `stats`' build_ms (PatchTable construction, one
# process per run, single-threaded parts and rayon parts on all cores).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
MESH="${MESH:-$ROOT/../shared/models/opensubdiv/catmark_car.obj}"
REPS="${REPS:-3}"
MAX_LEVEL="${MAX_LEVEL:-10}"
CAP_LEVEL="${CAP_LEVEL:-4}"
SHARPNESS="${SHARPNESS:-0 1 2 3 4 5 6 7 8}"

if [[ ! -f "$MESH" ]]; then
    echo "figure2: $MESH not found" >&2
    exit 1
fi
cargo build --release >&2
LIMITRAY="$ROOT/target/release/limitray"

TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

# run TAG S LEVEL [--no-single-crease]: REPS runs of `stats`, JSON lines into $TMP/TAG.
run() {
    local tag="$1" s="$2" level="$3"
    shift 3
    for ((r = 0; r < REPS; r++)); do
        "$LIMITRAY" stats "$MESH" --sharpness "$s" --max-level "$level" "$@" \
            | python3 -c 'import json, sys; print(json.dumps(json.load(sys.stdin)))' \
            >>"$TMP/$tag"
        echo "json: $tag $(tail -n 1 "$TMP/$tag")" >&2
    done
}

for s in $SHARPNESS; do
    full="$(python3 -c "import math; print(max(1, math.ceil(float('$s'))))")"
    echo "figure2: S = $s" >&2
    run "sc.$s" "$s" "$MAX_LEVEL"
    run "sd.$s" "$s" "$MAX_LEVEL" --no-single-crease
    if ((full > MAX_LEVEL)) && python3 -c "import sys; sys.exit(float('$s') >= 10)"; then
        run "full.$s" "$s" "$full" --no-single-crease
    fi
    run "capsc.$s" "$s" "$CAP_LEVEL"
    run "capsd.$s" "$s" "$CAP_LEVEL" --no-single-crease
done

python3 - "$TMP" "$MAX_LEVEL" "$CAP_LEVEL" "$MESH" $SHARPNESS <<'PY'
import json, math, os, statistics, sys

tmp, max_level, cap_level, mesh = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
svals = sys.argv[5:]

def load(tag):
    path = os.path.join(tmp, tag)
    if not os.path.exists(path):
        return None
    runs = [json.loads(l) for l in open(path) if l.strip()]
    first = runs[0]
    for r in runs[1:]:
        assert r["patches_total"] == first["patches_total"], tag
    first["build_ms_median"] = statistics.median(r["build_ms"] for r in runs)
    return first

def caps(d):
    return d["patches_by_type"].get("end_cap", 0)

def mb(d):
    return f"{d['bytes_total'] / 1e6:.1f}"

def table(header, rows):
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---:" for _ in header) + "|")
    for r in rows:
        print("| " + " | ".join(r) + " |")

any_full = any(load(f"full.{s}") for s in svals)
print(f"Patch table of {os.path.basename(mesh)}, all creases set to sharpness S, "
      f"--max-level {max_level} (MB = 10^6 bytes; build ms = median of runs)\n")
header = ["S", "patches (single-crease)", "MB (single-crease)", "build ms (single-crease)",
          "patches (subdivision only)", "MB (subdivision only)", "build ms (subdivision only)",
          "patches ratio", "end caps (single-crease / subdivision only)"]
if any_full:
    header += ["subdivision only at --max-level ceil(S): level", "patches", "MB", "end caps"]
rows = []
for s in svals:
    sc, sd = load(f"sc.{s}"), load(f"sd.{s}")
    row = [s, f"{sc['patches_total']:,}", mb(sc), f"{sc['build_ms_median']:.0f}",
           f"{sd['patches_total']:,}", mb(sd), f"{sd['build_ms_median']:.0f}",
           f"{sd['patches_total'] / sc['patches_total']:.2f}", f"{caps(sc):,} / {caps(sd):,}"]
    if any_full:
        full = load(f"full.{s}")
        if full:
            row += [str(full["max_level"]), f"{full['patches_total']:,}", mb(full),
                    f"{caps(full):,}"]
        else:
            row += [f"(= {max_level}, complete)", "", "", ""]
    rows.append(row)
table(header, rows)

print(f"\nCapped: the same sweep at --max-level {cap_level}; subdivision only stops isolating "
      f"at level {cap_level}, so for S > {cap_level} its crease faces end in end caps\n")
rows = []
for s in svals:
    sc, sd = load(f"capsc.{s}"), load(f"capsd.{s}")
    rows.append([s, f"{sc['patches_total']:,}", mb(sc), f"{caps(sc):,}",
                 f"{sd['patches_total']:,}", mb(sd), f"{caps(sd):,}"])
table(["S", "patches (single-crease)", "MB (single-crease)", "end caps (single-crease)",
       "patches (subdivision only)", "MB (subdivision only)", "end caps (subdivision only)"],
      rows)
PY
