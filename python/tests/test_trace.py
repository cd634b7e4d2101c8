"""Surface.trace: every ray from inside a closed mesh hits; the answers are the CLI's."""

import threading
import time

import numpy as np
import pytest

import limitray


def unit_directions(n, seed):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


# Closed meshes and a point inside each (the centroid of the control points is inside for
# these convex-ish shapes; for the gear, the hub centre).
CLOSED = [("cube", (0.0, 0.0, 0.0)), ("creased_cube", (0.1, -0.2, 0.05)),
          ("prism", (0.0, 0.0, 0.0))]


@pytest.mark.parametrize("name,inside", CLOSED)
@pytest.mark.parametrize("exact", [False, True])
def test_every_ray_from_inside_a_closed_mesh_hits(meshes, name, inside, exact):
    s = limitray.Surface(meshes[name])
    n = 4000
    d = unit_directions(n, seed=7)
    o = np.tile(np.array(inside, dtype=np.float32), (n, 1))
    h = s.trace(o, d, rate=8, exact=exact)
    extra = {"err", "sharp", "grazing"} if exact else set()
    assert set(h) == {"hit", "t", "face", "k", "u", "v", "n"} | extra
    assert h["hit"].dtype == np.bool_ and h["hit"].shape == (n,)
    assert h["n"].shape == (n, 3)
    # Watertight dicing and a watertight triangle test: not one ray escapes.
    assert h["hit"].all(), f"{np.count_nonzero(~h['hit'])} of {n} rays escaped"
    assert np.all(h["t"] > 0) and np.all(np.isfinite(h["t"]))
    # In the face's domain.
    for c in ("u", "v"):
        assert np.all((h[c] >= 0) & (h[c] <= 1))
    # Unit normals facing away from an inside point: |n| = 1 to f32 rounding (1e-6).
    assert np.allclose(np.linalg.norm(h["n"], axis=1), 1.0, atol=1e-6)
    # The hit point lies on the limit surface at the reported (face, k, u, v). A diced hit's
    # (u, v) is interpolated across its triangle, so it is off by the dicing error: at rate 8
    # the largest seen is 2.0 % of the bounding-box diagonal (creased cube, at its sharp
    # corner), bounded here by 4 %. An exact hit is within its reported err, itself at most
    # 1e-12 of the diagonal unless the ray grazes (none of these rays from inside does).
    p = s.eval(h["face"], h["u"], h["v"], k=h["k"])["p"]
    x = o.astype(np.float64) + h["t"][:, None] * d.astype(np.float64)
    err = np.linalg.norm(p - x, axis=1)
    pts = s.refine(0)[0]
    diag = np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))
    assert err.max() < 0.04 * diag, err.max() / diag
    if exact:
        assert not h["grazing"].any()
        assert (h["err"] <= 1e-12).all(), h["err"].max()
        assert (err <= h["err"] * diag).all(), (err / diag - h["err"]).max()


def cli_trace(cli, mesh, o, d, rate, exact):
    stdin = "".join(
        " ".join(repr(float(c)) for c in (*oo, *dd)) + "\n" for oo, dd in zip(o, d)
    )
    args = ["trace", mesh, "--rate", rate] + (["--exact"] if exact else [])
    proc = cli(args, stdin)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.splitlines()


