"""The file stages: :func:`ingest`, :func:`calibrate`, :func:`unwarp`, :func:`pyramid`,
and the y-tal / mitransient interop. Keyword arguments are the ``femto`` flags (underscores
for dashes); each returns a :class:`StageResult` with the figures the command prints."""

from __future__ import annotations

import os
import warnings
from typing import Any, Dict, Optional, Sequence, Union

from . import _femto
from . import _args as A
from ._errors import FemtoError, keyword_errors
from ._progress import reporting
from ._render import FemtoWarning

PathLike = Union[str, "os.PathLike[str]"]


class StageResult:
    """The figures a stage's command prints, as attributes (see each stage's docstring);
    ``warnings`` lists its warnings (also issued as :class:`FemtoWarning`)."""

    def __init__(self, figures: Dict[str, Any]):
        figures.setdefault("warnings", [])
        self.__dict__.update(figures)
        for w in figures["warnings"]:
            warnings.warn(w, FemtoWarning, stacklevel=4)

    def __repr__(self) -> str:
        return f"StageResult({self.__dict__!r})"


def _dark(value: Any) -> Any:
    """A dark level (a number) or a dark-frame file."""
    if value is None:
        return None
    if isinstance(value, (str, os.PathLike)):
        return os.fspath(value)
    return A.number("dark", value)


def _saturation(value: Any) -> Any:
    """A saturation level (a number) or ``"auto"``."""
    if value is None or isinstance(value, str):
        return value
    return A.number("saturation", value)


