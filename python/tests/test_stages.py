"""The file stages against the command line: same inputs and flags, same outputs."""

import h5py
import numpy as np
import pytest
from PIL import Image

import femto
from conftest import assert_same_refusal, run_cli


def cube_values(path):
    with h5py.File(path, "r") as f:
        return f["cube"][...]


def test_chain_equals_the_cli_chain(demo, femto_bin, tmp_path):
    py, cli = tmp_path / "py", tmp_path / "cli"
    py.mkdir(), cli.mkdir()
    seen = []
    r = femto.ingest(demo["capture"], py / "cube.h5", power_ref="auto", saturation="auto",
                     progress=lambda what, done, total: seen.append((what, done, total)))
    run_cli(femto_bin, "ingest", demo["capture"], "-o", cli / "cube.h5", "--power-ref", "auto",
            "--saturation", "auto")
    assert np.array_equal(cube_values(py / "cube.h5"), cube_values(cli / "cube.h5"))
    assert r.shape == cube_values(cli / "cube.h5").shape and r.passes == 2
    assert seen and all(t == 2 * r.rows for _, _, t in seen)

    laser = "-0.13,0.06,-0.07"
    c = femto.calibrate(py / "cube.h5", mesh=demo["mesh"], points=demo["points"],
                        laser=[-0.13, 0.06, -0.07], square_pixels=True,
                        centred_principal_point=True, out=py / "cal.toml")
    out = run_cli(femto_bin, "calibrate", cli / "cube.h5", "--mesh", demo["mesh"], "--points",
                  demo["points"], f"--laser={laser}", "--square-pixels",
                  "--centred-principal-point", "--out", cli / "cal.toml").stdout
    assert f"time: t0 {c.t0_ps:.3f} +- {c.t0_std_error_ps:.3f} ps" in out, out
    assert f"reprojection: rms {c.reprojection_rms_px:.3f} px" in out
    assert abs(c.t0_ps) < 50 and c.t0_std_error_ps > 0
    assert len(c.scanline_offset_ps) == cube_values(py / "cube.h5").shape[0]
    for line in c.scanline_report:
        assert line in out, (line, out)

    u = femto.unwarp(py / "cube.h5", py / "world.h5")
    out = run_cli(femto_bin, "unwarp", cli / "cube.h5", "--out", cli / "world.h5").stdout
    assert np.array_equal(cube_values(py / "world.h5"), cube_values(cli / "world.h5"))
    assert u.to_clock == "world" and u.valid_pixels > 0
    # Mixed pixels: the capture's slanted floor and the box's edges straddle bins of path.
    assert 0 < u.mixed_pixels <= u.straddling_pixels and u.mask_spread_bins == 4.0
    assert (f"{u.straddling_pixels} pixels have footprints spanning more than one bin of path"
            in out and f"{u.mixed_pixels} spanning more than 4 bins are masked" in out), out
    # inf keeps every pixel: the same as the command's, and none masked.
    k = femto.unwarp(py / "cube.h5", py / "kept.h5", mask_spread_bins=float("inf"))
    out = run_cli(femto_bin, "unwarp", cli / "cube.h5", "--out", cli / "kept.h5",
                  "--mask-spread-bins", "inf").stdout
    assert np.array_equal(cube_values(py / "kept.h5"), cube_values(cli / "kept.h5"))
    assert k.mixed_pixels == 0 and k.straddling_pixels == u.straddling_pixels
    assert k.valid_pixels == u.valid_pixels + u.mixed_pixels
    assert "none is masked (--mask-spread-bins inf)" in out, out
    for bad in (float("nan"), 0.0, -1.0):
        with pytest.raises(femto.FemtoError, match="mask_spread_bins="):
            femto.unwarp(py / "cube.h5", py / "bad.h5", mask_spread_bins=bad)
    assert not (py / "bad.h5").exists()

    p = femto.pyramid(py / "world.h5")
    run_cli(femto_bin, "pyramid", cli / "world.h5")
    assert p.levels >= 1
    with h5py.File(py / "world.h5", "r") as a, h5py.File(cli / "world.h5", "r") as b:
        assert sorted(a["pyramid"]) == sorted(b["pyramid"])
        for name in a["pyramid"]:
            assert np.array_equal(a["pyramid"][name][...], b["pyramid"][name][...]), name


def test_ingest_of_a_numpy_made_png16_capture_equals_the_cli(femto_bin, tmp_path):
    rng = np.random.default_rng(3)
    ny, nt, nx = 6, 40, 9
    scans = tmp_path / "scans"
    scans.mkdir()
    for y in range(ny):
        img = rng.integers(0, 60000, size=(nt, nx), dtype=np.uint16)
        Image.fromarray(img.astype(np.uint16)).save(scans / f"scan_{y:03d}.png")
    pattern = str(scans / "scan_*.png")
    r = femto.ingest(pattern, tmp_path / "py.h5", dt_ps=2.0, t0_ps=-5.0, jitter=False,
                     progress=False)
    run_cli(femto_bin, "ingest", pattern, "-o", tmp_path / "cli.h5", "--dt-ps", "2",
            "--t0-ps=-5", "--no-jitter")
    a, b = cube_values(tmp_path / "py.h5"), cube_values(tmp_path / "cli.h5")
    assert a.shape == (ny, nx, nt) and np.array_equal(a, b)
    assert r.dt_ps == 2.0 and r.t0_ps == -5.0
    # The values are the counts (value scale 1), time along the image's rows.
    first = np.asarray(Image.open(scans / "scan_000.png"), dtype=np.float32)
    assert np.array_equal(a[0], first.T)


