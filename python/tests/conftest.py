"""Shared helpers of the pytest suite: the repository, its committed results and the
`xtask` command line (the reference every Python function is compared with).

Two ways to run the suite: `cargo test --workspace` (or `cargo test -p trailer-sway-py
--test pytest`) builds the package and runs it through `python/tests/pytest.rs`; or
`pip install ./python pytest` and then `pytest python/tests` from the repository root,
which builds the `xtask` binary the first time a test compares with the command line
(`cargo build -p xtask`, several minutes on a fresh clone; it says so before it starts).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CONFIGS = REPO / "configs"
RESULTS = REPO / "results"

_CONFIG: pytest.Config | None = None


def pytest_configure(config: pytest.Config) -> None:
    global _CONFIG
    _CONFIG = config
    try:
        import trailer_sway  # noqa: F401
    except ImportError as e:
        raise pytest.UsageError(
            f"the package trailer_sway cannot be imported ({e}). Install it first: "
            "`pip install ./python` from the repository root (a Rust toolchain builds it, "
            "`pip install -v ./python` shows the build), or run the suite with "
            "`cargo test -p trailer-sway-py --test pytest`, which builds the package itself. "
            "Run pytest from the repository root, not from python/ (whose trailer_sway/ "
            "sources lack the compiled extension)."
        ) from None


def _tell(message: str) -> None:
    """Prints `message` on the terminal at once, past pytest's output capture."""
    capture = _CONFIG.pluginmanager.getplugin("capturemanager") if _CONFIG else None
    reporter = _CONFIG.pluginmanager.getplugin("terminalreporter") if _CONFIG else None
    if capture is None or reporter is None:
        print(message, file=sys.stderr, flush=True)
        return
    with capture.global_and_fixture_disabled():
        reporter.write_line("")
        reporter.write_line(message, yellow=True, bold=True)


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
    _tell(
        f"building the command-line tool `xtask` (cargo build -p xtask, into {target}), the "
        "reference these tests compare the Python results with: several minutes on a fresh "
        "clone, once (TRAILER_SWAY_XTASK=/path/to/xtask uses a built one)"
    )
    capture = _CONFIG.pluginmanager.getplugin("capturemanager") if _CONFIG else None
    if capture is None:
        subprocess.run(["cargo", "build", "-p", "xtask"], cwd=REPO, check=True)
    else:
        # cargo's progress on the terminal, not in the first test's captured output
        with capture.global_and_fixture_disabled():
            subprocess.run(["cargo", "build", "-p", "xtask"], cwd=REPO, check=True)
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