@pytest.mark.parametrize("exact", [False, True])
def test_trace_is_the_cli(cli, meshes, exact):
    s = limitray.Surface(meshes["gear8"])
    rng = np.random.default_rng(3)
    n = 500
    # Rays from a box around the gear towards points near it: hits and misses.
    o = rng.uniform(-3, 3, size=(n, 3)).astype(np.float32)
    target = rng.uniform(-1, 1, size=(n, 3)).astype(np.float32)
    d = (target - o).astype(np.float32)
    h = s.trace(o, d, rate=4, exact=exact)
    lines = cli_trace(cli, meshes["gear8"], o, d, 4, exact)
    assert len(lines) == n
    assert 0 < np.count_nonzero(h["hit"]) < n
    for i, line in enumerate(lines):
        tok = line.split()
        if tok[0] == "miss":
            assert not h["hit"][i]
            assert (len(tok) > 1) == bool(exact and h["grazing"][i]), line
            assert h["t"][i] == np.inf and h["face"][i] == -1
            continue
        assert tok[0] == "hit" and h["hit"][i]
        assert int(tok[2]) == h["face"][i] and int(tok[3]) == h["k"][i]
        vals = np.array([float(tok[1]), float(tok[4]), float(tok[5]), *map(float, tok[6:9])])
        got = np.array([h["t"][i], h["u"][i], h["v"][i], *h["n"][i]])
        if exact:
            # 17 significant digits read back to the same bits; then err, sharp, grazing.
            assert np.array_equal(vals, got), (line, got)
            assert float(tok[9]) == float(f"{h['err'][i]:.3e}"), line
            assert tok[10] == ("1" if h["sharp"][i] else "0"), line
            assert tok[11] == ("1" if h["grazing"][i] else "0"), line
        else:
            # f32 printed as round-trip f32 text; the package widens f32 exactly.
            assert np.array_equal(vals.astype(np.float32), got.astype(np.float32)), (line, got)
            assert np.array_equal(got.astype(np.float32).astype(np.float64), got)


def test_trace_accepts_float64_and_lists(meshes):
    s = limitray.Surface(meshes["cube"])
    a = s.trace([[0.0, 0.0, 0.0]], [[1.0, 0.2, 0.1]])
    b = s.trace(np.zeros((1, 3), dtype=np.float32), np.array([[1, 0.2, 0.1]], dtype=np.float32))
    for key in a:
        assert np.array_equal(a[key], b[key])


def test_geometry_only_trace_has_the_same_hits(meshes):
    # Built for tracing alone, the diced surface gives the same hits bit for bit, and a unit
    # normal.
    s = limitray.Surface(meshes["gear8"])
    n = 20_000
    o = np.zeros((n, 3))
    d = unit_directions(n, seed=9)
    a = s.trace(o, d, rate=16)
    b = s.trace(o, d, rate=16, shading_normals=False)
    assert a["hit"].sum() > n // 3
    for key in ["hit", "t", "face", "k", "u", "v"]:
        assert np.array_equal(a[key], b[key], equal_nan=True), key
    hit = a["hit"]
    length = np.linalg.norm(b["n"][hit], axis=1)
    assert np.all(np.abs(length - 1.0) < 1e-6), length
    assert np.all(np.isnan(b["n"][~hit]))


def test_geometry_only_normal_is_the_triangles(meshes):
    # Its normal is the diced triangle's: perpendicular to the step between the hits of two
    # rays 1e-3 apart (from the centre of the cube, at rate 4, whose triangles are ~0.2
    # across, so nearly all pairs land on one triangle). The hit points are float32 `t`
    # along the rays: about 6e-8 of a unit over a 1e-3 step, a cosine of about 1e-4 (the
    # median measured is 6e-5); a pair across a triangle's edge is off by the edge's kink.
    # The interpolated shading normal is not perpendicular (median measured 0.083).
    s = limitray.Surface(meshes["cube"])
    n = 20_000
    rng = np.random.default_rng(9)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d2 = d + 1e-3 * rng.normal(size=(n, 3))
    d2 /= np.linalg.norm(d2, axis=1, keepdims=True)
    o = np.zeros((n, 3))

    def cosines(shading_normals):
        a = s.trace(o, d, rate=4, shading_normals=shading_normals)
        b = s.trace(o, d2, rate=4, shading_normals=shading_normals)
        same = a["hit"] & b["hit"] & (a["face"] == b["face"]) & (a["k"] == b["k"])
        assert same.sum() > 0.99 * n
        step = (d2 * b["t"][:, None] - d * a["t"][:, None])[same]
        dot = np.abs(np.sum(step * a["n"][same], axis=1))
        return dot / np.linalg.norm(step, axis=1)

    geometric = cosines(False)
    assert np.median(geometric) < 5e-4, np.median(geometric)
    assert np.mean(geometric < 1e-3) > 0.95, np.mean(geometric < 1e-3)
    assert np.median(cosines(True)) > 0.02