@pytest.mark.parametrize(
    "kwargs,flags",
    [
        (dict(dt_ps=-1.0, t0_ps=0.0), ["--dt-ps=-1", "--t0-ps", "0"]),
        (dict(), []),
        (dict(dt_ps=1.0, t0_ps=0.0, power_ref="1:2"), ["--dt-ps", "1", "--t0-ps", "0", "--power-ref", "1:2"]),
    ],
)
def test_bad_ingest_arguments_raise_the_cli_message(femto_bin, tmp_path, kwargs, flags):
    scans = tmp_path / "s"
    scans.mkdir()
    for y in range(2):
        Image.fromarray(np.ones((4, 3), np.uint16)).save(scans / f"s{y}.png")
    pattern = str(scans / "s*.png")
    with pytest.raises(femto.FemtoError) as e:
        femto.ingest(pattern, tmp_path / "o.h5", progress=False, **kwargs)
    cli = run_cli(femto_bin, "ingest", pattern, "-o", tmp_path / "o.h5", *flags, check=False)
    assert cli.returncode == 2
    line = cli.stderr.strip()
    if "invalid value" in line:
        # A value clap's parser refused: clap words the line, the library gives the reason.
        assert str(e.value).split(": ", 1)[1] in line, (str(e.value), line)
    else:
        assert_same_refusal(str(e.value), cli.stderr)
    assert not (tmp_path / "o.h5").exists()


def test_ytal_round_trip(demo, tmp_path):
    # y-tal is not among the package's extras: the wheel venv of .ci/run lacks it, and its
    # interop step checks the same round trip with y-tal's own reader (tools/interop/ytal.py).
    tal = pytest.importorskip(
        "tal", reason="skipped: y-tal is missing (pip install y-tal); .ci/run's interop step "
        "checks this round trip (tools/interop/ytal.py)")
    r = femto.export_tal(demo["cube"], tmp_path / "capture.hdf5")
    cap = tal.io.read_capture(str(tmp_path / "capture.hdf5"))
    assert cap.H.shape == tuple(r.H_shape)
    back = femto.ingest_tal(tmp_path / "capture.hdf5", tmp_path / "back.h5")
    orig = femto.open_cube(demo["cube"])
    again = femto.open_cube(back.path)
    assert again.shape == orig.shape
    assert np.allclose(again.data, orig.data, rtol=1e-6, atol=0)
    # y-tal's times start at the laser's emission: the calibration's t0 is taken off.
    t0_cal = orig.registration.attrs["t0_ps"]
    assert abs(again.t0_ps - (orig.t0_ps - t0_cal)) < 1e-6 * abs(orig.t0_ps)
    assert abs(again.dt_ps - orig.dt_ps) < 1e-9 * orig.dt_ps


def test_mitransient_array_in_memory(tmp_path):
    rng = np.random.default_rng(5)
    h = rng.random((4, 5, 16, 3), dtype=np.float32)
    np.save(tmp_path / "render.npy", h)
    r = femto.ingest_mitransient(tmp_path / "render.npy", tmp_path / "m.h5",
                                 start_opl_m=0.3, bin_width_opl_m=0.003)
    cube = femto.open_cube(r.path)
    assert cube.shape == (4, 5, 16)
    assert np.allclose(cube.data, h.mean(axis=3), rtol=1e-6)
    c_m_per_ps = 299792458e-12
    assert np.isclose(cube.dt_ps, 0.003 / c_m_per_ps) and np.isclose(cube.t0_ps, 0.3 / c_m_per_ps)
    with pytest.raises(femto.FemtoError, match="channels=x"):
        femto.ingest_mitransient(tmp_path / "render.npy", tmp_path / "n.h5", start_opl_m=0.3,
                                 bin_width_opl_m=0.003, channels="x")


def test_an_existing_output_is_refused_as_the_cli_refuses_it(femto_bin, tmp_path):
    scans = tmp_path / "s"
    scans.mkdir()
    for y in range(2):
        Image.fromarray(np.ones((4, 3), np.uint16)).save(scans / f"s{y}.png")
    pattern = str(scans / "s*.png")
    out = tmp_path / "o.h5"
    femto.ingest(pattern, out, dt_ps=1.0, t0_ps=0.0, progress=False)
    before = out.read_bytes()
    with pytest.raises(femto.FemtoError) as e:
        femto.ingest(pattern, out, dt_ps=1.0, t0_ps=0.0, progress=False)
    cli = run_cli(femto_bin, "ingest", pattern, "-o", out, "--dt-ps", "1", "--t0-ps", "0",
                  check=False)
    assert cli.returncode == 2
    assert_same_refusal(str(e.value), cli.stderr)
    assert "force=True" in str(e.value) and out.read_bytes() == before
    femto.ingest(pattern, out, dt_ps=1.0, t0_ps=0.0, force=True, progress=False)


def test_a_missing_mesh_is_named_before_the_laser_is_asked_for(demo, femto_bin, tmp_path):
    # docs/python.md: calibrate(mesh="missing.glb") raises FemtoFileNotFoundError, with or
    # without laser=, as the command does.
    with pytest.raises(femto.FemtoFileNotFoundError) as e:
        femto.calibrate(demo["cube"], mesh=tmp_path / "missing.glb", points=demo["points"],
                        out=tmp_path / "c.toml", progress=False)
    assert "missing.glb" in str(e.value) and e.value.errno == 2
    cli = run_cli(femto_bin, "calibrate", demo["cube"], "--mesh", tmp_path / "missing.glb",
                  "--points", demo["points"], "--out", tmp_path / "c.toml", check=False)
    assert cli.returncode == 2 and "missing.glb" in cli.stderr, cli.stderr


def test_the_world_cube_says_world_time_in_its_content_note(demo):
    assert femto.open_cube(demo["cube"]).attrs["content"] == "ingested capture, camera time"
    assert femto.open_cube(demo["world"]).attrs["content"] == "ingested capture, world time"
