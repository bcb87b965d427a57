"""femto.simulate against `femto simulate`: same flags, same files (but for the provenance,
which records who asked: the command line, or "python: femto.simulate"), same messages."""

import json
import os
from pathlib import Path

import h5py
import numpy as np
import pytest

import femto
from conftest import assert_same_refusal, run_cli

# The built-in cube scene, small: 16 x 12 pixels, 32 bins, 2 paths per pixel.
SMALL = dict(size=(16, 12), nt=32, spp=2)
SMALL_FLAGS = ["--size", "16x12", "--nt", "32", "--spp", "2"]


def small_flags_but(kwargs):
    """SMALL_FLAGS without the flags of the keyword arguments `kwargs` sets."""
    pairs = zip(SMALL_FLAGS[::2], SMALL_FLAGS[1::2])
    return [x for f, v in pairs if f[2:].replace("-", "_") not in kwargs for x in (f, v)]
PROVENANCE = "python: femto.simulate"


def files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in Path(folder).rglob("*") if p.is_file())


def h5_contents(path):
    """Every dataset's values and every attribute, but the cube's command_line."""
    out = {}
    with h5py.File(path, "r") as f:
        out["/"] = {k: str(v) for k, v in f.attrs.items()}

        def visit(name, obj):
            attrs = {k: str(v) for k, v in obj.attrs.items() if k != "command_line"}
            data = obj[...].tobytes() if isinstance(obj, h5py.Dataset) else None
            out[name] = (attrs, data)

        f.visititems(visit)
    return out


def assert_same_capture(py, cli):
    """The folders hold the same files, byte for byte, except where the provenance is: the
    manifest's created_by line and the HDF5 cubes' command_line attribute (whose length moves
    the bytes after it), compared without it."""
    assert files(py) == files(cli)
    for name in files(py):
        a, b = Path(py, name), Path(cli, name)
        if name.endswith(".h5"):
            assert h5_contents(a) == h5_contents(b), name
        elif name == "manifest.toml":
            drop = lambda text: [l for l in text.splitlines() if not l.startswith("created_by")]
            assert f'created_by = "{PROVENANCE}"' in a.read_text()
            assert drop(a.read_text()) == drop(b.read_text())
        else:
            assert a.read_bytes() == b.read_bytes(), name


def test_a_capture_equals_the_clis(femto_bin, tmp_path):
    seen = []
    r = femto.simulate(tmp_path / "py", realistic=True, sweep=0.1, format="png16,exr",
                       progress=lambda what, done, total: seen.append((what, done, total)),
                       **SMALL)
    out = run_cli(femto_bin, "simulate", "--out", tmp_path / "cli", "--realistic", "--sweep",
                  "0.1", "--format", "png16,exr", *SMALL_FLAGS).stdout
    assert_same_capture(tmp_path / "py", tmp_path / "cli")
    # The figures the command prints.
    assert f"scene cube, 16 x 12 pixels, 32 bins of {r.dt_ps:g} ps" in out
    assert f"paths: {r.paths} ({r.rays} rays)" in out
    assert (f"files: {len(r.files)} ({r.streak_images} streak images in scanlines/, "
            f"{r.fiducials} fiducials)") in out
    assert r.shape == (12, 16, 32) and r.streak_images == 24 and r.paths == 16 * 12 * 2
    assert {w for w, _, _ in seen} <= {"rendering", "writing"} and seen


def test_transient_only_and_bands_equal_the_clis(femto_bin, tmp_path):
    femto.simulate(tmp_path / "py", transient_only=True, time_filter="box", progress=False,
                   **SMALL)
    run_cli(femto_bin, "simulate", "--out", tmp_path / "cli", "--transient-only",
            "--time-filter", "box", *SMALL_FLAGS)
    assert files(tmp_path / "py") == ["render.json", "truth_camera.h5"]
    # render.json holds the render's counters and its timings, which differ run to run.
    assert h5_contents(tmp_path / "py/truth_camera.h5") == h5_contents(
        tmp_path / "cli/truth_camera.h5")

    # Russian roulette from another bounce (to match another renderer): the same cube as the
    # command's, and render.json records it.
    r = femto.simulate(tmp_path / "py_rr", transient_only=True, time_filter="box",
                       rr_start_bounce=1, bounces=3, progress=False, **SMALL)
    run_cli(femto_bin, "simulate", "--out", tmp_path / "cli_rr", "--transient-only",
            "--time-filter", "box", "--rr-start-bounce", "1", "--bounces", "3", *SMALL_FLAGS)
    assert r.rr_start_bounce == 1
    assert json.loads((tmp_path / "py_rr/render.json").read_text())["rr_start_bounce"] == 1
    assert h5_contents(tmp_path / "py_rr/truth_camera.h5") == h5_contents(
        tmp_path / "cli_rr/truth_camera.h5")
    assert h5_contents(tmp_path / "py_rr/truth_camera.h5") != h5_contents(
        tmp_path / "py/truth_camera.h5")

    # Two bands made in Python, merged by the command, equal its one-process capture.
    bands = [tmp_path / "b0", tmp_path / "b1"]
    femto.simulate(bands[0], rows="0..5", progress=False, **SMALL)
    b = femto.simulate(bands[1], rows=range(5, 12), progress=False, **SMALL)
    assert b.rows == (5, 12) and "--rows=5..12" in b.command
    run_cli(femto_bin, "merge", *bands, "--out", tmp_path / "merged")
    run_cli(femto_bin, "simulate", "--out", tmp_path / "whole", *SMALL_FLAGS)
    for name in files(tmp_path / "whole"):
        if name.endswith(".h5"):
            assert h5_contents(tmp_path / "merged" / name) == h5_contents(
                tmp_path / "whole" / name), name
        elif name != "manifest.toml":
            assert (tmp_path / "merged" / name).read_bytes() == (
                tmp_path / "whole" / name).read_bytes(), name


