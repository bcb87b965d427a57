"""Arguments are validated exactly, never truncated or converted (issue 47): a fractional
size or count, a stepped range, a negative level, a non-bool switch are FemtoErrors naming
the keyword; a library refusal names the keyword as the caller spelled it."""

import os

import numpy as np
import pytest

import femto
from conftest import run_cli

SMALL = dict(size=(16, 12), nt=32, spp=2, progress=False)


@pytest.mark.parametrize(
    "kwargs,words",
    [
        (dict(spp=2.5), "spp=2.5: expected a whole number, not a fraction"),
        (dict(spp=True), "spp=True: expected a whole number"),
        (dict(spp="4"), "spp='4': expected a whole number"),
        (dict(spp=-1), "spp=-1: must be at least 0"),
        (dict(seed=1.5), "seed=1.5"),
        (dict(bounces=2.5), "bounces=2.5"),
        (dict(nt=32.5), "nt=32.5"),
        (dict(size=(64.5, 48)), "size=(64.5, 48): expected WIDTHxHEIGHT"),
        (dict(size=(0, 48)), "size=(0, 48): expected WIDTHxHEIGHT"),
        (dict(size="64.5x48"), "size='64.5x48': expected WIDTHxHEIGHT"),
        (dict(rows=range(0, 12, 2)), "rows=range(0, 12, 2): a range of step 2"),
        (dict(rows=(-1, 5)), "rows=(-1, 5): expected A..B with 0 <= A < B"),
        (dict(rows=(0.5, 5)), "rows=(0.5, 5)"),
        (dict(realistic=1), "realistic=1: expected True or False"),
        (dict(sweep="0.1"), "sweep='0.1': expected a number"),
        (dict(dark=(0.1,)), "dark=(0.1,): expected two numbers"),
        (dict(rr_start_bounce=1.5, transient_only=True), "rr_start_bounce=1.5"),
    ],
)
def test_simulate_refuses_inexact_arguments_naming_the_keyword(tmp_path, kwargs, words):
    with pytest.raises(femto.FemtoError) as e:
        femto.simulate(tmp_path / "cap", **{**SMALL, **kwargs})
    assert words in str(e.value), str(e.value)
    assert os.listdir(tmp_path) == []


def test_an_integral_float_is_its_whole_number(tmp_path):
    r = femto.simulate(tmp_path / "cap", **{**SMALL, "spp": 2.0, "size": (16.0, 12)})
    assert r.spp == 2 and r.shape == (12, 16, 32) and "--spp=2" in r.command


def test_render_refuses_a_stepped_range_and_a_fractional_size(demo, tmp_path):
    args = (demo["world"], demo["calibration"], demo["mesh"])
    for kwargs, words in [
        (dict(frames=range(0, 4, 2)), "frames=range(0, 4, 2): a range of step 2"),
        (dict(size=(64.5, 48)), "size=(64.5, 48): expected WIDTHxHEIGHT"),
        (dict(frame_count=10.5), "frame_count=10.5: expected a whole number"),
        (dict(frame_count=-3), "frame_count=-3: must be at least 0"),
        (dict(frames="a..b"), "frames='a..b': expected A..B"),
        (dict(exposure="2"), "exposure='2': expected a number"),
        (dict(linear=1), "linear=1: expected True or False"),
    ]:
        with pytest.raises(femto.FemtoError) as e:
            femto.render(*args, dolly=0.5, progress=False, **{"frame_count": 4, **kwargs})
        assert words in str(e.value), (kwargs, str(e.value))
    frames = femto.render(*args, dolly=0.5, size=(32, 24), frame_count=4,
                          frames=range(1, 3), progress=False)
    assert frames.shape == (2, 24, 32, 3)


def test_pyramid_levels_are_whole_and_not_negative(world_copy):
    for levels, words in [(1.5, "levels=1.5: expected a whole number, not a fraction"),
                          (-1, "levels=-1: must be at least 0")]:
        with pytest.raises(femto.FemtoError) as e:
            femto.pyramid(world_copy, levels=levels, progress=False)
        assert str(e.value).startswith(words), str(e.value)


