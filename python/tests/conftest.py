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


def _flagless(text):
    """`text` with each flag (`--min-peak`, `--no-jitter`) or keyword (`min_peak=`,
    `jitter=False`, `force=True`) reduced to its bare name and every space dropped: what the
    CLI's line and the package's message must share word for word."""
    import re

    text = re.sub(r"(?<![\w-])--([a-z][a-z0-9-]*)", lambda m: m.group(1).replace("-", "_"), text)
    text = re.sub(r"\b([a-z][a-z0-9_]*)=False\b", r"no_\1", text)
    text = re.sub(r"\b([a-z][a-z0-9_]*)=(True\b)?", r"\1", text)
    return re.sub(r"\s+", "", text)


def assert_same_refusal(message, cli_stderr):
    """The package's FemtoError `message` says what `femto` printed (its last line, after
    `femto: error: `), in the caller's spelling: keywords, not flags."""
    line = cli_stderr.strip().splitlines()[-1]
    prefix = "femto: error: "
    assert line.startswith(prefix), line
    assert "--" not in message, f"a flag in the package's message: {message}"
    assert _flagless(message) == _flagless(line[len(prefix):]), (message, line)