@keyword_errors
def ingest(
    source: PathLike,
    out: PathLike,
    *,
    rows: Optional[int] = None,
    dataset: Optional[str] = None,
    dt_ps: Optional[float] = None,
    t0_ps: Optional[float] = None,
    resample_time: bool = False,
    laser_nm: Optional[float] = None,
    transpose: bool = False,
    dark: Union[float, PathLike, None] = None,
    flat: Optional[PathLike] = None,
    sweep_table: Optional[PathLike] = None,
    no_manifest_corrections: bool = False,
    jitter: bool = True,
    power_ref: Optional[str] = None,
    saturation: Union[float, str, None] = None,
    allow_missing: bool = False,
    value_scale: Optional[float] = None,
    compression: Union[int, str, None] = None,
    force: bool = False,
    progress: Any = None,
    time_axis: Optional[int] = None,
    select: Optional[Dict[Union[str, int], int]] = None,
    sum: Optional[Sequence[Union[str, int]]] = None,
    confocal: bool = False,
    wall_size_m: Optional[float] = None,
    device_m: Optional[Sequence[float]] = None,
    clock: Optional[str] = None,
) -> StageResult:
    """Assemble a streak capture into an x-y-t cube in camera time (``femto ingest``), or
    ingest a file as instruments and labs save it (``.npy``, ``.npz``, ``.mat``, ``.hspy``,
    HDF5, Delmic SPARC, PicoQuant ``.ptu``): the library decides which, as the command does.

    ``source``: a folder with manifest.toml, a manifest, a glob (``"scan_*.png"``), a printf
    pattern with ``rows=N``, an HDF5 stack with ``dataset=``, or one scanline image. ``out``:
    the cube (HDF5). ``dt_ps`` / ``t0_ps``: bin width and start of bin 0, ps, for files that
    record no time axis (``resample_time=True`` resamples a recorded axis onto them).
    ``laser_nm``: laser wavelength, nm. ``dark``: a level (value units) or a dark-frame file;
    ``flat``: flat-field gains image; ``sweep_table``: nt+1 true bin-edge times, ps.
    ``jitter=False`` keeps trigger jitter (``--no-jitter``); ``power_ref``: ``"auto"`` or
    ``"x0:x1,t0:t1"``; ``saturation``: a level or ``"auto"``; ``value_scale``: signal per
    stored count; ``compression``: ``"none"`` or deflate level 0-9 (default 1).

    Returns ``path``, ``rows``, ``shape`` (ny, nx, nt), ``t0_ps``, ``dt_ps``, ``time_axis``
    (where the axis came from), ``laser_nm``, ``corrections``, ``jitter_shifts_ps``,
    ``power_gains``, ``missing_rows``, ``saturated_pixels``, ``masked_pixels``, ``passes``.
    y-tal captures and mitransient arrays: :func:`ingest_tal`, :func:`ingest_mitransient`.
    ``force``: replace ``out`` if it exists (``--force``; without it an existing cube is
    refused, docs/faults.md "Overwriting").

    Array, Delmic and PTU files (docs/ingest.md): ``time_axis``: which stored axis is time
    (``--time-axis``, indexing the shape :func:`info` gives); ``select``: ``{axis: index}``
    kept of extra axes (``{"frame": 0}``, ``{"C": 12}``); ``sum``: unnamed extra axes summed;
    ``confocal=True`` with ``wall_size_m`` (and ``device_m``) records a confocal scan;
    ``clock``: ``"camera"`` or ``"world"``. Returns ``path``, ``format``, ``source``,
    ``shape``, ``t0_ps``, ``dt_ps``, ``time_axis``, ``layout`` (which axis became what),
    ``saturated_pixels``, ``inexact_values``.
    """
    array_only = (time_axis is not None or select or sum or confocal or wall_size_m is not None
                  or device_m is not None or clock is not None)
    source_s = A.path("source", source)
    dataset_s = A.opt_text("dataset", dataset)
    if _femto.input_kind(source_s, dataset_s, False) == "array":
        if A.switch("confocal", confocal) and wall_size_m is None:
            raise FemtoError(f"{source_s}: confocal=True needs wall_size_m=")
        return StageResult(
            _femto.ingest_array(
                source_s, A.path("out", out), dataset_s, A.opt_whole("time_axis", time_axis),
                A.switch("transpose", transpose), _select(select), _sum(sum),
                A.opt_number("dt_ps", dt_ps), A.opt_number("t0_ps", t0_ps),
                _saturation(saturation),
                A.opt_number("wall_size_m", wall_size_m) if confocal else None,
                A.point("device_m", device_m), A.opt_text("clock", clock),
                A.opt_number("laser_nm", laser_nm), A.switch("force", force),
            )
        )
    if array_only:
        raise FemtoError(
            f"{source_s}: time_axis, select, sum, confocal, wall_size_m, device_m and clock "
            "are only for array files (.npy, .npz, .mat, .hspy, HDF5, Delmic, .ptu)"
        )
    with reporting(progress) as callback:
        figures = _femto.ingest(
            source_s, A.path("out", out), A.opt_whole("rows", rows, 1),
            dataset_s, A.opt_number("dt_ps", dt_ps),
            A.opt_number("t0_ps", t0_ps), A.switch("resample_time", resample_time),
            A.opt_number("laser_nm", laser_nm), A.switch("transpose", transpose), _dark(dark),
            A.path("flat", flat), A.path("sweep_table", sweep_table),
            A.switch("no_manifest_corrections", no_manifest_corrections),
            A.switch("jitter", jitter), A.opt_text("power_ref", power_ref),
            _saturation(saturation), A.switch("allow_missing", allow_missing),
            A.opt_number("value_scale", value_scale), A.compression("compression", compression),
            A.switch("force", force), callback,
        )
    return StageResult(figures)


