"""femto from Python: streak captures to x-y-t cubes, calibration, time unwarp and
relativistic rendering, with numpy arrays in and out.

Every function calls the same library stage as the ``femto`` command (and the demo), with
the same defaults; keyword arguments are named as the command's flags (underscores for
dashes). Times are in picoseconds (``_ps``), lengths in metres (``_m``), wavelengths in nm.
Errors raise :class:`FemtoError` (a ``ValueError``; :class:`FemtoOSError` and
:class:`FemtoFileNotFoundError` for files the system could not open) with the command's
one-line message. Long stages release the GIL, report progress (a tqdm bar when tqdm is
installed, or ``progress=callback(what, done, total)``), and stop on Ctrl-C, leaving
nothing written. See docs/python.md.
"""

try:
    from ._femto import __version__, Pyramid
except ModuleNotFoundError as e:  # pragma: no cover - depends on the working directory
    if e.name != f"{__name__}._femto":
        raise
    import os as _os

    _here = _os.path.dirname(_os.path.abspath(__file__))
    raise ImportError(
        f"femto: {_here} holds femto's Python sources without the compiled extension, and "
        "Python imports them first because it runs from their folder. Run from any other "
        "folder to use the installed femto (pip install ./python), or build the extension "
        "in place with `maturin develop --release` in python/."
    ) from None
from ._errors import FemtoError, FemtoOSError, FemtoFileNotFoundError
from ._cube import Cube, Registration, open_cube, cube_from_array
from ._render import FemtoWarning, RenderResult, render, render_still, state_path_toml
from ._stages import (
    StageResult,
    ingest,
    calibrate,
    unwarp,
    pyramid,
    export_tal,
    ingest_tal,
    ingest_mitransient,
    info,
)
from ._simulate import simulate

__all__ = [
    "info",
    "__version__",
    "Cube",
    "Registration",
    "Pyramid",
    "FemtoError",
    "FemtoOSError",
    "FemtoFileNotFoundError",
    "open_cube",
    "cube_from_array",
    "FemtoWarning",
    "RenderResult",
    "render",
    "render_still",
    "state_path_toml",
    "StageResult",
    "ingest",
    "calibrate",
    "unwarp",
    "pyramid",
    "export_tal",
    "ingest_tal",
    "ingest_mitransient",
    "simulate",
]
