"""The README's worked example runs, and prints what the README says it prints."""

import contextlib
import io
import os
import re

from conftest import ROOT


def test_the_readme_example_runs_and_prints_its_table():
    text = (ROOT / "python" / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    example = next(b for b in blocks if "exact=True" in b)
    printed = re.search(r"which prints.*?```\n(.*?)```", text, re.S).group(1)
    out = io.StringIO()
    cwd = os.getcwd()
    os.chdir(ROOT)  # the example opens scenes/creased_cube.obj
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(example, "README.md", "exec"), {})
    finally:
        os.chdir(cwd)
    # Same seed, same scene, same library: the same digits.
    assert out.getvalue() == printed
