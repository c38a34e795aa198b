"""Progress of the long calls: a callback ``progress(stage, done, total)``, a tqdm bar, or
nothing.

Every long call (``simulate``, ``bifurcation_diagram``, ``stability_chart``,
``nonlinear_chart``, ``sweep``, ``lateral_stability``) takes ``progress=``:

- ``None`` (the default): a tqdm bar when tqdm is installed, else nothing;
- ``True``: a tqdm bar (ImportError without tqdm); ``False``: nothing;
- a callable ``progress(stage: str, done: int, total: int)``: called from the calling
  thread whenever the reported progress changed (at most every 50 ms); ``total`` is 0
  where a stage does not know its size. An exception it raises stops the computation and
  is raised by the call.

Calls that take less than about a quarter of a second report nothing.
"""

from __future__ import annotations

from typing import Any, Callable, Optional, Union

ProgressCallback = Callable[[str, int, int], None]
Progress = Union[None, bool, ProgressCallback]


class _TqdmBars:
    """One tqdm bar per stage, closed when the stage changes or the call ends."""

    def __init__(self, tqdm: Any) -> None:
        self._tqdm = tqdm
        self._bar: Any = None
        self._stage: Optional[str] = None

    def __call__(self, stage: str, done: int, total: int) -> None:
        if stage != self._stage:
            self.close()
            self._bar = self._tqdm(total=total or None, desc=stage, leave=False)
            self._stage = stage
        self._bar.n = done
        self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def _reporter(progress: Progress) -> Optional[ProgressCallback]:
    if progress is False:
        return None
    if progress is None or progress is True:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            if progress is True:
                raise ImportError("progress=True: the progress bar needs tqdm (pip install tqdm)")
            return None
        return _TqdmBars(tqdm)
    if not callable(progress):
        raise TypeError(
            "progress: expected None, True, False or a callable progress(stage, done, total),"
            f" got {type(progress).__name__}"
        )
    return progress


def run(progress: Progress, call: Callable[[Optional[ProgressCallback]], Any]) -> Any:
    """``call(reporter)`` with the reporter of ``progress``; a tqdm bar is closed after."""
    reporter = _reporter(progress)
    try:
        return call(reporter)
    finally:
        if isinstance(reporter, _TqdmBars):
            reporter.close()
