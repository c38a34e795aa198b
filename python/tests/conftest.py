"""Shared helpers of the pytest suite: the repository, its committed results and the
`xtask` command line (the reference every Python function is compared with)."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CONFIGS = REPO / "configs"
RESULTS = REPO / "results"


def committed(task: str) -> dict:
    """`results/<task>/summary.json` as committed (the shipped configs' run)."""
    return json.loads((RESULTS / task / "summary.json").read_text())


def _xtask_binary() -> str:
    exe = os.environ.get("TRAILER_SWAY_XTASK")
    if exe:
        return exe
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    for profile in ("debug", "release"):
        p = target / profile / "xtask"
        if p.exists():
            return str(p)
    subprocess.run(["cargo", "build", "-q", "-p", "xtask"], cwd=REPO, check=True)
    return str(target / "debug" / "xtask")


def xtask(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Runs the CLI (`cargo xtask ARGS`) from the repository root."""
    r = subprocess.run(
        [_xtask_binary(), *map(str, args)], cwd=REPO, capture_output=True, text=True
    )
    if check and r.returncode != 0:
        raise AssertionError(f"xtask {' '.join(map(str, args))} failed:\n{r.stderr}")
    return r


def cli_error(*args: str) -> str:
    """The message the CLI prints for a refused input (its `error: ` prefix removed)."""
    r = xtask(*args, check=False)
    assert r.returncode != 0, f"xtask {args} accepted the input"
    lines = [l for l in r.stderr.splitlines() if l.startswith("error: ")]
    assert lines, r.stderr
    msg = lines[0][len("error: "):]
    # a refusal during a run is prefixed with the task's name
    if msg.startswith("task `") and "` failed: " in msg:
        msg = msg.split("` failed: ", 1)[1]
    return msg


def run_task(task: str, config_text: str | None, tmp: Path, *extra: str) -> Path:
    """Runs `xtask TASK --config FILE --results DIR` and returns its results directory."""
    args = [task]
    if config_text is not None:
        cfg = tmp / f"{task}.toml"
        cfg.write_text(config_text)
        args += ["--config", str(cfg)]
    args += ["--results", str(tmp / "results"), *extra]
    xtask(*args)
    return tmp / "results"


@pytest.fixture
def table1():
    import trailer_sway as ts

    return ts.Vehicle.table1()
