"""Loop meshes (``scheme="loop"``) and paper 002's approximations (``surface=...``) from
Python: evaluation, tracing and limit refinement give the CLI's answers bit for bit."""

import numpy as np
import pytest

import limitray
from conftest import ROOT, cli_error

BLOB = ROOT / "scenes" / "meshes" / "blob.obj"
SURFACES = ["exact", "pn", "wm", "gregory"]


def rows(text):
    return np.array([[float(x) for x in line.split()] for line in text.splitlines()])


@pytest.mark.parametrize("surface", SURFACES)
def test_eval_is_the_cli(cli, surface):
    s = limitray.Surface(BLOB, scheme="loop", surface=surface)
    rng = np.random.default_rng(5)
    n = 200
    face = rng.integers(0, s.num_faces, n)
    u = rng.uniform(0, 1, n)
    v = rng.uniform(0, 1, n) * (1 - u)
    out = s.eval(face, u, v)
    stdin = "".join(f"{int(f)} {float(a)!r} {float(b)!r}\n" for f, a, b in zip(face, u, v))
    proc = cli(["eval", BLOB, "--scheme", "loop", "--surface", surface], stdin)
    assert proc.returncode == 0, proc.stderr
    got = np.hstack([out["p"], out["du"], out["dv"]])
    assert np.array_equal(rows(proc.stdout), got)


@pytest.mark.parametrize("surface", SURFACES)
def test_trace_from_inside_hits_and_is_the_cli(cli, surface):
    s = limitray.Surface(BLOB, scheme="loop", surface=surface)
    rng = np.random.default_rng(8)
    n = 2000
    d = rng.normal(size=(n, 3)).astype(np.float32)
    o = np.zeros((n, 3), dtype=np.float32)
    h = s.trace(o, d, rate=4)
    # Watertight: the blob is closed around the origin.
    assert h["hit"].all(), f"{np.count_nonzero(~h['hit'])} of {n} rays escaped"
    # Hits are in the triangle's own parameter, k = 0.
    assert np.all(h["k"] == 0)
    assert np.all(h["u"] >= 0) and np.all(h["v"] >= 0) and np.all(h["u"] + h["v"] <= 1 + 1e-12)
    stdin = "".join(f"0 0 0 {float(a)!r} {float(b)!r} {float(c)!r}\n" for a, b, c in d)
    proc = cli(["trace", BLOB, "--scheme", "loop", "--surface", surface, "--rate", "4"], stdin)
    assert proc.returncode == 0, proc.stderr
    for i, line in enumerate(proc.stdout.splitlines()):
        tok = line.split()
        assert tok[0] == "hit" and int(tok[2]) == h["face"][i] and tok[3] == "0", line
        assert float(tok[1]) == np.float32(h["t"][i])
        assert float(tok[4]) == h["u"][i] and float(tok[5]) == h["v"][i], line


def test_exact_trace_is_the_cli_and_on_the_surface(cli):
    s = limitray.Surface(BLOB, scheme="loop")
    rng = np.random.default_rng(11)
    n = 300
    d = rng.normal(size=(n, 3))
    o = np.zeros((n, 3))
    h = s.trace(o, d, exact=True)
    # The blob is closed around the origin: every ray hits, in the triangle's own (u, v).
    assert h["hit"].all()
    assert np.all(h["k"] == 0) and np.all(h["u"] + h["v"] <= 1 + 1e-12)
    # On the exact surface at the reported parameters (1e-12 of the diagonal, the reference
    # intersector's bound; the blob's diagonal is about 3).
    at = s.eval(h["face"], h["u"], h["v"])
    gap = np.linalg.norm(o + h["t"][:, None] * d - at["p"], axis=1)
    assert gap.max() < 3e-12, gap.max()
    stdin = "".join(f"0 0 0 {float(a)!r} {float(b)!r} {float(c)!r}\n" for a, b, c in d)
    proc = cli(["trace", BLOB, "--scheme", "loop", "--exact"], stdin)
    assert proc.returncode == 0, proc.stderr
    for i, line in enumerate(proc.stdout.splitlines()):
        tok = line.split()
        assert tok[0] == "hit" and int(tok[2]) == h["face"][i] and tok[3] == "0", line
        # The CLI prints 17 significant digits: the same f64.
        assert float(tok[1]) == h["t"][i] and float(tok[4]) == h["u"][i], line


def test_limit_refinement_is_the_cli(cli, tmp_path):
    s = limitray.Surface(BLOB, scheme="loop")
    pos, faces = s.refine(1, limit=True)
    out = tmp_path / "r.obj"
    proc = cli(["refine", BLOB, "--scheme", "loop", "--level", "1", "--limit", "-o", out])
    assert proc.returncode == 0, proc.stderr
    text = out.read_text().splitlines()
    v = np.array([[float(x) for x in l.split()[1:]] for l in text if l.startswith("v ")])
    f = np.array([[int(x) - 1 for x in l.split()[1:]] for l in text if l.startswith("f ")])
    assert np.array_equal(v, pos) and np.array_equal(f, faces)
    assert faces.shape == (4 * s.num_faces, 3)


def test_loop_errors_are_the_cli(cli, meshes):
    with pytest.raises(ValueError) as e:
        limitray.Surface(meshes["cube"], scheme="loop")
    assert "triangles" in str(e.value)
    with pytest.raises(ValueError, match="approximates Loop meshes"):
        limitray.Surface(BLOB, surface="pn")
    with pytest.raises(ValueError, match="unknown surface 'bezier'|unknown surface `bezier`"):
        limitray.Surface(BLOB, scheme="loop", surface="bezier")
    with pytest.raises(ValueError, match="scheme 'bilinear' is not one of"):
        limitray.Surface(BLOB, scheme="bilinear")
    proc = cli(["dice", BLOB, "--surface", "wm", "-o", "-"])
    assert "approximates Loop meshes" in cli_error(proc)


def test_catmark_gregory_is_the_cli(cli, meshes):
    # Paper 004's Gregory patches of a Catmull-Clark mesh (pentagons, quads, a semi-sharp
    # crease): eval and trace give the CLI's numbers.
    path = meshes["prism"]
    s = limitray.Surface(path, surface="gregory")
    rng = np.random.default_rng(2)
    n = 100
    face = rng.integers(0, s.num_faces, n)
    k = np.array([rng.integers(0, m) for m in s.sub_faces()[face]])
    u, v = rng.uniform(0, 1, n), rng.uniform(0, 1, n)
    out = s.eval(face, u, v, k=k)
    stdin = "".join(f"{int(f)} {int(kk)} {float(a)!r} {float(b)!r}\n" for f, kk, a, b in zip(face, k, u, v))
    proc = cli(["eval", path, "--surface", "gregory"], stdin)
    assert proc.returncode == 0, proc.stderr
    assert np.array_equal(rows(proc.stdout), np.hstack([out["p"], out["du"], out["dv"]]))
    exact = limitray.Surface(path).eval(face, u, v, k=k)
    # Close to the exact surface, not equal to it (the prism is coarse: within 5%).
    gap = np.linalg.norm(out["p"] - exact["p"], axis=1)
    assert 0 < gap.max() < 0.05 * 2.6
    o = np.zeros((500, 3), dtype=np.float32)
    d = rng.normal(size=(500, 3)).astype(np.float32)
    h = s.trace(o, d, rate=4)
    assert h["hit"].all()
    with pytest.raises(ValueError, match="not an approximation"):
        s.trace(o, d, exact=True)
