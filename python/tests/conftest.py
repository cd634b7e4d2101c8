"""Shared fixtures: the `limitray` CLI the package is compared against, and test meshes."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# A unit cube: closed, all quads, every vertex of valence 3.
CUBE = """\
v -0.5 -0.5 0.5
v 0.5 -0.5 0.5
v -0.5 0.5 0.5
v 0.5 0.5 0.5
v -0.5 0.5 -0.5
v 0.5 0.5 -0.5
v -0.5 -0.5 -0.5
v 0.5 -0.5 -0.5
f 1 2 4 3
f 3 4 6 5
f 5 6 8 7
f 7 8 2 1
f 2 8 6 4
f 7 1 3 5
"""

# A pentagonal prism: closed, two pentagons (five sub-faces each) and five quads, with one
# semi-sharp crease around the top pentagon.
PRISM = """\
v 1.0 0.0 -0.6
v 0.309017 0.951057 -0.6
v -0.809017 0.587785 -0.6
v -0.809017 -0.587785 -0.6
v 0.309017 -0.951057 -0.6
v 1.0 0.0 0.6
v 0.309017 0.951057 0.6
v -0.809017 0.587785 0.6
v -0.809017 -0.587785 0.6
v 0.309017 -0.951057 0.6
f 5 4 3 2 1
f 6 7 8 9 10
f 1 2 7 6
f 2 3 8 7
f 3 4 9 8
f 4 5 10 9
f 5 1 6 10
t crease 2/1 5 6 1.5
t crease 2/1 6 7 1.5
t crease 2/1 7 8 1.5
t crease 2/1 8 9 1.5
t crease 2/1 9 5 1.5
"""

# An open 3 × 2 grid of quads with a triangle: boundaries, a boundary corner of one face, and
# an n-gon on the boundary.
GRID = """\
v 0 0 0
v 1 0 0.2
v 2 0 0
v 3 0 0.1
v 0 1 0.1
v 1 1 0.4
v 2 1 0.3
v 3 1 0
v 0 2 0
v 1 2 0.2
v 2 2 0.1
v 3 2 0
v 1.5 3 0.5
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 5 6 10 9
f 6 7 11 10
f 7 8 12 11
f 10 11 13
"""


def cli_path():
    """The `limitray` binary: $LIMITRAY_BIN, else the test-profile or release build."""
    env = os.environ.get("LIMITRAY_BIN")
    if env:
        return pathlib.Path(env)
    for p in (ROOT / "target" / "debug" / "limitray", ROOT / "target" / "release" / "limitray"):
        if p.exists():
            return p
    pytest.fail("no limitray binary: build it (cargo build) or set LIMITRAY_BIN")


@pytest.fixture(scope="session")
def cli():
    """Runs the CLI: cli(args, stdin="") -> CompletedProcess (text)."""
    exe = cli_path()

    def run(args, stdin=""):
        return subprocess.run(
            [str(exe), *map(str, args)], input=stdin, capture_output=True, text=True,
            timeout=600,
        )

    return run


@pytest.fixture(scope="session")
def meshes(tmp_path_factory):
    """name -> path of each test mesh (written here, or from the repository's scenes/)."""
    d = tmp_path_factory.mktemp("meshes")
    out = {}
    for name, text in (("cube", CUBE), ("prism", PRISM), ("grid", GRID)):
        p = d / f"{name}.obj"
        p.write_text(text)
        out[name] = p
    out["creased_cube"] = ROOT / "scenes" / "creased_cube.obj"
    out["gear8"] = ROOT / "scenes" / "meshes" / "gear8.obj"
    return out


def cli_error(proc):
    """The message of a failed CLI run (its last stderr line, without `error: `)."""
    assert proc.returncode == 2, proc.stderr
    line = proc.stderr.strip().splitlines()[-1]
    assert line.startswith("error: "), proc.stderr
    return line[len("error: "):]
