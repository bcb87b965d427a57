"""open_cube and cube_from_array against h5py, the reference HDF5 reader."""

import h5py
import numpy as np
import pytest

import femto


def test_version_is_the_crates():
    assert femto.__version__ == "0.1.0"


def test_open_cube_data_equals_h5py_exactly(demo):
    for name in ("cube", "world"):
        path = demo[name]
        cube = femto.open_cube(path)
        with h5py.File(path, "r") as f:
            ref = f["cube"][...]
            attrs = dict(f["cube"].attrs)
        assert cube.data.dtype == np.float32
        assert cube.data.shape == ref.shape == cube.shape
        assert np.array_equal(cube.data, ref)
        assert cube.dt_ps == attrs["dt_ps"] and cube.t0_ps == attrs["t0_ps"]
        t = attrs["t0_ps"] + (np.arange(ref.shape[2]) + 0.5) * attrs["dt_ps"]
        assert np.allclose(cube.t_ps, t, rtol=0, atol=1e-9)
        assert cube.clock == ("camera" if name == "cube" else "world")
        assert cube.attrs["time_frame"] == cube.clock


def test_world_cube_has_registration_and_pyramid(demo):
    cube = femto.open_cube(demo["world"])
    assert cube.pyramid is not None
    with h5py.File(demo["world"], "r") as f:
        ref = f["cube"][...].astype(np.float64)
    # The whole time span: the sum of every bin.
    whole = cube.pyramid.integral(cube.t0_ps, cube.t0_ps + cube.shape[2] * cube.dt_ps)
    assert whole.shape == cube.shape[:2]
    assert np.allclose(whole, ref.sum(axis=2), rtol=1e-5, atol=1e-6 * np.abs(ref).max())
    # Bins 3..9 exactly.
    part = cube.pyramid.integral(cube.t0_ps + 3 * cube.dt_ps, cube.t0_ps + 9 * cube.dt_ps)
    assert np.allclose(part, ref[:, :, 3:9].sum(axis=2), rtol=1e-5, atol=1e-6 * np.abs(ref).max())
    camera = femto.open_cube(demo["cube"])
    assert camera.registration is not None
    with h5py.File(demo["cube"], "r") as f:
        g = f["registration"]
        for name, ds in g.items():
            assert np.array_equal(camera.registration[name], ds[...]), name


def test_cube_from_array_round_trips_through_h5py(tmp_path):
    rng = np.random.default_rng(7)
    a = rng.normal(size=(5, 7, 33)).astype(np.float32)
    p = tmp_path / "made.h5"
    cube = femto.cube_from_array(a, 2.5, -10.0, p, clock="world", laser_nm=532)
    with h5py.File(p, "r") as f:
        assert np.array_equal(f["cube"][...], a)
        assert f["cube"].attrs["dt_ps"] == 2.5
        assert f["cube"].attrs["t0_ps"] == -10.0
        tf = f["cube"].attrs["time_frame"]
        assert (tf.decode() if isinstance(tf, bytes) else tf) == "world"
    assert np.array_equal(cube.data, a)
    assert cube.attrs["laser_nm"] == "532"
    # Non-contiguous and float64 input is converted.
    b = np.asfortranarray(a.astype(np.float64))
    p2 = tmp_path / "f.h5"
    assert np.array_equal(femto.cube_from_array(b, 1.0, 0.0, p2).data, a)


def test_cube_from_array_refuses_overwrite_and_bad_values(tmp_path):
    a = np.zeros((2, 2, 4), np.float32)
    p = tmp_path / "c.h5"
    femto.cube_from_array(a, 1.0, 0.0, p)
    with pytest.raises(femto.FemtoError, match="exists; pass force=True"):
        femto.cube_from_array(a, 1.0, 0.0, p)
    femto.cube_from_array(a + 1, 1.0, 0.0, p, force=True)
    assert femto.open_cube(p).data[0, 0, 0] == 1.0
    with pytest.raises(femto.FemtoError, match="clock"):
        femto.cube_from_array(a, 1.0, 0.0, tmp_path / "d.h5", clock="lab")
    with pytest.raises(femto.FemtoError, match="3 dimensions"):
        femto.cube_from_array(a[0], 1.0, 0.0, tmp_path / "d.h5")
    assert not (tmp_path / "d.h5").exists()


def test_missing_file_is_a_file_not_found_error(tmp_path, femto_bin):
    from conftest import run_cli

    missing = tmp_path / "nope.h5"
    with pytest.raises(femto.FemtoFileNotFoundError) as e:
        femto.open_cube(missing)
    assert isinstance(e.value, FileNotFoundError)
    assert isinstance(e.value, femto.FemtoError) and isinstance(e.value, ValueError)
    cli = run_cli(femto_bin, "info", missing, check=False)
    assert cli.returncode == 2
    assert str(e.value) in cli.stderr, (str(e.value), cli.stderr)


def test_nan_values_are_refused_naming_the_pixel(tmp_path):
    a = np.zeros((2, 3, 4), np.float32)
    a[1, 2, 3] = np.nan
    p = tmp_path / "nan.h5"
    with h5py.File(p, "w") as f:
        d = f.create_dataset("cube", data=a)
        d.attrs["t0_ps"] = 0.0
        d.attrs["dt_ps"] = 1.0
        d.attrs["time_frame"] = "camera"
    with pytest.raises(femto.FemtoError, match="nan.h5"):
        femto.open_cube(p).data
