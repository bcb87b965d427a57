# Type stubs of the femto package (times in ps, lengths in m, wavelengths in nm).
import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, os.PathLike[str]]
Progress = Union[None, bool, Callable[[str, int, int], None]]

__version__: str

class FemtoError(ValueError): ...
class FemtoOSError(FemtoError, OSError): ...
class FemtoFileNotFoundError(FemtoOSError, FileNotFoundError): ...
class FemtoWarning(UserWarning): ...

class Pyramid:
    @property
    def shape(self) -> Tuple[int, int, int]: ...
    @property
    def levels(self) -> int: ...
    def integral(self, t0_ps: float, t1_ps: float) -> npt.NDArray[np.float64]: ...

class Registration:
    attrs: Dict[str, Any]
    arrays: Dict[str, np.ndarray]
    def __getitem__(self, name: str) -> np.ndarray: ...

class Cube:
    path: str
    shape: Tuple[int, int, int]
    t0_ps: float
    dt_ps: float
    clock: str
    attrs: Dict[str, Any]
    groups: List[str]
    @property
    def data(self) -> npt.NDArray[np.float32]: ...
    @property
    def mask(self) -> Optional[npt.NDArray[np.uint8]]: ...
    @property
    def t_ps(self) -> npt.NDArray[np.float64]: ...
    @property
    def registration(self) -> Optional[Registration]: ...
    @property
    def pyramid(self) -> Optional[Pyramid]: ...

class RenderResult:
    frames: Tuple[int, int]
    frames_written: int
    width: int
    height: int
    seconds: float
    black_frames: List[int]
    time_offset_ps: float
    dtau_ps: float
    laser_nm: float
    laser: str
    warnings: List[str]

class StageResult:
    warnings: List[str]
    def __getattr__(self, name: str) -> Any: ...