def test_the_gil_is_released_while_tracing(meshes):
    s = limitray.Surface(meshes["gear8"])
    n = 400_000
    o = np.zeros((n, 3), dtype=np.float32)
    d = unit_directions(n, seed=5)
    s.trace(o[:10], d[:10], rate=8)  # build the BVH first
    done = threading.Event()
    span = {}

    def work():
        t0 = time.perf_counter()
        s.trace(o, d, rate=8)
        span["t"] = (t0, time.perf_counter())
        done.set()

    th = threading.Thread(target=work)
    stamps = []
    th.start()
    while not done.is_set():
        stamps.append(time.perf_counter())
    th.join()
    t0, t1 = span["t"]
    inside = [t for t in stamps if t0 <= t <= t1]
    # This thread kept running Python while the other traced: with the GIL held through the
    # call it could not have (its longest pause would be the whole call).
    assert t1 - t0 > 0.05, "the trace was too short to tell"
    gaps = np.diff([t0, *inside, t1])
    assert gaps.max() < 0.5 * (t1 - t0), (gaps.max(), t1 - t0)


def test_exact_hits_are_for_the_float64_rays(meshes):
    # The exact intersector answers for the rays as given (float64), not their float32
    # rounding: o + t d lies on the limit surface at the reported (face, k, u, v) within
    # 1e-12 of the creased cube's size (measured about 1e-15); for the float32-rounded rays
    # that point is 1e-9 to 1e-7 away.
    s = limitray.Surface(meshes["creased_cube"])
    rng = np.random.default_rng(11)
    n = 500
    o = rng.uniform(-0.3, 0.3, size=(n, 3))
    d = rng.normal(size=(n, 3))
    h = s.trace(o, d, rate=4, exact=True)
    ok = h["hit"]
    assert ok.all() and not h["grazing"].any()
    p = s.eval(h["face"][ok], h["u"][ok], h["v"][ok], k=h["k"][ok])["p"]
    q = o[ok] + h["t"][ok][:, None] * d[ok]
    assert np.abs(p - q).max() < 1e-12
    q32 = (o[ok].astype(np.float32).astype(np.float64)
           + h["t"][ok][:, None] * d[ok].astype(np.float32).astype(np.float64))
    assert np.abs(p - q32).max() > 1e-10


@pytest.mark.parametrize("fvar", ["all", "corners-plus1"])
def test_uv_is_the_cli(cli, tmp_path, fvar):
    """Surface.uv at the CLI's hits equals the `s t` that `trace --uv` appends, bit for bit;
    in mode `all` a cube whose faces each carry the unit square gives (s, t) = (u, v)."""
    text = "".join(f"v {(i & 1) * 2 - 1} {(i >> 1 & 1) * 2 - 1} {(i >> 2 & 1) * 2 - 1}\n"
                   for i in range(8))
    text += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    for f in [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]:
        text += "f " + " ".join(f"{v + 1}/{j + 1}" for j, v in enumerate(f)) + "\n"
    path = tmp_path / "cube_uv.obj"
    path.write_text(text)
    d = unit_directions(200, seed=11)
    stdin = "".join(f"0 0 0 {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in d)
    r = cli(["trace", path, "--uv", "--fvar", fvar, "--rate", "8"], stdin)
    assert r.returncode == 0, r.stderr
    rows = [line.split() for line in r.stdout.splitlines()]
    assert len(rows) == 200 and all(row[0] == "hit" for row in rows)
    face = np.array([int(row[2]) for row in rows])
    k = np.array([int(row[3]) for row in rows])
    u = np.array([float(row[4]) for row in rows])
    v = np.array([float(row[5]) for row in rows])
    st = np.array([[float(row[-2]), float(row[-1])] for row in rows])
    s = limitray.Surface(path, fvar=fvar)
    out = s.uv(face, u, v, k=k)
    assert set(out) == {"st", "du", "dv"} and out["st"].shape == (200, 2)
    assert np.array_equal(out["st"], st)
    if fvar == "all":
        # Bilinear corners (0,0), (1,0), (1,1), (0,1): the interpolation's rounding only.
        assert np.abs(out["st"] - np.stack([u, v], axis=1)).max() < 1e-15


def test_uv_needs_texture_coordinates(meshes):
    s = limitray.Surface(meshes["cube"])
    with pytest.raises(ValueError, match="no texture coordinates"):
        s.uv([0], [0.5], [0.5])
    with pytest.raises(ValueError, match="fvar 'sometimes'"):
        limitray.Surface(meshes["cube"], fvar="sometimes")
