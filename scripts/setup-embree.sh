#!/usr/bin/env bash
# Fetch Embree 4.4 for the `embree` cargo feature.
#
# Debian ships only Embree 3, so the library comes from PyPI's `embreex==4.4.0.post1` wheel
# (CPython 3.11, manylinux x86_64), which bundles `libembree4-<hash>.so.4` and its `libtbb`.
# The wheel is downloaded with pip (no install, no dependencies), checked against a pinned
# sha256, and the two shared libraries are extracted into `.embree/lib/` (git-ignored) with a
# `libembree4.so` symlink for the linker. build.rs adds `-L .embree/lib -lembree4` and an rpath,
# so nothing is needed at run time.
#
# Idempotent: when `.embree/lib` already holds the libraries of the pinned wheel it does nothing.
# FORCE=1 re-extracts. The wheel carries no C headers; the FFI in src/embree/ffi.rs is written
# from Embree 4.4's documented API, with struct sizes asserted in tests/embree.rs.
#
# Usage: bash scripts/setup-embree.sh
#        cargo test --release --features embree --test embree
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEST="$ROOT/.embree"
LIB="$DEST/lib"
WHL_DIR="$DEST/whl"
VERSION="4.4.0.post1"
WHEEL="embreex-${VERSION}-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl"
SHA256="2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f"
STAMP="$LIB/.wheel-sha256"

if [[ "${FORCE:-0}" != 1 && -f "$STAMP" && "$(cat "$STAMP")" == "$SHA256" && -e "$LIB/libembree4.so" ]]; then
    echo "setup-embree: $LIB is up to date" >&2
    exit 0
fi

if [[ "$(uname -s)-$(uname -m)" != "Linux-x86_64" ]]; then
    echo "setup-embree: only Linux x86_64 is supported (this is $(uname -s)-$(uname -m))" >&2
    exit 1
fi

PY="${PYTHON:-python3}"
mkdir -p "$WHL_DIR" "$LIB"

check() {
    [[ -f "$WHL_DIR/$WHEEL" ]] && echo "$SHA256  $WHL_DIR/$WHEEL" | sha256sum --check --status
}

if ! check; then
    rm -f "$WHL_DIR/$WHEEL"
    echo "setup-embree: downloading $WHEEL" >&2
    # The platform/ABI options pick the same wheel whatever python3 runs pip.
    "$PY" -m pip download --quiet --no-deps --only-binary=:all: \
        --platform manylinux_2_28_x86_64 --python-version 3.11 --implementation cp --abi cp311 \
        --dest "$WHL_DIR" "embreex==$VERSION"
    if ! check; then
        echo "setup-embree: sha256 of $WHL_DIR/$WHEEL does not match the pinned $SHA256" >&2
        exit 1
    fi
fi

# Extract only the two libraries (embreex.libs/libembree4-*.so.4, embreex.libs/libtbb-*.so*).
rm -f "$LIB"/libembree4* "$LIB"/libtbb* "$STAMP"
"$PY" - "$WHL_DIR/$WHEEL" "$LIB" <<'EOF'
import os, re, sys, zipfile
wheel, dest = sys.argv[1], sys.argv[2]
found = []
with zipfile.ZipFile(wheel) as z:
    for name in z.namelist():
        base = os.path.basename(name)
        if re.fullmatch(r"libembree4[^/]*\.so\.4", base) or re.fullmatch(r"libtbb[^/]*\.so[.0-9]*", base):
            with z.open(name) as src, open(os.path.join(dest, base), "wb") as out:
                out.write(src.read())
            os.chmod(os.path.join(dest, base), 0o755)
            found.append(base)
embree = [f for f in found if f.startswith("libembree4")]
if len(embree) != 1 or not any(f.startswith("libtbb") for f in found):
    sys.exit("setup-embree: the wheel does not hold one libembree4 and a libtbb: %r" % found)
os.symlink(embree[0], os.path.join(dest, "libembree4.so"))
print("setup-embree: extracted " + ", ".join(sorted(found)), file=sys.stderr)
EOF
echo "$SHA256" >"$STAMP"
echo "setup-embree: ready in $LIB" >&2
