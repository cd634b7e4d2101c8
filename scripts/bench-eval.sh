#!/usr/bin/env bash
# Exact limit evaluation benchmark (criterion, benches/eval.rs): patch-table build time and
# evaluation throughput of 10,000 random (face, k, u, v) queries on catmark_car.obj with 1 and
# 2 rayon threads. Runs `cargo bench --bench eval` (about a minute after building; criterion's
# own report goes to stderr) and prints a markdown table of the medians on stdout, read from
# criterion's target/criterion/eval/*/*/new/{benchmark,estimates}.json of this run.
#
# Usage:
#   bash scripts/bench-eval.sh
#   bash scripts/bench-eval.sh -- --save-baseline before   # extra arguments go to criterion
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
[[ "${1:-}" == "--" ]] && shift

TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
touch "$TMP/start"
sleep 1 # file times may have a one-second resolution

cargo bench --bench eval -- "$@" >&2

DIR="${CARGO_TARGET_DIR:-$ROOT/target}/criterion/eval"
if [[ ! -d "$DIR" ]]; then
    echo "bench-eval: no results in $DIR (is ../shared/models/opensubdiv/catmark_car.obj missing?)" >&2
    exit 1
fi
find "$DIR" -path '*/new/estimates.json' -newer "$TMP/start" | sort >"$TMP/files"
if [[ ! -s "$TMP/files" ]]; then
    echo "bench-eval: criterion wrote no new results (catmark_car.obj missing?)" >&2
    exit 1
fi

python3 - "$TMP/files" <<'PY'
import json, os, sys

rows = []
for est in open(sys.argv[1]).read().split():
    d = os.path.dirname(est)
    bench = json.load(open(os.path.join(d, "benchmark.json")))
    e = json.load(open(est))
    med = e["median"]
    ns = med["point_estimate"]
    lo, hi = med["confidence_interval"]["lower_bound"], med["confidence_interval"]["upper_bound"]
    thr = bench.get("throughput") or {}
    elems = thr.get("Elements")
    row = [bench["full_id"], f"{ns / 1e6:.2f}", f"{lo / 1e6:.2f} – {hi / 1e6:.2f}"]
    if elems and bench["function_id"].startswith("eval"):
        row.append(f"{elems / (ns * 1e-9) / 1e6:.3f} M evals/s")
    else:
        row.append("")
    rows.append((0 if "table_build" in bench["full_id"] else 1, row))

print("| benchmark | median (ms / iteration) | 95 % CI of median (ms) | throughput at median |")
print("|---|---:|---:|---:|")
for _, r in sorted(rows):
    print("| " + " | ".join(r) + " |")
PY
