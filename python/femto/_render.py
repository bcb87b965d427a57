"""Rendering: :func:`render` (``femto render``) and :func:`render_still` (a ``femto view``
state), frames as numpy arrays."""

from __future__ import annotations

import json
import os
import warnings
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from . import _femto
from ._errors import FemtoError
from ._progress import progress_callback

PathLike = Union[str, "os.PathLike[str]"]


class FemtoWarning(UserWarning):
    """A stage's warning (``femto ...: warning: ...`` on the command line)."""


class RenderResult:
    """What ``femto render`` prints: ``frames`` (A, B), ``frames_written``, ``width``,
    ``height``, ``seconds`` (wall), ``black_frames``, ``time_offset_ps``, ``dtau_ps`` (frame
    interval, ps of proper time), ``laser_nm``, ``laser`` (wavelength and where it came
    from), ``warnings``."""

    def __init__(self, figures: Dict[str, Any]):
        self.__dict__.update(figures)

    def __repr__(self) -> str:
        return f"RenderResult({self.__dict__!r})"


def _path(p: Any) -> Optional[str]:
    if p is None:
        return None
    if hasattr(p, "path") and not isinstance(p, (str, bytes, os.PathLike)):
        return os.fspath(p.path)  # a femto.Cube
    return os.fspath(p)


def _size(size: Any) -> Optional[Tuple[int, int]]:
    if size is None:
        return None
    if isinstance(size, str):
        w, sep, h = size.lower().partition("x")
        try:
            pair = (int(w), int(h)) if sep else None
        except ValueError:
            pair = None
        if pair is None or pair[0] < 1 or pair[1] < 1:
            raise FemtoError(
                f"--size {size}: expected WIDTHxHEIGHT with both at least 1, e.g. 640x480"
            )
        return pair
    w, h = size
    if int(w) < 1 or int(h) < 1:
        raise FemtoError(f"--size {w}x{h}: expected WIDTHxHEIGHT with both at least 1, e.g. 640x480")
    return int(w), int(h)


def _range(flag: str, value: Any, example: str) -> Optional[Tuple[int, int]]:
    """``value`` as (A, B): from ``"A..B"``, ``range(A, B)`` or a pair; a string that is not
    ``A..B`` is refused in the words of ``--flag`` (``example``: e.g. ``"frame B excluded,
    e.g. 0..50"``)."""
    if value is None:
        return None
    if isinstance(value, range):
        return value.start, value.stop
    if isinstance(value, str):
        a, sep, b = value.partition("..")
        try:
            return int(a), int(b)
        except ValueError:
            raise FemtoError(
                f"--{flag} {value}: expected A..B with A < B, {example}"
            ) from None
    a, b = value
    return int(a), int(b)


def _frames(frames: Any) -> Optional[Tuple[int, int]]:
    return _range("frames", frames, "frame B excluded, e.g. 0..50")


def _warn(figures: Dict[str, Any]) -> None:
    for w in figures.get("warnings", []):
        warnings.warn(w, FemtoWarning, stacklevel=3)


