"""Rendering: :func:`render` (``femto render``) and :func:`render_still` (a ``femto view``
state), frames as numpy arrays."""

from __future__ import annotations

import json
import os
import warnings
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from . import _femto
from . import _args as A
from ._errors import keyword_errors
from ._progress import reporting

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


def _warn(figures: Dict[str, Any]) -> None:
    for w in figures.get("warnings", []):
        warnings.warn(w, FemtoWarning, stacklevel=4)


@keyword_errors
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
    Raises :class:`FemtoError` with ``femto render``'s message, naming the keyword, for a bad
    argument or input.
    Releases the GIL; Ctrl-C stops it with nothing written.
    """
    with reporting(progress) as callback:
        array, figures = _femto.render(
            A.path("cube", cube),
            A.path("calibration", calibration),
            A.path("mesh", mesh),
            A.path("path", path),
            A.path("pyramid", pyramid),
            A.opt_number("laser_nm", laser_nm),
            A.opt_number("dolly", dolly),
            A.opt_number("orbit", orbit),
            A.switch("capture_view", capture_view),
            A.size("size", size),
            A.span("frames", frames, "frame B excluded, e.g. 0..50"),
            A.opt_whole("frame_count", frame_count),
            A.opt_number("dtau_ps", dtau_ps),
            A.opt_number("time_offset_ps", time_offset_ps),
            A.text("effects", effects),
            A.text("radiometry", radiometry),
            A.text("view", view),
            A.number("exposure", exposure),
            A.opt_number("contour_ps", contour_ps),
            A.switch("linear", linear),
            A.path("out", out),
            A.opt_text("format", format),
            A.number("fps", fps),
            A.switch("force", force),
            callback,
        )
    _warn(figures)
    if out is not None:
        return RenderResult(figures)
    return array


@keyword_errors
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
    with reporting(progress) as callback:
        frame, figures = _femto.render_still(
            A.path("cube", cube),
            A.path("calibration", calibration),
            A.path("mesh", mesh),
            text,
            A.path("pyramid", pyramid),
            A.switch("linear", linear),
            callback,
        )
    _warn(figures)
    return frame


@keyword_errors
def state_path_toml(state: Union[Dict[str, Any], str], inputs: str = "") -> str:
    """The one-frame camera path TOML of a viewer state (what ``femto view`` exports);
    ``inputs``: the ``femto render`` flags to quote in its comment."""
    text = state if isinstance(state, str) else json.dumps(state)
    return _femto.state_path_toml(text, inputs)
