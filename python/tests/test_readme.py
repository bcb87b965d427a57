"""The README's "From Python" example runs as written on a quick demo's folder, with
matplotlib's Agg backend: it saves the frame to frame.png (tools/doc_examples.py runs it, and
every other Python example of the docs, in .ci/run's fresh venv)."""

import os
import re
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).resolve().parents[2] / "README.md"


def readme_example():
    text = README.read_text()
    section = text.split("## From Python", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) == 1, "one python block in README's From Python"
    return blocks[0]


def test_the_readme_example_runs_and_saves_its_figure(demo, tmp_path, monkeypatch):
    try:
        import matplotlib

        matplotlib.use("Agg")
    except ImportError:
        if os.environ.get("CI") == "true":
            pytest.fail("matplotlib is missing (pip install './python[plot]'; CI=true)")
        pytest.skip("skipped: matplotlib is missing (pip install './python[plot]')")
    # The demo fixture's folder is .../femto-demo/data, as the README's paths expect.
    work = tmp_path / "readme"
    work.mkdir()
    (work / "femto-demo").symlink_to(Path(demo["dir"]).parent)
    monkeypatch.chdir(work)
    ns = {"__name__": "readme"}
    exec(compile(readme_example(), "README.md", "exec"), ns)
    frame = ns["frames"][0]
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8 and frame.max() > 0
    assert (work / "frame.png").stat().st_size > 1000
