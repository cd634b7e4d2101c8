"""Surface.eval against `limitray eval`: the same f64 bits, sample for sample."""

import numpy as np
import pytest

import limitray

# (mesh, Surface keyword arguments, the same options on the command line)
CASES = [
    ("cube", {}, []),
    ("creased_cube", {}, []),
    ("creased_cube", {"chaikin": True, "max_level": 6}, ["--chaikin", "--max-level", "6"]),
    ("prism", {}, []),
    ("prism", {"smooth_triangles": True}, ["--smooth-triangles"]),
    ("grid", {"boundary": "edge"}, ["--boundary", "edge"]),
    ("grid", {"boundary": "corner"}, ["--boundary", "corner"]),
    ("gear8", {"max_level": 4}, ["--max-level", "4"]),
]


def samples(surface, per_face, seed):
    """(face, k, u, v) on every sub-face: its corners, edge midpoints, centre, and random."""
    rng = np.random.default_rng(seed)
    fixed = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5)]
    faces, ks, us, vs = [], [], [], []
    for f, n in enumerate(surface.sub_faces()):
        for k in range(n):
            uv = fixed + [tuple(x) for x in rng.random((per_face, 2))]
            for u, v in uv:
                faces.append(f)
                ks.append(k)
                us.append(u)
                vs.append(v)
    return np.array(faces), np.array(ks), np.array(us), np.array(vs)


def cli_eval(cli, mesh, args, face, k, u, v):
    # repr() is the shortest text that reads back as the same double (Rust parses it so too).
    stdin = "".join(
        f"{f} {kk} {float(uu)!r} {float(vv)!r}\n" for f, kk, uu, vv in zip(face, k, u, v)
    )
    proc = cli(["eval", mesh, *args], stdin)
    assert proc.returncode == 0, proc.stderr
    # Rust's `{:?}` of an f64 is also a round-trip text: float() gives back the bits.
    rows = [[float(x) for x in line.split()] for line in proc.stdout.splitlines()]
    return np.array(rows, dtype=np.float64).reshape(-1, 9)


@pytest.mark.parametrize("name,kwargs,args", CASES)
def test_eval_is_the_cli_bit_for_bit(cli, meshes, name, kwargs, args):
    s = limitray.Surface(meshes[name], **kwargs)
    face, k, u, v = samples(s, per_face=6, seed=len(name))
    out = s.eval(face, u, v, k=k)
    assert set(out) == {"p", "du", "dv"}
    for key in out:
        assert out[key].shape == (len(face), 3) and out[key].dtype == np.float64
    want = cli_eval(cli, meshes[name], args, face, k, u, v)
    got = np.hstack([out["p"], out["du"], out["dv"]])
    # Bit for bit: the same f64 values (array_equal on the raw bits, so -0.0 != 0.0 too).
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))


def test_eval_defaults_and_broadcasting(meshes):
    s = limitray.Surface(meshes["prism"])
    # k defaults to 0; scalars broadcast against arrays.
    u = np.linspace(0.0, 1.0, 11)
    a = s.eval(2, u, 0.25)
    b = s.eval(np.full(11, 2), u, np.full(11, 0.25), k=np.zeros(11, dtype=np.int64))
    for key in a:
        assert np.array_equal(a[key], b[key])
    one = s.eval(0, 0.5, 0.5, k=3)
    assert one["p"].shape == (1, 3)
    # Python ints of any width and unsigned arrays are indices too.
    c = s.eval(np.array([2], dtype=np.uint8), [0.1], [0.25])
    assert np.array_equal(c["p"][0], s.eval(2, 0.1, 0.25)["p"][0])


def test_eval_of_no_samples(meshes):
    s = limitray.Surface(meshes["cube"])
    out = s.eval(np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0))
    assert out["p"].shape == (0, 3)


def test_shared_corner_of_adjacent_faces_agrees(meshes):
    # Two faces of the cube meeting at vertex 1 (0-based): their limit points there are the
    # same point; across faces the evaluation paths differ, so allow a few ulps of the unit
    # cube (1e-15) rather than demand equal bits.
    s = limitray.Surface(meshes["cube"])
    p = s.eval([0, 3], [1.0, 1.0], [0.0, 1.0])["p"]
    assert np.max(np.abs(p[0] - p[1])) < 1e-15
