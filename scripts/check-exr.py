#!/usr/bin/env python3
"""Independent check of a limitray EXR with the reference OpenEXR library (pip `OpenEXR`).

    scripts/check-exr.py OUT.exr

Checks that every documented channel is present as 32-bit float with the image's size, that
misses have faceid = level = -1 and Z = inf, and prints the mean of R, G, B. Exit code 1 on a
failed check, 77 when the OpenEXR module is not installed (a skip).
"""
import math
import sys

try:
    import OpenEXR
except ImportError:
    print("OpenEXR Python module not installed (pip install OpenEXR); skipping", file=sys.stderr)
    sys.exit(77)

CHANNELS = ["R", "G", "B", "A", "Z", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B",
            "faceid", "level"]


def main(path):
    f = OpenEXR.File(path, separate_channels=True)
    header = f.header()
    (x0, y0), (x1, y1) = header["dataWindow"]
    w, h = x1 - x0 + 1, y1 - y0 + 1
    chans = f.channels()
    missing = [c for c in CHANNELS if c not in chans]
    if missing:
        print(f"{path}: missing channels {missing}; have {sorted(chans)}", file=sys.stderr)
        return 1
    for name in CHANNELS:
        px = chans[name].pixels
        if px.shape != (h, w) or px.dtype.name != "float32":
            print(f"{path}: channel {name} is {px.dtype} {px.shape}, want float32 ({h}, {w})",
                  file=sys.stderr)
            return 1
    miss = chans["faceid"].pixels < 0
    if miss.any():
        if not (chans["level"].pixels[miss] == -1).all():
            print(f"{path}: a miss has level != -1", file=sys.stderr)
            return 1
        if not all(math.isinf(z) for z in chans["Z"].pixels[miss].ravel()[:1000]):
            print(f"{path}: a miss has finite Z", file=sys.stderr)
            return 1
    means = [float(chans[c].pixels.mean()) for c in "RGB"]
    print(f"{path}: {w}x{h}, {len(chans)} channels OK, mean RGB "
          f"{means[0]:.6f} {means[1]:.6f} {means[2]:.6f}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
