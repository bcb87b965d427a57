"""Shared fixtures: the `femto` binary (to compare the package with the command line) and
a quick demo's data (capture, cube, calibration, world cube with its pyramid, mesh).

The binary is $FEMTO_BIN, else the repository's target/debug/femto or target/release/femto
(whichever is newer). Without one the tests that need it are skipped, and under CI=true
they fail.
"""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _femto_bin():
    env = os.environ.get("FEMTO_BIN")
    if env:
        return Path(env)
    found = [REPO / "target" / p / "femto" for p in ("debug", "release")]
    found = [p for p in found if p.is_file()]
    return max(found, key=lambda p: p.stat().st_mtime) if found else None


def _need(what):
    if os.environ.get("CI") == "true":
        pytest.fail(f"{what} is missing (CI=true: nothing is skipped)")
    pytest.skip(f"skipped: {what} is missing")


@pytest.fixture(scope="session")
def femto_bin():
    b = _femto_bin()
    if b is None or not b.is_file():
        _need("the femto binary (cargo build, or FEMTO_BIN)")
    return b


def run_cli(femto_bin, *args, cwd=None, check=True):
    """Run `femto ARGS`; returns the CompletedProcess (text)."""
    p = subprocess.run(
        [str(femto_bin), *map(str, args)], capture_output=True, text=True, cwd=cwd
    )
    if check and p.returncode != 0:
        raise AssertionError(f"femto {' '.join(map(str, args))}: exit {p.returncode}: {p.stderr}")
    return p


@pytest.fixture(scope="session")
def demo(tmp_path_factory, femto_bin):
    """`femto demo --quick`'s data folder."""
    out = tmp_path_factory.mktemp("demo") / "femto-demo"
    run_cli(femto_bin, "demo", "--quick", "--out", out)
    data = out / "data"
    return {
        "dir": data,
        "capture": data / "capture",
        "cube": data / "cube.h5",
        "world": data / "world.h5",
        "calibration": data / "calibration.toml",
        "mesh": data / "capture" / "scene.glb",
        "points": data / "fiducials_detected.toml",
    }


@pytest.fixture()
def world_copy(demo, tmp_path):
    """A copy of the demo's world cube that a test may change."""
    p = tmp_path / "world.h5"
    shutil.copyfile(demo["world"], p)
    return p
