#!/usr/bin/env bash
# Paper 002's Table 3 redone (BENCHMARKS.md): `limitray approx-error` of the PN, Walton-Meek
# and Gregory approximations on the corpus's smooth closed Loop shapes, generated spindles with
# poles of valence 3-12 (examples/approx_meshes.rs) and the Stanford bunny
# (scripts/setup-bunny.sh), then the evaluation and tracing speed of each surface on the bunny
# (bench-eval, bench-trace). Prints markdown tables on stdout; the raw JSON lines go to
# target/approx/table.jsonl.
#
# Usage: bash scripts/approx-table.sh [SAMPLES]     (default 100000 points each way)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
SAMPLES="${1:-100000}"
MODELS="$ROOT/../shared/models/opensubdiv"
bash scripts/setup-bunny.sh >&2
cargo build --release >&2
cargo run --release --example approx_meshes -- target/approx >&2
BIN=target/release/limitray
OUT=target/approx/table.jsonl
: >"$OUT"
meshes=()
for s in loop_tetrahedron loop_cube loop_icosahedron loop_toroidal_tet loop_xord_interior loop_pole8 loop_pole64; do
    [[ -f "$MODELS/$s.obj" ]] && meshes+=("$MODELS/$s.obj")
done
for n in 3 4 5 6 7 8 10 12; do meshes+=("target/approx/spindle$n.obj"); done
meshes+=(target/bunny/bunny.obj)
for m in "${meshes[@]}"; do
    name="$(basename "$m" .obj)"
    "$BIN" approx-error "$m" --samples "$SAMPLES" --json \
        | python3 -c "import json,sys
for l in sys.stdin:
    d = json.loads(l); d['mesh'] = '$name'; print(json.dumps(d))" >>"$OUT"
done
for s in exact pn wm gregory; do
    "$BIN" bench-eval target/bunny/bunny.obj --scheme loop --surface "$s" --samples 200000 >>"$OUT"
    "$BIN" bench-trace target/bunny/bunny.obj --scheme loop --surface "$s" --rate 8 --rays 1000000 --reps 5 >>"$OUT"
done
python3 - "$OUT" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
err = [r for r in rows if "mesh" in r]
print("| mesh | surface | max | mean | rms | max_reverse | normal max (deg) | normal mean (deg) |")
print("|---|---|---|---|---|---|---|---|")
for r in err:
    print("| %s | %s | %.3e | %.3e | %.3e | %.3e | %.1f | %.2f |" % (r["mesh"], r["surface"], r["max"], r["mean"], r["rms"], r["max_reverse"], r["normal_max_deg"], r["normal_mean_deg"]))
print()
print("| surface | table build (ms) | evals/s | dice (ms) | coherent Mrays/s | incoherent Mrays/s | any-hit Mrays/s |")
print("|---|---|---|---|---|---|---|")
ev = [r for r in rows if "evals_per_s" in r]
tr = [r for r in rows if "incoherent_mrays_per_s" in r]
for e, t in zip(ev, tr):
    print("| %s | %.0f | %.3g | %.0f | %.2f | %.2f | %.2f |" % (e["surface"], t["table_ms"], e["evals_per_s"], t["dice_ms"], t["coherent_mrays_per_s"], t["incoherent_mrays_per_s"], t["incoherent_anyhit_mrays_per_s"]))
PY