def test_library_refusals_name_the_keyword_not_the_flag(demo, femto_bin, world_copy, tmp_path):
    # The library's words, with the flag written as the keyword: --levels 40 as levels=40.
    with pytest.raises(femto.FemtoError) as e:
        femto.pyramid(world_copy, levels=40, progress=False)
    cli = run_cli(femto_bin, "pyramid", world_copy, "--levels", "40", check=False)
    line = cli.stderr.strip().splitlines()[-1]
    flag = "femto: error: --levels 40"
    assert line.startswith(flag), line
    assert str(e.value) == "levels=40" + line[len(flag):]
    # An existing output: out=..., force=True.
    out = tmp_path / "w.h5"
    out.write_bytes(b"mine")
    with pytest.raises(femto.FemtoError) as e:
        femto.unwarp(demo["cube"], out, progress=False)
    assert str(e.value).startswith(f"out={out}: ") and "add force=True" in str(e.value)
    assert "--" not in str(e.value) and out.read_bytes() == b"mine"
    # calibrate's floor: min_peak=, not --min-peak.
    with pytest.raises(femto.FemtoError) as e:
        femto.calibrate(demo["cube"], mesh=demo["mesh"], points=demo["points"],
                        laser=[-0.13, 0.06, -0.07], min_peak=-1.0, out=tmp_path / "c.toml",
                        progress=False)
    assert "min_peak" in str(e.value) and "--min-peak" not in str(e.value), str(e.value)


def test_keyword_spelling_rules():
    from femto._errors import keyword_spelling

    kw = dict(levels=None, out=None, force=False, min_peak=None, jitter=True, size=None,
              paper_size=False, nt=None, spp=64)
    for message, spelled in [
        ("--levels 40: must be at most 12", "levels=40: must be at most 12"),
        ("--out c.h5: file exists; add --force to replace it",
         "out=c.h5: file exists; add force=True to replace it"),
        ("raise --min-peak, or check the laser", "raise min_peak=, or check the laser"),
        ("--paper-size cannot be used with --size, --nt or --dt-ps",
         "paper_size=True cannot be used with size=, nt= or --dt-ps"),
        ("--no-jitter keeps the offsets", "jitter=False keeps the offsets"),
        ("--spp: must be at least 1", "spp: must be at least 1"),
        ("--threads 2: no such keyword here", "--threads 2: no such keyword here"),
    ]:
        assert keyword_spelling(message, kw) == spelled


def test_cube_from_array_refuses_before_writing(tmp_path):
    p = tmp_path / "nan.h5"
    a = np.zeros((4, 5, 6), np.float32)
    a[2, 3, 4] = np.nan
    with pytest.raises(femto.FemtoError) as e:
        femto.cube_from_array(a, 2.0, 0.0, p)
    assert str(e.value).endswith("nan.h5: cube has NaN at x 3, y 2, bin 4"), str(e.value)
    b = np.zeros((4, 5, 6))
    b[0, 1, 2] = -np.inf
    with pytest.raises(femto.FemtoError, match="cube has -inf at x 1, y 0, bin 2"):
        femto.cube_from_array(b, 2.0, 0.0, p)
    b[0, 1, 2] = 1e39  # finite in float64, beyond float32
    with pytest.raises(femto.FemtoError, match=r"array\[0, 1, 2\] = 1e\+39: beyond float32"):
        femto.cube_from_array(b, 2.0, 0.0, p)
    for bad, words in [
        (np.zeros((4, 5, 6), complex), "dtype complex128"),
        (np.zeros((4, 5, 6), bool), "dtype bool"),
        (np.full((4, 5, 6), "1"), "dtype <U1"),
        (np.zeros((4, 5, 6), object), "dtype object"),
        (np.zeros((4, 5)), "3 dimensions"),
        (np.zeros((0, 5, 6)), "at least one pixel and one bin"),
    ]:
        with pytest.raises(femto.FemtoError, match=words):
            femto.cube_from_array(bad, 2.0, 0.0, p)
    good = np.ones((4, 5, 6), np.float32)
    for mask, words in [
        (np.full((4, 5), 2), r"mask\[0, 0\] = 2: expected 0 or 1"),
        (np.full((4, 5), 0.5), "mask: an array of dtype float64"),
        (np.ones((5, 4), np.uint8), r"mask of shape \(5, 4\)"),
    ]:
        with pytest.raises(femto.FemtoError, match=words):
            femto.cube_from_array(good, 2.0, 0.0, p, mask=mask)
    for dt, t0, words in [(float("nan"), 0.0, "dt_ps"), (2.0, float("inf"), "t0_ps inf"),
                          ("2", 0.0, "dt_ps='2': expected a number")]:
        with pytest.raises(femto.FemtoError, match=words):
            femto.cube_from_array(good, dt, t0, p)
    assert os.listdir(tmp_path) == []
    # Integers are real numbers; a boolean mask is a mask.
    c = femto.cube_from_array(np.arange(120).reshape(4, 5, 6), 2.0, 0.0, p,
                              mask=np.ones((4, 5), bool))
    assert c.data.dtype == np.float32 and c.data[3, 4, 5] == 119 and c.mask.all()
