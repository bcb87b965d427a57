"""The README's "From Python" example runs as written (on a quick demo's folder), with
matplotlib replaced by a recorder so that nothing is shown."""

import re
import sys
import types
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[2] / "README.md"


def readme_example():
    text = README.read_text()
    section = text.split("## From Python", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) == 1, "one python block in README's From Python"
    return blocks[0]


def test_the_readme_example_runs(demo, monkeypatch):
    shown = []
    pyplot = types.ModuleType("matplotlib.pyplot")
    pyplot.imshow = lambda image, **kw: shown.append(("imshow", np.asarray(image)))
    pyplot.show = lambda **kw: shown.append(("show", None))
    matplotlib = types.ModuleType("matplotlib")
    matplotlib.pyplot = pyplot
    monkeypatch.setitem(sys.modules, "matplotlib", matplotlib)
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", pyplot)
    # The demo fixture's folder is .../femto-demo/data, as the README's paths expect.
    monkeypatch.chdir(Path(demo["dir"]).parent.parent)
    exec(compile(readme_example(), "README.md", "exec"), {"__name__": "readme"})
    assert [k for k, _ in shown] == ["imshow", "show"]
    frame = shown[0][1]
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8 and frame.max() > 0
