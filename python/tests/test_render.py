"""femto.render and femto.render_still against the PNG frames `femto render` writes."""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import femto
from conftest import assert_same_refusal, run_cli


def png_frames(folder):
    files = sorted(Path(folder).glob("*.png"))
    assert files, f"no PNG frames in {folder}"
    return np.stack([np.asarray(Image.open(f).convert("RGB")) for f in files])


def cli_render(femto_bin, demo, out, *flags):
    run_cli(
        femto_bin,
        "render",
        "--cube", demo["world"],
        "--calibration", demo["calibration"],
        "--mesh", demo["mesh"],
        "--out", out,
        *flags,
    )
    return png_frames(out)


@pytest.mark.parametrize(
    "kwargs,flags",
    [
        (dict(dolly=0.5, size=(64, 48), frame_count=4),
         ["--dolly", "0.5", "--size", "64x48", "--frame-count", "4"]),
        (dict(orbit=-0.3, size="48x36", frame_count=6, frames="2..5", effects="unwarp,doppler",
              exposure=2.0, radiometry="paper"),
         ["--orbit", "-0.3", "--size", "48x36", "--frame-count", "6", "--frames", "2..5",
          "--effects", "unwarp,doppler", "--exposure", "2", "--radiometry", "paper"]),
        (dict(capture_view=True, size=(40, 30), frame_count=3, view="isochrones"),
         ["--capture-view", "--size", "40x30", "--frame-count", "3", "--view", "isochrones"]),
    ],
)
def test_render_equals_the_cli_png_frames_byte_for_byte(demo, femto_bin, tmp_path, kwargs, flags):
    frames = femto.render(demo["world"], demo["calibration"], demo["mesh"], progress=False, **kwargs)
    ref = cli_render(femto_bin, demo, tmp_path / "frames", *flags)
    assert frames.dtype == np.uint8
    assert frames.shape == ref.shape
    assert np.array_equal(frames, ref)
    assert frames.max() > 0


def test_render_linear_is_the_exr_values_and_out_writes_as_the_cli(demo, tmp_path):
    cube = femto.open_cube(demo["world"])
    lin = femto.render(cube, demo["calibration"], demo["mesh"], dolly=0.4, size=(32, 24),
                       frame_count=2, linear=True, progress=False)
    assert lin.dtype == np.float32 and lin.shape == (2, 24, 32, 3)
    assert np.isfinite(lin).all() and lin.max() > 0
    out = tmp_path / "png"
    result = femto.render(cube, demo["calibration"], demo["mesh"], dolly=0.4, size=(32, 24),
                          frame_count=2, out=out, progress=False)
    assert isinstance(result, femto.RenderResult)
    assert result.frames_written == 2 and (result.width, result.height) == (32, 24)
    srgb = femto.render(cube, demo["calibration"], demo["mesh"], dolly=0.4, size=(32, 24),
                        frame_count=2, progress=False)
    assert np.array_equal(png_frames(out), srgb)


def capture_state(demo, t_world_ps, width=48, height=36):
    cal = tomllib.loads(Path(demo["calibration"]).read_text())
    k, e = cal["intrinsics"], cal["extrinsics"]
    vfov = math.degrees(2 * math.atan(k["height"] / 2 / k["fy"]))
    return {
        "position_m": e["position_m"],
        "world_from_camera": e["world_from_camera"],
        "vfov_deg": vfov,
        "beta": [0.0, 0.0, -0.3],
        "t_world_ps": t_world_ps,
        "dtau_ps": 20.0,
        "width": width,
        "height": height,
        "rotation": None,
        "effects": {k: True for k in
                    ("unwarp", "aberration", "doppler", "searchlight", "dilation", "rotation")},
        "view": "transient",
        "radiometry": "consistent",
        "exposure": 1.0,
        "laser_nm": 670.0,
    }


def test_render_still_equals_the_cli_render_of_the_state_path(demo, femto_bin, tmp_path):
    world = femto.open_cube(demo["world"])
    t_mid = world.t0_ps + 0.5 * world.shape[2] * world.dt_ps
    state = capture_state(demo, t_mid + 2900.0)
    frame = femto.render_still(world, demo["calibration"], demo["mesh"], state)
    assert frame.shape == (36, 48, 3) and frame.dtype == np.uint8
    path = tmp_path / "state.toml"
    path.write_text(femto.state_path_toml(state))
    ref = cli_render(femto_bin, demo, tmp_path / "still", "--path", path, "--laser-nm", "670")
    assert np.array_equal(frame, ref[0])
    assert frame.max() > 0


def test_bad_render_arguments_raise_the_cli_message(demo, femto_bin, tmp_path):
    args = (demo["world"], demo["calibration"], demo["mesh"])
    cases = [
        (dict(dolly=1.5), ["--dolly", "1.5"]),
        (dict(dolly=0.5, exposure=-1), ["--dolly", "0.5", "--exposure=-1"]),
        (dict(dolly=0.5, frame_count=0), ["--dolly", "0.5", "--frame-count", "0"]),
        (dict(dolly=0.5, frame_count=5, frames="3..9"),
         ["--dolly", "0.5", "--frame-count", "5", "--frames", "3..9"]),
    ]
    for kwargs, flags in cases:
        with pytest.raises(femto.FemtoError) as e:
            femto.render(*args, progress=False, **kwargs)
        cli = run_cli(femto_bin, "render", "--cube", args[0], "--calibration", args[1],
                      "--mesh", args[2], "--out", tmp_path / "x", *flags, check=False)
        assert cli.returncode == 2
        assert_same_refusal(str(e.value), cli.stderr)
    with pytest.raises(femto.FemtoError, match="exactly one camera"):
        femto.render(*args, dolly=0.2, orbit=0.2)
    with pytest.raises(femto.FemtoFileNotFoundError, match="missing.h5"):
        femto.render(tmp_path / "missing.h5", args[1], args[2], dolly=0.2)
    with pytest.raises(femto.FemtoError, match="missing.glb"):
        femto.render(args[0], args[1], tmp_path / "missing.glb", dolly=0.2)
