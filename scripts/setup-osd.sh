#!/usr/bin/env bash
# Install OpenSubdiv (Debian's libosd-dev) and g++, then build the reference
# benchmark benches/osd/osd_refine_bench.cpp into target/osd/osd_refine_bench and the
# differential-test oracle benches/osd/osd_oracle.cpp into target/osd/osd_oracle.
#
# Idempotent: packages already installed are not touched (apt-get update runs
# only when something is missing) and the binary is rebuilt only when the
# source is newer than it (or when FORCE=1).
#
# Meant for Debian 12 as root (no sudo). Usage:
#   bash scripts/setup-osd.sh
#   target/osd/osd_refine_bench MESH.obj LEVEL [--chaikin] [--reps N] [--dump OUT.obj]
#   target/osd/osd_refine_bench --grid N LEVEL ...
#   target/osd/osd_oracle MESH.obj [--refine N] [--eval] < samples
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUTDIR="$ROOT/target/osd"
BIN="$OUTDIR/osd_refine_bench"

is_installed() {
    dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q '^install ok installed$'
}

missing=()
for pkg in libosd-dev g++; do
    if ! is_installed "$pkg"; then
        missing+=("$pkg")
    fi
done

if ((${#missing[@]} > 0)); then
    if [[ $(id -u) -ne 0 ]]; then
        echo "setup-osd: need root to install: ${missing[*]}" >&2
        exit 1
    fi
    echo "setup-osd: installing ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update
    apt-get install -y --no-install-recommends "${missing[@]}"
else
    echo "setup-osd: libosd-dev and g++ already installed" >&2
fi

# libosd-dev ships libosdCPU.so (Far/Vtr/Sdc/Bfr and the CPU Osd evaluators)
# and libosdGPU.so. Only the CPU library is needed here.
if ! ldconfig -p | grep -q 'libosdCPU\.so '; then
    # Fall back to looking in the package's file list.
    if ! dpkg -L libosd-dev | grep -q 'libosdCPU\.so$'; then
        echo "setup-osd: libosdCPU.so not found in libosd-dev" >&2
        exit 1
    fi
fi

mkdir -p "$OUTDIR"
build() {
    local src="$ROOT/benches/osd/$1.cpp" bin="$OUTDIR/$1"
    local header="$ROOT/benches/osd/osd_mesh.h"
    if [[ "${FORCE:-0}" == 1 || ! -x "$bin" || "$src" -nt "$bin" || "$header" -nt "$bin" ||
          "${BASH_SOURCE[0]}" -nt "$bin" ]]; then
        echo "setup-osd: building $bin" >&2
        g++ -std=c++17 -O2 -DNDEBUG -Wall -Wextra -o "$bin.tmp" "$src" -losdCPU
        mv -f "$bin.tmp" "$bin"
    else
        echo "setup-osd: $bin is up to date" >&2
    fi
}
build osd_oracle
build osd_refine_bench
# Last line: the benchmark binary (scripts/bench-refine.sh reads it).
echo "$BIN"
