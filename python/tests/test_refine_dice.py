"""Surface.refine and Surface.dice against the OBJ files `limitray refine` / `dice` write."""

import numpy as np
import pytest

import limitray


def parse_obj(text):
    """v, vn, vt rows (as float64 from the round-trip text) and f rows (0-based vertex
    indices, the `v` part of each `v/vt/vn`)."""
    v, vn, vt, f = [], [], [], []
    for line in text.splitlines():
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        if tok[0] == "v":
            v.append([float(x) for x in tok[1:]])
        elif tok[0] == "vn":
            vn.append([float(x) for x in tok[1:]])
        elif tok[0] == "vt":
            vt.append([float(x) for x in tok[1:]])
        elif tok[0] == "f":
            f.append([int(x.split("/")[0]) - 1 for x in tok[1:]])
    return v, vn, vt, f


@pytest.mark.parametrize(
    "name,level,limit,kwargs,args",
    [
        ("cube", 2, False, {}, []),
        ("creased_cube", 3, False, {}, []),
        ("creased_cube", 2, True, {"chaikin": True}, ["--chaikin"]),
        ("prism", 1, True, {}, []),
        ("grid", 2, False, {"boundary": "none"}, ["--boundary", "none"]),
        ("grid", 0, False, {}, []),
    ],
)
def test_refine_is_the_cli_obj(cli, meshes, name, level, limit, kwargs, args):
    s = limitray.Surface(meshes[name], **kwargs)
    pos, faces = s.refine(level, limit=limit)
    extra = ["--limit"] if limit else []
    proc = cli(["refine", meshes[name], "--level", level, *args, *extra, "-o", "-"])
    assert proc.returncode == 0, proc.stderr
    v, _, _, f = parse_obj(proc.stdout)
    assert pos.dtype == np.float64 and pos.shape == (len(v), 3)
    # `{:?}` of an f64 reads back exactly: the same bits.
    assert np.array_equal(pos, np.array(v))
    if isinstance(faces, list):
        assert [list(x) for x in faces] == f
    else:
        assert faces.shape[0] == len(f)
        assert np.array_equal(faces, np.array(f).reshape(faces.shape))
    if level >= 1:
        assert not isinstance(faces, list) and faces.shape[1] == 4


def test_refine_level_zero_of_mixed_faces_is_a_list(meshes):
    s = limitray.Surface(meshes["grid"])
    _, faces = s.refine(0)
    assert isinstance(faces, list) and [len(x) for x in faces] == [4] * 6 + [3]


@pytest.mark.parametrize("name,rate", [("cube", 4), ("prism", 3), ("creased_cube", 8),
                                       ("gear8", 2)])
def test_dice_is_the_cli_obj(cli, meshes, name, rate):
    s = limitray.Surface(meshes[name])
    pos, tri, params = s.dice(rate)
    proc = cli(["dice", meshes[name], "--rate", rate, "-o", "-"])
    assert proc.returncode == 0, proc.stderr
    v, vn, vt, f = parse_obj(proc.stdout)
    assert pos.dtype == np.float32 and pos.shape == (len(v), 3)
    assert tri.shape == (len(f), 3)
    # f32 values printed as round-trip f32 text: equal after rounding the text to f32.
    assert np.array_equal(pos, np.array(v, dtype=np.float32))
    assert np.array_equal(params["n"], np.array(vn, dtype=np.float32))
    uv = np.array(vt, dtype=np.float32)
    assert np.array_equal(params["u"].astype(np.float32), uv[:, 0])
    assert np.array_equal(params["v"].astype(np.float32), uv[:, 1])
    assert np.array_equal(tri, np.array(f))
    # Each vertex is the limit surface at its (face, k, u, v), rounded once to f32.
    p = s.eval(params["face"], params["u"], params["v"], k=params["k"])["p"]
    assert np.array_equal(p.astype(np.float32), pos)
    assert np.all(params["k"] < s.sub_faces()[params["face"]])


def test_dice_of_a_closed_mesh_is_closed(meshes):
    # Crack-free: faces dice separately (a vertex on a face edge is stored once per face), but
    # the copies are the same f32 points, so every edge, keyed by its two end points' bits,
    # is shared by exactly two triangles.
    s = limitray.Surface(meshes["creased_cube"])
    pos, tri, _ = s.dice(5)
    _, ids = np.unique(pos.view(np.uint32), axis=0, return_inverse=True)
    t = ids.reshape(-1)[tri]
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)


def test_displaced_dice_is_the_cli_obj_and_closed(cli, meshes):
    # displace= is --displace: the same f32 vertices and normals as `limitray dice`, moved off
    # the limit surface, and still closed (shared edge vertices are displaced once).
    s = limitray.Surface(meshes["creased_cube"], displace="noise:0.1:3")
    pos, tri, params = s.dice(6)
    proc = cli(["dice", meshes["creased_cube"], "--rate", 6, "--displace", "noise:0.1:3",
                "-o", "-"])
    assert proc.returncode == 0, proc.stderr
    v, vn, _, f = parse_obj(proc.stdout)
    assert np.array_equal(pos, np.array(v, dtype=np.float32))
    assert np.array_equal(params["n"], np.array(vn, dtype=np.float32))
    assert np.array_equal(tri, np.array(f))
    p = limitray.Surface(meshes["creased_cube"]).eval(params["face"], params["u"],
                                                       params["v"], k=params["k"])["p"]
    moved = np.linalg.norm(pos - p.astype(np.float32), axis=1)
    assert moved.max() > 0.05 and moved.max() < 0.1 * 1.1 + 1e-6
    _, ids = np.unique(pos.view(np.uint32), axis=0, return_inverse=True)
    t = ids.reshape(-1)[tri]
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)
    with pytest.raises(ValueError, match="displace"):
        s.trace(np.array([[0.0, 0.0, 5.0]]), np.array([[0.0, 0.0, -1.0]]), exact=True)
    with pytest.raises(ValueError, match="noise:AMPLITUDE:FREQUENCY"):
        limitray.Surface(meshes["creased_cube"], displace="bump:1")