@pytest.mark.parametrize(
    "kwargs,flags",
    [
        (dict(sweep=1.5), ["--sweep", "1.5"]),
        (dict(dark=(0.1, -1.0)), ["--dark=0.1,-1"]),
        (dict(photon_noise=0.0), ["--photon-noise", "0"]),
        (dict(scene="nosuch"), ["--scene", "nosuch"]),
        (dict(scene="bunny"), ["--scene", "bunny"]),
        (dict(format="img16,img32"), ["--format", "img16,img32"]),
        (dict(rows="0..99"), ["--rows", "0..99"]),
        (dict(spp=0), ["--spp", "0"]),
        (dict(size="0x10"), ["--size", "0x10"]),
        (dict(rr_start_bounce=0, transient_only=True), ["--rr-start-bounce", "0", "--transient-only"]),
    ],
)
def test_bad_arguments_raise_the_cli_message(femto_bin, tmp_path, kwargs, flags):
    args = {**SMALL, **kwargs}
    with pytest.raises(femto.FemtoError) as e:
        femto.simulate(tmp_path / "cap", progress=False, **args)
    cli = run_cli(femto_bin, "simulate", "--out", tmp_path / "cap", *small_flags_but(kwargs),
                  *flags, check=False)
    assert cli.returncode == 2
    line = cli.stderr.strip().splitlines()[-1]
    if "invalid value" in line:
        # A value clap's parser refused: clap words the line; the command names the flag,
        # the package the keyword.
        flag = flags[0].split("=")[0]
        keyword = flag.lstrip("-").replace("-", "_")
        assert str(e.value).startswith(keyword) and flag in line, (str(e.value), line)
    else:
        assert_same_refusal(str(e.value), cli.stderr)
    assert os.listdir(tmp_path) == []


def test_an_existing_folder_is_refused_unless_forced(femto_bin, tmp_path):
    cap = tmp_path / "cap"
    cap.mkdir()
    (cap / "keep.txt").write_text("mine")
    with pytest.raises(femto.FemtoError) as e:
        femto.simulate(cap, progress=False, **SMALL)
    cli = run_cli(femto_bin, "simulate", "--out", cap, *SMALL_FLAGS, check=False)
    assert_same_refusal(str(e.value), cli.stderr)
    assert "force=True" in str(e.value) and (cap / "keep.txt").read_text() == "mine"
    femto.simulate(cap, force=True, progress=False, **SMALL)
    assert not (cap / "keep.txt").exists() and (cap / "manifest.toml").is_file()


def test_missing_scene_and_mesh_files_raise_file_not_found(femto_bin, demo, tmp_path,
                                                            monkeypatch):
    monkeypatch.chdir(tmp_path)
    for kwargs, flags in [
        (dict(scene="missing.toml"), ["--scene", "missing.toml"]),
        (dict(scene="bunny", bunny="missing.obj"), ["--scene", "bunny", "--bunny", "missing.obj"]),
    ]:
        with pytest.raises(FileNotFoundError) as e:
            femto.simulate("cap", progress=False, **kwargs)
        assert isinstance(e.value, femto.FemtoFileNotFoundError) and e.value.errno == 2
        cli = run_cli(femto_bin, "simulate", "--out", "cap", *flags, check=False, cwd=tmp_path)
        assert_same_refusal(str(e.value), cli.stderr)
    for mesh in ["missing.glb", "missing.obj"]:
        with pytest.raises(femto.FemtoFileNotFoundError) as e:
            femto.calibrate(demo["cube"], mesh=mesh, points=demo["points"],
                            laser=[-0.13, 0.06, -0.07], out=tmp_path / "cal.toml")
        assert isinstance(e.value, FileNotFoundError) and e.value.errno == 2
        assert str(e.value) == f"{mesh}: No such file or directory (os error 2)"
    assert os.listdir(tmp_path) == []


def test_help_gives_the_units():
    doc = femto.simulate.__doc__
    for words in ["dt_ps", "bin width in ps", "metres", "femto simulate"]:
        assert words in doc