@keyword_errors
def calibrate(
    cube: Any,
    *,
    mesh: PathLike,
    points: PathLike,
    laser: Optional[Sequence[float]] = None,
    intrinsics: Optional[PathLike] = None,
    eta: Optional[float] = None,
    square_pixels: bool = False,
    centred_principal_point: bool = False,
    fit_distortion: bool = False,
    fit_time_scale: bool = False,
    keep_outliers: bool = False,
    threshold: Optional[float] = None,
    min_peak: Optional[float] = None,
    out: Optional[PathLike] = None,
    force: bool = False,
    progress: Any = None,
) -> StageResult:
    """Fit the capture camera and ``t0`` (``femto calibrate``); writes the calibration TOML
    (``out``, default ``<cube stem>.calibration.toml`` beside the cube) and the cube's
    ``registration`` group, both or neither.

    ``mesh``: scene mesh in metres; ``points``: 2D-3D correspondences (.toml or .csv);
    ``laser``: laser spot (X, Y, Z) in metres, mesh frame; ``intrinsics``: a calibration TOML
    whose intrinsics are known (only the pose is fitted); ``eta``: refractive index (default
    1); ``threshold``: first-arrival detection fraction of a pixel's maximum (library default
    0.3); ``min_peak``: detection floor in value units (default 20 noise sigmas).

    Returns ``t0_ps`` and ``t0_std_error_ps``, ``time_scale``, ``time_residual_rms_ps``,
    ``time_residual_sigma_ps``, ``time_samples``, ``time_inliers``, ``check_t0_ps`` (with the
    floor doubled), ``noise_sigma``, ``reprojection_rms_px``, ``reprojection_median_px``,
    ``per_point_px``, ``outliers``, ``calibration`` (the TOML's path), ``scanline_offset_ps``
    (each scanline's time offset against the geometry, ps, that ``unwarp`` removes: 0 where
    not significant, NaN where not estimated), ``scanline_report`` (the lines the command
    prints about them), ``warnings``.
    ``force``: replace the TOML if it exists (``--force``; without it, refused). The cube's
    registration group follows the calibration written last.
    """
    with reporting(progress) as callback:
        figures = _femto.calibrate(
            A.path("cube", cube), A.path("mesh", mesh), A.path("points", points),
            A.point("laser", laser), A.path("intrinsics", intrinsics), A.opt_number("eta", eta),
            A.switch("square_pixels", square_pixels),
            A.switch("centred_principal_point", centred_principal_point),
            A.switch("fit_distortion", fit_distortion),
            A.switch("fit_time_scale", fit_time_scale),
            A.switch("keep_outliers", keep_outliers), A.opt_number("threshold", threshold),
            A.opt_number("min_peak", min_peak), A.path("out", out), A.switch("force", force),
            callback,
        )
    return StageResult(figures)


@keyword_errors
def unwarp(
    cube: Any,
    out: PathLike,
    *,
    to: str = "world",
    t0_ps: Optional[float] = None,
    nt: Optional[int] = None,
    dt_ps: Optional[float] = None,
    calibration: Optional[PathLike] = None,
    mesh: Optional[PathLike] = None,
    compression: Union[int, str, None] = None,
    mask_spread_bins: Optional[float] = None,
    force: bool = False,
    progress: Any = None,
) -> StageResult:
    """Convert a cube between camera and world time (``femto unwarp``; Jarabo et al. 2013, Eq. 2:
    ``t_world = t_camera - eta |p - o| / c``) with its registration's distances (or rays cast
    through ``calibration`` into ``mesh``). ``to``: ``"world"`` or ``"camera"``; ``t0_ps``,
    ``nt``, ``dt_ps``: the output axis (default: covering every shifted sample, the input's
    bins); ``compression``: default the input's. ``mask_spread_bins``: mask the pixels whose
    footprint spans more than this many bins of path (the registration's footprint_spread_m;
    default 4, ``float("inf")`` keeps every pixel, smeared).

    Returns ``path``, ``from_clock``, ``to_clock``, ``shape``, ``t0_ps``, ``dt_ps``,
    ``input_t0_ps``, ``input_nt``, ``eta``, ``valid_pixels``, ``dist_range_m``,
    ``straddling_pixels`` (footprints spanning more than one bin), ``mixed_pixels`` (of
    those, the ones masked), ``mask_spread_bins`` (the threshold used) and
    ``scanlines_moved`` (by the registration's time offsets).
    ``force``: replace ``out`` whole if it exists (``--force``; without it, refused); groups
    the old file held (a pyramid) go with it.
    """
    with reporting(progress) as callback:
        figures = _femto.unwarp(
            A.path("cube", cube), A.path("out", out), A.text("to", to),
            A.opt_number("t0_ps", t0_ps), A.opt_whole("nt", nt), A.opt_number("dt_ps", dt_ps),
            A.path("calibration", calibration), A.path("mesh", mesh),
            A.compression("compression", compression), A.opt_number("mask_spread_bins", mask_spread_bins),
            A.switch("force", force), callback,
        )
    return StageResult(figures)


@keyword_errors
def pyramid(
    cube: Any,
    *,
    levels: Optional[int] = None,
    side_file: Optional[PathLike] = None,
    compression: Union[int, str, None] = None,
    force: bool = False,
    progress: Any = None,
) -> StageResult:
    """Store a cube's temporal prefix sums and mip levels (``femto pyramid``), in the cube's
    file or ``side_file``. ``levels``: mip levels above level 0 (default all);
    ``compression``: ``"none"`` (the library's default) or a deflate level.

    Returns ``path``, ``shape``, ``levels``, ``level_nts`` (samples per pixel of each level).
    ``force``: replace ``side_file`` if it exists (``--force``; without it, refused). A
    pyramid group in the cube itself is replaced by each run.
    """
    with reporting(progress) as callback:
        figures = _femto.pyramid(
            A.path("cube", cube), A.opt_whole("levels", levels), A.path("side_file", side_file),
            A.compression("compression", compression), A.switch("force", force), callback,
        )
    return StageResult(figures)


