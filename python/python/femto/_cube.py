"""Cubes as numpy: :func:`open_cube` and :func:`cube_from_array`."""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Union

import numpy as np

from . import _femto
from . import _args as A
from ._errors import FemtoError, keyword_errors
from ._progress import reporting


class Registration:
    """A cube's ``registration`` group (written by ``femto calibrate``).

    ``attrs``: the calibration and fit figures (``t0_ps``, ``reprojection_rms_px``, ...).
    ``arrays``: its datasets by name (``dist_m``: camera-to-surface distance per pixel in
    metres, ``(ny, nx)``; ``points_m``, ``normals``, ``hit``, ... as stored).
    """

    def __init__(self, attrs: Dict[str, Any], arrays: Dict[str, np.ndarray]):
        self.attrs = attrs
        self.arrays = arrays

    def __getitem__(self, name: str) -> np.ndarray:
        return self.arrays[name]

    def __repr__(self) -> str:
        return f"Registration(arrays={sorted(self.arrays)})"


class Cube:
    """An x-y-t cube file opened by :func:`open_cube`.

    Attributes (times in picoseconds):

    - ``data``: float32 ``(ny, nx, nt)``; bin ``i`` holds the signal integrated over
      ``[t0_ps + i dt_ps, t0_ps + (i + 1) dt_ps)``. Read on first use (GIL released).
    - ``t_ps``: float64 ``(nt,)``, bin centres. ``dt_ps``: bin width. ``t0_ps``: start of bin 0.
    - ``clock``: ``"camera"`` (when light reaches the sensor) or ``"world"`` (when it is at
      the surface point), docs/physics.md "two clocks".
    - ``attrs``: the ``/cube`` attributes (``units``, ``femto_version``, ``command_line``,
      provenance notes such as ``laser_nm``).
    - ``mask``: uint8 ``(ny, nx)`` (1 = valid pixel) or None.
    - ``registration``: :class:`Registration` or None. ``pyramid``: the stored prefix sums,
      with ``integral(t0_ps, t1_ps) -> (ny, nx)``, or None.
    """

    def __init__(self, path: "os.PathLike[str] | str", progress=None):
        self.path = os.fspath(path)
        meta = _femto.read_meta(self.path)
        self.shape = (meta["ny"], meta["nx"], meta["nt"])
        self.t0_ps: float = meta["t0_ps"]
        self.dt_ps: float = meta["dt_ps"]
        self.clock: str = meta["clock"]
        self.groups = list(meta["groups"])
        attrs: Dict[str, Any] = {
            "t0_ps": meta["t0_ps"],
            "dt_ps": meta["dt_ps"],
            "time_frame": meta["clock"],
            "units": meta["units"],
        }
        if meta["femto_version"] is not None:
            attrs["femto_version"] = meta["femto_version"]
        if meta["command_line"] is not None:
            attrs["command_line"] = meta["command_line"]
        for key, value in meta["notes"]:
            attrs[key] = value
        self.attrs = attrs
        self._progress = progress
        self._data: Optional[np.ndarray] = None
        self._mask: Optional[np.ndarray] = None
        self._registration: Any = ...
        self._pyramid: Any = ...

    def _load(self) -> None:
        with reporting(self._progress) as callback:
            self._data, self._mask = _femto.read_values(self.path, callback)

    @property
    def data(self) -> np.ndarray:
        if self._data is None:
            self._load()
        return self._data  # type: ignore[return-value]

    @property
    def mask(self) -> Optional[np.ndarray]:
        if self._data is None:
            self._load()
        return self._mask

    @property
    def t_ps(self) -> np.ndarray:
        return self.t0_ps + (np.arange(self.shape[2], dtype=np.float64) + 0.5) * self.dt_ps

    @property
    def registration(self) -> Optional[Registration]:
        if self._registration is ...:
            if "registration" in self.groups:
                attrs, arrays = _femto.read_group(self.path, "registration")
                self._registration = Registration(attrs, arrays)
            else:
                self._registration = None
        return self._registration

    @property
    def pyramid(self):
        if self._pyramid is ...:
            self._pyramid = (
                _femto.read_pyramid(self.path) if "pyramid" in self.groups else None
            )
        return self._pyramid

    def __repr__(self) -> str:
        ny, nx, nt = self.shape
        return (
            f"Cube({self.path!r}, ny={ny}, nx={nx}, nt={nt}, t0_ps={self.t0_ps}, "
            f"dt_ps={self.dt_ps}, clock={self.clock!r})"
        )


@keyword_errors
def open_cube(path: "os.PathLike[str] | str", progress=None) -> Cube:
    """Open the cube file at ``path`` (HDF5, docs/cube-format.md).

    Metadata is read now; ``.data`` (float32 ``(ny, nx, nt)``) on first use, with the
    library's reader (every stage's), which refuses NaN or infinite values.
    Raises :class:`FemtoError` (``FemtoFileNotFoundError`` for a missing file) with the
    message ``femto info`` would print.
    """
    return Cube(A.path("path", path), progress)


@keyword_errors
def cube_from_array(
    array: np.ndarray,
    dt_ps: float,
    t0_ps: float,
    path: "os.PathLike[str] | str",
    *,
    clock: str = "camera",
    units: str = "arbitrary",
    mask: Optional[np.ndarray] = None,
    force: bool = False,
    compression: Union[int, str, None] = None,
    progress: Any = None,
    **attrs: Any,
) -> Cube:
    """Write ``array`` (``(ny, nx, nt)`` real numbers, converted to float32) as a cube file
    at ``path``.

    ``dt_ps``: bin width, ps; ``t0_ps``: start of bin 0, ps; ``clock``: ``"camera"`` or
    ``"world"``; ``units``: units of the values (signal integrated over a bin); ``mask``:
    optional ``(ny, nx)`` validity mask (booleans, or 0 and 1; 1 = valid); further keyword
    arguments become string attributes of ``/cube`` (e.g. ``laser_nm=532``, read by
    ``femto render``). The file is written atomically, shuffle + deflate compressed
    (``compression``: ``"none"`` or a level 0-9, default the library's); an existing file is
    refused unless ``force=True``. Returns the written cube, opened.

    Refused with :class:`FemtoError` before anything is written, by the checks the library
    applies to every cube it reads: a NaN or infinite value (named by its pixel and bin), a
    value beyond float32's range, an array that is not 3-dimensional or not of real numbers
    (booleans, complex numbers, strings and objects are refused, never converted), a mask
    of another shape or other values, a non-finite ``t0_ps`` or a ``dt_ps`` out of range.
    Ctrl-C stops the write and leaves nothing at ``path``.
    """
    a = A.array_values("array", array)
    if a.ndim != 3:
        raise FemtoError(f"array of shape {a.shape}: a cube is (ny, nx, nt), 3 dimensions")
    m = A.mask_values("mask", mask)
    if m is not None and m.ndim != 2:
        raise FemtoError(f"mask of shape {m.shape}: expected (ny, nx) = {a.shape[:2]}")
    notes = [(str(k), str(v)) for k, v in attrs.items()]
    target = A.path("path", path)
    with reporting(progress) as callback:
        _femto.write_cube(
            a, A.number("dt_ps", dt_ps), A.number("t0_ps", t0_ps), target,
            A.text("clock", clock), A.text("units", units), notes, m, A.switch("force", force),
            A.compression("compression", compression),
            callback,
        )
    return Cube(target)
