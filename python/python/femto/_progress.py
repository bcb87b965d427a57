"""Progress of long stages: a callback ``progress(what, done, total)``, called on the
calling thread every 50 ms or so while the stage runs; by default a tqdm bar when tqdm is
installed, else nothing. ``progress=False`` turns it off.

The default bar is one bar per call, whose description names the current pass (``"rendering"``,
``"writing"``, ...); it shows the share done, the counts and the time left, not a rate (a
stage's steps are rows, frames or passes of different cost, so "it/s" would mislead), and
it is cleared when the stage ends, leaving no line behind."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Callable, Iterator, Optional

ProgressCallback = Callable[[str, int, int], None]

_BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}]"


class _TqdmBar:
    """One tqdm bar for a stage; each pass resets it with its own total and description."""

    def __init__(self, tqdm: Any):
        self._tqdm = tqdm
        self._bar: Any = None
        self._what: Optional[str] = None

    def __call__(self, what: str, done: int, total: int) -> None:
        if self._bar is None:
            self._bar = self._tqdm(
                total=total, desc=what, leave=False, dynamic_ncols=True, bar_format=_BAR_FORMAT,
            )
            self._what = what
        elif what != self._what or total != self._bar.total:
            self._bar.reset(total=total)
            self._bar.set_description_str(what, refresh=False)
            self._what = what
        # Counts as whole numbers, large ones in k and M (1.44M/2.00M, not 1438047/2000000).
        self._bar.unit_scale = total >= 10000
        self._bar.n = done
        self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def progress_callback(progress: Any) -> Optional[ProgressCallback]:
    """The callback a stage reports to: ``progress`` itself when callable, None for
    ``False``, a tqdm bar for None when tqdm is installed."""
    if progress is False:
        return None
    if callable(progress):
        return progress
    if progress is not None:
        from ._errors import FemtoError

        raise FemtoError(
            f"progress={progress!r}: expected a callable progress(what, done, total), "
            "False or None"
        )
    try:
        from tqdm.auto import tqdm  # type: ignore[import-not-found]
    except ImportError:
        return None
    return _TqdmBar(tqdm)


@contextmanager
def reporting(progress: Any) -> Iterator[Optional[ProgressCallback]]:
    """The callback for ``progress`` while a stage runs; the default bar is closed after."""
    callback = progress_callback(progress)
    try:
        yield callback
    finally:
        close = getattr(callback, "close", None)
        if isinstance(callback, _TqdmBar) and close is not None:
            close()