@keyword_errors
def export_tal(
    cube: Any, out: PathLike, *, laser_origin_m: Optional[Sequence[float]] = None
) -> StageResult:
    """Write a cube with a registration (or tal) group as a y-tal capture (HDF5,
    ``femto export --to tal``). Returns ``path``, ``H_shape`` (nt, sx, sy), ``delta_t_m``,
    ``t_start_m``, ``t_accounts_first_and_last_bounces``, ``unseen_points``."""
    return StageResult(_femto.export_tal(
        A.path("cube", cube), A.path("out", out), A.point("laser_origin_m", laser_origin_m)))


@keyword_errors
def ingest_tal(
    source: PathLike, out: PathLike, *, saturation: Optional[float] = None
) -> StageResult:
    """Ingest a y-tal capture (HDF5 with ``H`` and ``H_format``) into a cube
    (``femto ingest CAPTURE.hdf5``). Returns ``path``, ``shape``, ``t0_ps``, ``dt_ps``,
    ``clock``."""
    return StageResult(_femto.ingest_tal(
        A.path("source", source), A.path("out", out), A.opt_number("saturation", saturation)))


@keyword_errors
def ingest_mitransient(
    source: PathLike,
    out: PathLike,
    *,
    start_opl_m: float,
    bin_width_opl_m: float,
    channels: str = "mean",
    opl_clock: str = "camera",
) -> StageResult:
    """Ingest a mitransient transient array ``(H, W, T, C)`` saved with ``np.save``
    (``femto ingest RENDER.npy``). ``start_opl_m`` / ``bin_width_opl_m``: the film's binning
    in metres of optical path (t = opl / c); ``channels``: ``"mean"``, ``"r"``, ``"g"``,
    ``"b"`` or ``"luminance"``; ``opl_clock``: ``"camera"`` (mitransient's default) or
    ``"world"`` (rendered with camera_unwarp). Returns ``path``, ``shape``, ``t0_ps``,
    ``dt_ps``, ``clock``."""
    return StageResult(
        _femto.ingest_mitransient(
            A.path("source", source), A.path("out", out), A.number("start_opl_m", start_opl_m),
            A.number("bin_width_opl_m", bin_width_opl_m), A.text("channels", channels),
            A.text("opl_clock", opl_clock),
        )
    )


def _select(select: Any) -> list:
    """``{axis: index}`` as ``[(axis, index)]`` (``--select AXIS=I``)."""
    if select is None:
        return []
    if not isinstance(select, dict):
        raise FemtoError(f"select: a dict {{axis: index}}, not {type(select).__name__}")
    return [(str(k), A.whole(f"select[{k!r}]", v)) for k, v in select.items()]


def _sum(axes: Any) -> list:
    """Axes to sum, as names (``--sum AXIS``)."""
    if axes is None:
        return []
    if isinstance(axes, (str, int)):
        axes = [axes]
    return [str(a) for a in axes]


@keyword_errors
def info(
    path: PathLike,
    *,
    dataset: Optional[str] = None,
    time_axis: Optional[int] = None,
    select: Optional[Dict[Union[str, int], int]] = None,
    sum: Optional[Sequence[Union[str, int]]] = None,
) -> Dict[str, Any]:
    """Describe a file femto reads or writes (``femto info FILE --json``): a dict whose
    ``kind`` says what it is (``"cube"``, ``"array"``, ``"streak_image"``, ...). For an
    array, Delmic or PTU file: ``stored_shape`` (the axes ``time_axis`` numbers),
    ``candidates`` (every array that could be the data, with its shape), ``layout``,
    ``time_axis``, ``ingest_needs``; ``dataset``, ``time_axis``, ``select`` and ``sum``
    describe the file as :func:`ingest` would read it with them."""
    import json

    return json.loads(
        _femto.info(
            A.path("path", path), A.opt_text("dataset", dataset),
            A.opt_whole("time_axis", time_axis), _select(select), _sum(sum),
        )
    )
