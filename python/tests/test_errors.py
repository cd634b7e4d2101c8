"""Bad input raises Python exceptions carrying the CLI's messages."""

import numpy as np
import pytest

import limitray

from conftest import cli_error


def test_missing_file_is_an_oserror_with_the_cli_message(cli, tmp_path):
    path = tmp_path / "nope.obj"
    want = cli_error(cli(["eval", path]))
    with pytest.raises(OSError) as e:
        limitray.Surface(path)
    assert str(e.value) == want
    assert str(path) in want


@pytest.mark.parametrize(
    "text",
    [
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n",  # vertex index out of range
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nt crease 2/1 0 1 -3\n",  # bad sharpness
        "v 0 0 zero\n",  # not a number
        "v 0 0 0\nv 1 0 0\nf 1 2\n",  # a face of two vertices
    ],
)
def test_bad_obj_is_a_valueerror_with_the_cli_message(cli, tmp_path, text):
    path = tmp_path / "bad.obj"
    path.write_text(text)
    want = cli_error(cli(["eval", path], ""))
    with pytest.raises(ValueError) as e:
        limitray.Surface(path)
    assert str(e.value) == want
    # The message names the file (and the line, for a line's error).
    assert "bad.obj" in want


def cli_line_error(cli, mesh, line):
    proc = cli(["eval", mesh], line + "\n")
    assert proc.returncode == 2
    first = proc.stderr.splitlines()[0]
    assert first.startswith("stdin:1: "), proc.stderr
    return first[len("stdin:1: "):]


@pytest.mark.parametrize(
    "face,k,u,v",
    [(99, 0, 0.5, 0.5), (2, 1, 0.5, 0.5), (0, 5, 0.5, 0.5), (1, 0, 1.5, 0.5),
     (1, 0, 0.5, -0.25)],
)
def test_bad_samples_raise_the_cli_message(cli, meshes, face, k, u, v):
    s = limitray.Surface(meshes["prism"])
    want = cli_line_error(cli, meshes["prism"], f"{face} {k} {u!r} {v!r}")
    # Sample 2 of three: the message names it as the CLI names the line.
    with pytest.raises(ValueError) as e:
        s.eval([0, 1, face], [0.5, 0.5, u], [0.5, 0.5, v], k=[0, 0, k])
    assert str(e.value) == f"sample 2: {want}"


def test_a_hole_is_an_error_with_the_cli_message(cli, meshes):
    s = limitray.Surface(meshes["grid"], boundary="none")
    proc = cli(["eval", meshes["grid"], "--boundary", "none"], "0 0.5 0.5\n")
    want = proc.stderr.splitlines()[0][len("stdin:1: "):]
    assert "hole" in want
    with pytest.raises(ValueError) as e:
        s.eval(0, 0.5, 0.5)
    assert str(e.value) == f"sample 0: {want}"


def test_bad_arguments(meshes):
    path = meshes["cube"]
    with pytest.raises(ValueError, match="scheme 'bilinear' is not one of"):
        limitray.Surface(path, scheme="bilinear")
    with pytest.raises(ValueError, match="boundary 'sharp' is not one of"):
        limitray.Surface(path, boundary="sharp")
    s = limitray.Surface(path)
    with pytest.raises(TypeError, match="face must be integers"):
        s.eval([0.5], [0.5], [0.5])
    with pytest.raises(ValueError, match="invalid index '-1'"):
        s.eval([-1], [0.5], [0.5])
    with pytest.raises(ValueError, match="invalid parameter 'NaN'"):
        s.eval([0], [np.nan], [0.5])
    with pytest.raises(ValueError, match="shape mismatch|broadcast"):
        s.eval([0, 1], [0.5, 0.5, 0.5], [0.5])
    o = np.zeros((2, 3), dtype=np.float32)
    with pytest.raises(ValueError, match=r"ray 1: ray direction is zero"):
        s.trace(o, np.array([[1, 0, 0], [0, 0, 0]], dtype=np.float32))
    with pytest.raises(ValueError, match=r"ray 0: invalid number 'inf'"):
        s.trace(o, np.array([[np.inf, 0, 0], [1, 0, 0]], dtype=np.float32))
    with pytest.raises(ValueError, match=r"must be of shape \(N, 3\)"):
        s.trace(np.zeros((2, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="differ in shape"):
        s.trace(np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="rate 0 must be in"):
        s.trace(o, o + 1, rate=0)
    with pytest.raises(ValueError, match="rate 0 must be in"):
        s.dice(0)


def test_the_zero_direction_message_is_the_clis(cli, meshes):
    proc = cli(["trace", meshes["cube"]], "0 0 0 0 0 0\n")
    assert proc.returncode == 2
    assert proc.stderr.splitlines()[0] == "stdin:1: ray direction is zero"


def test_reader_warnings_become_python_warnings(cli, tmp_path):
    # An unknown statement is ignored with a warning: the CLI prints it, the package warns.
    path = tmp_path / "odd.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nfrobnicate 1 2\n")
    proc = cli(["eval", path], "")
    assert proc.returncode == 0, proc.stderr
    cli_warnings = [l[len("warning: "):] for l in proc.stderr.splitlines()
                    if l.startswith("warning: ")]
    assert len(cli_warnings) == 1 and "frobnicate" in cli_warnings[0]
    with pytest.warns(UserWarning) as rec:
        s = limitray.Surface(path)
    assert s.warnings == cli_warnings
    assert [str(w.message) for w in rec] == cli_warnings