def open_cube(path: PathLike, progress: Progress = ...) -> Cube: ...
def cube_from_array(
    array: npt.ArrayLike,
    dt_ps: float,
    t0_ps: float,
    path: PathLike,
    *,
    clock: str = ...,
    units: str = ...,
    mask: Optional[npt.ArrayLike] = ...,
    force: bool = ...,
    compression: Union[int, str, None] = ...,
    progress: Progress = ...,
    **attrs: Any,
) -> Cube: ...
def render(
    cube: Union[PathLike, Cube],
    calibration: Optional[PathLike] = ...,
    mesh: Optional[PathLike] = ...,
    path: Optional[PathLike] = ...,
    *,
    dolly: Optional[float] = ...,
    orbit: Optional[float] = ...,
    capture_view: bool = ...,
    size: Union[str, Tuple[int, int], None] = ...,
    frames: Union[str, range, Tuple[int, int], None] = ...,
    frame_count: Optional[int] = ...,
    dtau_ps: Optional[float] = ...,
    time_offset_ps: Optional[float] = ...,
    effects: str = ...,
    radiometry: str = ...,
    view: str = ...,
    exposure: float = ...,
    contour_ps: Optional[float] = ...,
    pyramid: Optional[PathLike] = ...,
    laser_nm: Optional[float] = ...,
    linear: bool = ...,
    out: Optional[PathLike] = ...,
    format: Optional[str] = ...,
    fps: float = ...,
    force: bool = ...,
    progress: Progress = ...,
) -> Any: ...
def render_still(
    cube: Union[PathLike, Cube],
    calibration: Optional[PathLike],
    mesh: Optional[PathLike],
    state: Union[Dict[str, Any], str],
    *,
    pyramid: Optional[PathLike] = ...,
    linear: bool = ...,
    progress: Progress = ...,
) -> np.ndarray: ...
def state_path_toml(state: Union[Dict[str, Any], str], inputs: str = ...) -> str: ...
def ingest(
    source: PathLike,
    out: PathLike,
    *,
    rows: Optional[int] = ...,
    dataset: Optional[str] = ...,
    dt_ps: Optional[float] = ...,
    t0_ps: Optional[float] = ...,
    resample_time: bool = ...,
    laser_nm: Optional[float] = ...,
    transpose: bool = ...,
    dark: Union[float, PathLike, None] = ...,
    flat: Optional[PathLike] = ...,
    sweep_table: Optional[PathLike] = ...,
    no_manifest_corrections: bool = ...,
    jitter: bool = ...,
    power_ref: Optional[str] = ...,
    saturation: Union[float, str, None] = ...,
    allow_missing: bool = ...,
    value_scale: Optional[float] = ...,
    compression: Union[int, str, None] = ...,
    force: bool = ...,
    progress: Progress = ...,
    time_axis: Optional[int] = ...,
    select: Optional[Dict[Union[str, int], int]] = ...,
    sum: Optional[Sequence[Union[str, int]]] = ...,
    confocal: bool = ...,
    wall_size_m: Optional[float] = ...,
    device_m: Optional[Sequence[float]] = ...,
    clock: Optional[str] = ...,
) -> StageResult: ...
def calibrate(
    cube: Union[PathLike, Cube],
    *,
    mesh: PathLike,
    points: PathLike,
    laser: Optional[Sequence[float]] = ...,
    intrinsics: Optional[PathLike] = ...,
    eta: Optional[float] = ...,
    square_pixels: bool = ...,
    centred_principal_point: bool = ...,
    fit_distortion: bool = ...,
    fit_time_scale: bool = ...,
    keep_outliers: bool = ...,
    threshold: Optional[float] = ...,
    min_peak: Optional[float] = ...,
    out: Optional[PathLike] = ...,
    force: bool = ...,
    progress: Progress = ...,
) -> StageResult: ...
def unwarp(
    cube: Union[PathLike, Cube],
    out: PathLike,
    *,
    to: str = ...,
    t0_ps: Optional[float] = ...,
    nt: Optional[int] = ...,
    dt_ps: Optional[float] = ...,
    calibration: Optional[PathLike] = ...,
    mesh: Optional[PathLike] = ...,
    compression: Union[int, str, None] = ...,
    mask_spread_bins: Optional[float] = ...,
    force: bool = ...,
    progress: Progress = ...,
) -> StageResult: ...
def pyramid(
    cube: Union[PathLike, Cube],
    *,
    levels: Optional[int] = ...,
    side_file: Optional[PathLike] = ...,
    compression: Union[int, str, None] = ...,
    force: bool = ...,
    progress: Progress = ...,
) -> StageResult: ...
def export_tal(
    cube: Union[PathLike, Cube], out: PathLike, *, laser_origin_m: Optional[Sequence[float]] = ...
) -> StageResult: ...
def ingest_tal(source: PathLike, out: PathLike, *, saturation: Optional[float] = ...) -> StageResult: ...
def ingest_mitransient(
    source: PathLike,
    out: PathLike,
    *,
    start_opl_m: float,
    bin_width_opl_m: float,
    channels: str = ...,
    opl_clock: str = ...,
) -> StageResult: ...
def simulate(
    out: PathLike,
    *,
    scene: Union[str, os.PathLike[str]] = ...,
    bunny: Optional[PathLike] = ...,
    format: Union[str, Sequence[str]] = ...,
    spp: int = ...,
    seed: int = ...,
    bounces: int = ...,
    size: Union[str, Tuple[int, int], None] = ...,
    nt: Optional[int] = ...,
    dt_ps: Optional[float] = ...,
    paper_size: bool = ...,
    transient_only: bool = ...,
    time_filter: str = ...,
    rr_start_bounce: Optional[int] = ...,
    rows: Union[str, range, Tuple[int, int], None] = ...,
    marker_spacing_m: float = ...,
    realistic: bool = ...,
    photon_noise: Optional[float] = ...,
    dark: Optional[Tuple[float, float]] = ...,
    vignetting: Optional[float] = ...,
    jitter_ps: Optional[float] = ...,
    power_sigma: Optional[float] = ...,
    sweep: Optional[float] = ...,
    saturation: Optional[float] = ...,
    fiducial_photo_px: Optional[float] = ...,
    force: bool = ...,
    progress: Progress = ...,
) -> StageResult:
    """Simulate a streak-camera capture of a scene into the folder ``out``
    (``femto simulate``; defaults: the cube scene at its own size, 64 paths per pixel, 4
    bounces, seed 0, PNG scanlines, no imperfections).

    Units: ``size`` pixels (width, height); ``nt`` bins; ``dt_ps`` bin width, ps;
    ``marker_spacing_m`` metres; ``photon_noise`` photons at the clean maximum; ``dark``
    (offset, sigma) and ``saturation`` fractions of the clean maximum; ``vignetting`` and
    ``sweep`` strengths in [0, 1); ``jitter_ps`` ps (sd); ``power_sigma`` relative sd;
    ``fiducial_photo_px`` pixels of a 4032-pixel-wide photo (sd). ``rows``: image rows A..B
    of a band. Returns the figures the command prints (``paths``, ``rays``,
    ``render_seconds``, ``files``, ``fiducials``, ...); see ``help(femto.simulate)``.
    """
    ...
def info(
    path: PathLike,
    *,
    dataset: Optional[str] = ...,
    time_axis: Optional[int] = ...,
    select: Optional[Dict[Union[str, int], int]] = ...,
    sum: Optional[Sequence[Union[str, int]]] = ...,
) -> Dict[str, Any]: ...
