"""femto.ingest and femto.info on files as instruments and labs write them (issue 44): the
same decisions as the command line, since both call the library's kind decision and array
ingest. A time-first array is refused naming time_axis's flag and read with it; a PicoQuant
PTU scan (../shared/data/real/ptu, skipped without it, a failure under CI=true) gives the
numbers ptufile gave; femto.info lists an .npz file's arrays.
"""

import os
from pathlib import Path

import numpy as np
import pytest

import femto

from conftest import REPO, _need


def test_a_time_first_array_needs_time_axis(tmp_path):
    a = np.arange(64 * 3 * 5, dtype=np.float32).reshape(64, 3, 5)  # (t, y, x)
    src = tmp_path / "tfirst.npy"
    np.save(src, a)
    with pytest.raises(femto.FemtoError, match="time_axis=N"):
        femto.ingest(src, tmp_path / "no.h5", dt_ps=4.0)
    assert not (tmp_path / "no.h5").exists()
    r = femto.ingest(src, tmp_path / "c.h5", dt_ps=4.0, time_axis=0)
    assert r.shape == (3, 5, 64)
    assert "--time-axis 0" in r.layout
    cube = femto.open_cube(tmp_path / "c.h5")
    np.testing.assert_array_equal(np.asarray(cube.data), np.transpose(a, (1, 2, 0)))
    d = femto.info(src)
    assert d["kind"] == "array" and d["stored_shape"] == [64, 3, 5]
    assert "--time-axis" in d["ingest_needs"]


def test_info_lists_npz_arrays_and_describes_one(tmp_path):
    src = tmp_path / "scan.npz"
    np.savez_compressed(src, data=np.ones((2, 3, 8), np.float32), t_ps=np.arange(8.0))
    d = femto.info(src)
    assert any(c.startswith("data [2, 3, 8]") for c in d["candidates"]), d
    one = femto.info(src, dataset="data")
    assert (one["ny"], one["nx"], one["nt"]) == (2, 3, 8)
    r = femto.ingest(src, tmp_path / "c.h5", dataset="data", dt_ps=2.0)
    assert r.shape == (2, 3, 8)


def test_a_real_ptu_scan_equals_ptufile(tmp_path):
    shared = Path(os.environ.get("FEMTO_SHARED", REPO.parent / "shared"))
    ptu = shared / "data" / "real" / "ptu" / "ptu_stack_FLIM_z1.ptu"
    if not ptu.is_file():
        _need(str(ptu))
    r = femto.ingest(ptu, tmp_path / "flim.h5")
    assert r.shape == (256, 256, 133)
    assert abs(r.dt_ps - 96.96969697) < 1e-6
    values = np.asarray(femto.open_cube(tmp_path / "flim.h5").data)
    # ptufile 2026.2.6: 150363 photons, peak bin 12; frame 4 alone 29743.
    assert values.sum() == 150363
    assert int(values.sum(axis=(0, 1)).argmax()) == 12
    one = femto.ingest(ptu, tmp_path / "f4.h5", select={"frame": 4})
    assert np.asarray(femto.open_cube(tmp_path / "f4.h5").data).sum() == 29743
    assert "frame 4 of 5 kept" in one.layout
