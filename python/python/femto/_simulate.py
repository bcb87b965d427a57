""":func:`simulate`: a simulated streak-camera capture of a scene (``femto simulate``)."""

from __future__ import annotations

import os
from typing import Any, Optional, Sequence, Tuple, Union

from . import _femto
from . import _args as A
from ._errors import FemtoError, keyword_errors
from ._progress import reporting
from ._stages import PathLike, StageResult

# The largest seed (the command's --seed is a u64 below 2**63) and bounce count.
_MAX_SEED = 2**63 - 1
_MAX_COUNT = 2**32 - 1


def _formats(format: Union[str, Sequence[str]]) -> list:
    if isinstance(format, str):
        return format.split(",")
    try:
        names = list(format)
    except TypeError:
        names = None
    if not names or not all(isinstance(f, str) for f in names):
        raise FemtoError(f"format={format!r}: expected a format name, a list of them or a "
                         "comma-separated string, e.g. \"png16,exr\"")
    return names


@keyword_errors
def simulate(
    out: PathLike,
    *,
    scene: Union[str, "os.PathLike[str]"] = "cube",
    bunny: Optional[PathLike] = None,
    format: Union[str, Sequence[str]] = "png16",
    spp: int = 64,
    seed: int = 0,
    bounces: int = 4,
    size: Union[str, Tuple[int, int], None] = None,
    nt: Optional[int] = None,
    dt_ps: Optional[float] = None,
    paper_size: bool = False,
    transient_only: bool = False,
    time_filter: str = "sensor",
    rr_start_bounce: Optional[int] = None,
    rows: Union[str, range, Tuple[int, int], None] = None,
    marker_spacing_m: float = 0.008,
    realistic: bool = False,
    photon_noise: Optional[float] = None,
    dark: Optional[Tuple[float, float]] = None,
    vignetting: Optional[float] = None,
    jitter_ps: Optional[float] = None,
    power_sigma: Optional[float] = None,
    sweep: Optional[float] = None,
    saturation: Optional[float] = None,
    fiducial_photo_px: Optional[float] = None,
    force: bool = False,
    progress: Any = None,
) -> StageResult:
    """Simulate a streak-camera capture of a scene and write its folder (``femto simulate``):
    one streak image per scanline, manifest.toml, scene.glb, the true calibration.toml,
    fiducials.toml, flat.exr, dark.exr and the ground-truth cubes (truth_camera.h5,
    truth_world.h5, truth_direct.h5). The same library call as the command, with the same
    defaults; the files are the command's, bit for bit, but for the provenance
    (``created_by = "python: femto.simulate"``).

    ``out``: the capture folder (must not exist or be empty; ``force=True`` replaces it).
    ``scene``: a built-in scene (``"cube"``, ``"cornell"``, ``"bunny"`` with ``bunny=`` the
    mesh file) or a scene file (.toml). ``format``: scanline formats, ``"png16"``, ``"exr"``,
    ``"img16"`` (or ``"img"``), ``"img32"``, a list or comma-separated; the first is the
    manifest's primary file. ``spp``: camera paths per pixel; ``seed``: random seed (0 to
    2**63 - 1); ``bounces``: most surface interactions per path (1 = direct light only, at
    most 1000).

    Size (default: the scene's): ``size``: image width x height in pixels, ``"64x48"`` or
    ``(64, 48)``; ``nt``: time bins; ``dt_ps``: bin width in ps; ``paper_size=True``: 672 x 600
    pixels, 512 bins of 1.71 ps (Jarabo et al. 2013; not with size, nt or dt_ps).

    ``transient_only=True``: only truth_camera.h5 and render.json (the path tracer alone);
    ``time_filter``: ``"sensor"`` (the laser pulse and the sensor's one-bin response) or
    ``"box"`` (a histogram of arrival times; only with transient_only); ``rr_start_bounce``:
    first bounce at which Russian roulette may end a path (1 = the surface the camera ray hits;
    ``None``: the tracer's 3), only with transient_only, to match another renderer's setting.
    ``rows``: render only
    image rows A..B (B excluded) into a band folder, ``"A..B"``, ``range(A, B)`` or
    ``(A, B)``; ``femto merge`` assembles the bands (docs/cluster.md).
    ``marker_spacing_m``: spacing of the fiducial marker grid, metres.

    Imperfections: ``realistic=True`` starts from the realistic set, which the ones given
    override. ``photon_noise``: expected photons at the clean cube's maximum; ``dark``:
    (offset, sigma), fractions of the clean maximum; ``vignetting``: strength in [0, 1) (gain
    1 - S r^2, r = 1 at the corners); ``jitter_ps``: per-scanline trigger jitter, sd in ps;
    ``power_sigma``: per-scanline laser power, relative sd; ``sweep``: sweep non-linearity
    in [0, 1); ``saturation``: level, fraction of the clean maximum; ``fiducial_photo_px``:
    sd of the markers' positions in a 4032-pixel-wide photo, pixels.

    Returns the figures the command prints: ``path``, ``scene``, ``shape`` (ny, nx, nt),
    ``t0_ps``, ``dt_ps``, ``spp``, ``bounces``, ``seed``, ``threads``, ``transient_only``,
    ``time_filter``, ``rr_start_bounce`` (``None`` unless given), ``rows``, ``paths``, ``rays``, ``render_seconds`` (wall),
    ``render_cpu_seconds``, ``paths_per_second``, ``seconds`` (all of it), ``files`` (every
    file written), ``streak_images``, ``fiducials``, ``values_at_top_count`` (streak-image
    values clipped at 65535), and ``command`` (the equivalent ``femto simulate`` command line,
    which a band records for ``femto merge``). Errors raise :class:`FemtoError` with the
    command's message (:class:`FemtoFileNotFoundError` for a missing scene or mesh file).
    The GIL is released while it runs; Ctrl-C stops it and leaves nothing written.
    """
    with reporting(progress) as callback:
        figures = _femto.simulate(
            A.path("out", out), A.path("scene", scene), A.path("bunny", bunny),
            _formats(format), A.whole("spp", spp, 0, _MAX_COUNT),
            A.whole("seed", seed, 0, _MAX_SEED), A.whole("bounces", bounces, 0, _MAX_COUNT),
            A.size("size", size), A.opt_whole("nt", nt), A.opt_number("dt_ps", dt_ps),
            A.switch("paper_size", paper_size), A.switch("transient_only", transient_only),
            A.text("time_filter", time_filter),
            A.opt_whole("rr_start_bounce", rr_start_bounce, 0, _MAX_COUNT),
            A.span("rows", rows, "row B excluded, e.g. 0..100"),
            A.number("marker_spacing_m", marker_spacing_m), A.switch("realistic", realistic),
            A.opt_number("photon_noise", photon_noise), A.pair("dark", dark),
            A.opt_number("vignetting", vignetting), A.opt_number("jitter_ps", jitter_ps),
            A.opt_number("power_sigma", power_sigma), A.opt_number("sweep", sweep),
            A.opt_number("saturation", saturation),
            A.opt_number("fiducial_photo_px", fiducial_photo_px),
            A.switch("force", force), callback,
        )
    return StageResult(figures)
