"""Progress of long stages: a callback ``progress(what, done, total)``, called on the
calling thread every 50 ms or so while the stage runs; by default a tqdm bar when tqdm is
installed (one bar per pass), else nothing. ``progress=False`` turns it off."""

from __future__ import annotations

from typing import Callable, Optional

ProgressCallback = Callable[[str, int, int], None]


class _TqdmBars:
    """One tqdm bar per pass of a stage."""

    def __init__(self, tqdm):
        self._tqdm = tqdm
        self._bar = None
        self._what = None

    def __call__(self, what: str, done: int, total: int) -> None:
        if what != self._what or self._bar is None:
            self.close()
            self._bar = self._tqdm(total=total, desc=what, leave=False)
            self._what = what
        self._bar.total = total
        self._bar.n = done
        self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __del__(self):
        self.close()


def progress_callback(progress) -> Optional[ProgressCallback]:
    """The callback a stage reports to: ``progress`` itself when callable, None for
    ``False``, a tqdm bar for None when tqdm is installed."""
    if progress is False:
        return None
    if callable(progress):
        return progress
    try:
        from tqdm.auto import tqdm  # type: ignore[import-not-found]
    except ImportError:
        return None
    return _TqdmBars(tqdm)
