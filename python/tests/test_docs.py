"""The Python of the README and of the user guide (`docs/src/**/*.md`) runs.

Reference: the documentation's own blocks, executed as a reader would run them from the
repository root, with `my_car.toml` (the README's tour: "copy the paper's vehicle") a copy
of `configs/vehicle.toml`. Each block must run without an exception; the numbers it
prints are checked against the tasks by the other tests of this suite.
"""

from __future__ import annotations

import os
import re
import shutil

import pytest

from conftest import CONFIGS, REPO

DOCS = [REPO / "README.md", *sorted((REPO / "docs" / "src").rglob("*.md"))]


def _blocks():
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        for i, m in enumerate(re.finditer(r"^```python\n(.*?)^```", text, re.S | re.M)):
            yield pytest.param(m.group(1), id=f"{doc.relative_to(REPO)}#{i}")


@pytest.mark.parametrize("code", list(_blocks()))
def test_python_block_runs(code, tmp_path, monkeypatch):
    # a reader's working directory: the repository's configs and a vehicle file of one's own
    os.symlink(CONFIGS, tmp_path / "configs")
    shutil.copy(CONFIGS / "vehicle.toml", tmp_path / "my_car.toml")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<documentation>", "exec"), {"__name__": "__docs__"})