def render(
    cube: Any,
    calibration: Optional[PathLike] = None,
    mesh: Optional[PathLike] = None,
    path: Optional[PathLike] = None,
    *,
    dolly: Optional[float] = None,
    orbit: Optional[float] = None,
    capture_view: bool = False,
    size: Union[str, Tuple[int, int], None] = None,
    frames: Union[str, range, Tuple[int, int], None] = None,
    frame_count: Optional[int] = None,
    dtau_ps: Optional[float] = None,
    time_offset_ps: Optional[float] = None,
    effects: str = "all",
    radiometry: str = "consistent",
    view: str = "transient",
    exposure: float = 1.0,
    contour_ps: Optional[float] = None,
    pyramid: Optional[PathLike] = None,
    laser_nm: Optional[float] = None,
    linear: bool = False,
    out: Optional[PathLike] = None,
    format: Optional[str] = None,
    fps: float = 30.0,
    force: bool = False,
    progress: Any = None,
):
    """Render a relativistic novel-view sequence of a world-time cube (``femto render``).

    Returns the frames as a numpy array ``(frames, height, width, 3)``: uint8 display sRGB,
    the pixels of the PNG frames ``femto render --format png`` writes, byte for byte; or,
    with ``linear=True``, float32 linear RGB (the EXR frames' values, before exposure).
    With ``out=``, writes the frames as ``femto render --out`` does (PNG/EXR folder, MP4 or
    GIF file; ``format=``, ``fps=``) and returns a :class:`RenderResult` instead. Warnings
    (black frames, a defaulted laser wavelength) are issued as :class:`FemtoWarning`.

    Inputs:
      cube: world-time cube (path or :class:`Cube`), e.g. from :func:`unwarp`.
      calibration, mesh: the capture's calibration TOML and scene mesh (.glb, .gltf, .obj,
        world metres); both or neither (a y-tal wall cube's own grid).
      pyramid: pyramid side file (default: the cube's ``pyramid`` group, else prefix sums
        built in memory). laser_nm: laser wavelength, nm (default: the cube's ``laser_nm``
        attribute, else 670 with a warning).

    Camera (exactly one):
      path: camera path TOML (docs/camera-path.md). dolly: straight dolly from the capture
        camera at constant speed beta (units of c; negative backs away). orbit: orbit about
        the scene at constant beta (negative: clockwise from above). capture_view: the
        capture camera at rest.

    Frames:
      size: ``"640x480"`` or ``(640, 480)``, pixels (default 640x480 or the path file's).
      frame_count: frames of the whole sequence (default 100 or the path file's).
      frames: only frames A..B of it (``"0..10"``, ``range(0, 10)`` or ``(0, 10)``).
      dtau_ps: frame interval and exposure window, ps of camera proper time (default: the
        path file's; for shortcuts, sweeping the cube's time span).
      time_offset_ps: world time of the path's time 0, ps after the pulse leaves the laser
        spot (default 0 for a path file; for shortcuts, the target's first light).

    Look:
      effects: comma-separated unwarp, aberration, doppler, searchlight, dilation, rotation;
        or ``"all"`` / ``"none"``. radiometry: ``"consistent"`` (D^-3, docs/physics.md) or
        ``"paper"`` (Jarabo et al. 2013's D^-5). view: ``"transient"``, ``"naive"``,
        ``"isochrones"`` or ``"integrated"``. exposure: multiplier of the automatic exposure
        (log-average of the lit bins at mid-grey). contour_ps: isochrone contour spacing, ps.

    progress: ``callback(what, done, total)``, ``False`` for none; default a tqdm bar when
    tqdm is installed. force: replace an existing ``out`` (``--force``): the video file,
    or the frame files this render writes; without it they are refused.
    Raises :class:`FemtoError` with ``femto render``'s message for a bad argument or input.
    Releases the GIL; Ctrl-C stops it with nothing written.
    """
    array, figures = _femto.render(
        _path(cube),
        _path(calibration),
        _path(mesh),
        _path(path),
        _path(pyramid),
        None if laser_nm is None else float(laser_nm),
        None if dolly is None else float(dolly),
        None if orbit is None else float(orbit),
        bool(capture_view),
        _size(size),
        _frames(frames),
        None if frame_count is None else int(frame_count),
        None if dtau_ps is None else float(dtau_ps),
        None if time_offset_ps is None else float(time_offset_ps),
        str(effects),
        str(radiometry),
        str(view),
        float(exposure),
        None if contour_ps is None else float(contour_ps),
        bool(linear),
        _path(out),
        format,
        float(fps),
        bool(force),
        progress_callback(progress),
    )
    _warn(figures)
    if out is not None:
        return RenderResult(figures)
    return array


def render_still(
    cube: Any,
    calibration: Optional[PathLike],
    mesh: Optional[PathLike],
    state: Union[Dict[str, Any], str],
    *,
    pyramid: Optional[PathLike] = None,
    linear: bool = False,
    progress: Any = False,
) -> np.ndarray:
    """The frame of a ``femto view`` camera state: ``(height, width, 3)`` uint8 display sRGB
    (``linear=True``: float32 linear RGB).

    ``state`` is the viewer's state (a dict, or its JSON text): the ``/api/state`` JSON of
    ``femto view`` (docs/view.md): ``position_m``, ``world_from_camera``, ``vfov_deg``,
    ``beta`` (velocity over c), ``t_world_ps``, ``dtau_ps``, ``width``, ``height``,
    ``rotation``, ``effects``, ``view``, ``radiometry``, ``exposure``, ``laser_nm``. The
    frame is the still the viewer saves: what ``femto render --path`` renders from the
    state's one-frame camera path, byte for byte.
    """
    text = state if isinstance(state, str) else json.dumps(state)
    frame, figures = _femto.render_still(
        _path(cube),
        _path(calibration),
        _path(mesh),
        text,
        _path(pyramid),
        bool(linear),
        progress_callback(progress),
    )
    _warn(figures)
    return frame


def state_path_toml(state: Union[Dict[str, Any], str], inputs: str = "") -> str:
    """The one-frame camera path TOML of a viewer state (what ``femto view`` exports);
    ``inputs``: the ``femto render`` flags to quote in its comment."""
    text = state if isinstance(state, str) else json.dumps(state)
    return _femto.state_path_toml(text, inputs)
