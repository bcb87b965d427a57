#!/usr/bin/env python3
"""Run the examples of README.md and docs/*.md as written (issue 47).

Every ```python block of README.md and of docs/*.md runs, the blocks of one document in
order in one namespace, in a scratch folder that holds what the document tells its reader
to have first:

- README.md: `femto-demo/` of the demo (its Quick start; `--quick` here, the same files);
- docs/cube-format.md: a cube file `cube.h5` with a pyramid (the demo's world cube);
- any other document: nothing (docs/python.md's first block makes its own capture).

After a document's blocks, the check of what the text says they produce runs (README.md:
the saved figure; docs/python.md: light in the window it integrates, the frames' shape).
Figures go to files (matplotlib's Agg backend). With --slurm, the sh block of docs/cluster.md's
"Try it on one machine" runs too, with bash, from the repository's root (its /tmp folders
removed first; a `sudo` that runs the command itself when run as root without sudo).

A document whose python blocks this script does not know is run all the same, in an empty
folder: a new example cannot be skipped by omission.

usage: python tools/doc_examples.py --femto target/release/femto [--slurm|--slurm-only]
           [--keep DIR]
Run it with the Python that has the femto package installed (a fresh venv in .ci/run).
Exit status 1 when an example fails, with the document, the block and the error.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Callable, Dict, List

REPO = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def documents() -> List[Path]:
    return [REPO / "README.md"] + sorted((REPO / "docs").glob("*.md"))


def python_blocks(path: Path) -> List[str]:
    return BLOCK.findall(path.read_text())


def demo(femto: str, where: Path) -> Path:
    """`femto demo --quick --out femto-demo` in `where` (the README's folder, quickly)."""
    out = where / "femto-demo"
    subprocess.run([femto, "demo", "--quick", "--out", str(out)], check=True,
                   stdout=subprocess.DEVNULL)
    return out


def setup_readme(femto: str, scratch: Path, cache: Dict[str, Path]) -> None:
    shutil.copytree(cache["demo"], scratch / "femto-demo")


def setup_cube_format(femto: str, scratch: Path, cache: Dict[str, Path]) -> None:
    shutil.copyfile(cache["demo"] / "data" / "world.h5", scratch / "cube.h5")


def check_readme(ns: dict, scratch: Path) -> None:
    figure = scratch / "frame.png"
    assert figure.is_file() and figure.stat().st_size > 1000, "no frame.png saved"
    assert ns["frames"].shape == (1, 240, 320, 3), ns["frames"].shape
    assert ns["frames"].max() > 0, "a black frame"


def check_python(ns: dict, scratch: Path) -> None:
    assert ns["light"].max() > 0, "no light in the window the example integrates"
    assert ns["frames"].shape == (60, 480, 640, 3), ns["frames"].shape
    assert ns["frames"].max() > 0, "black frames"


def check_cube_format(ns: dict, scratch: Path) -> None:
    assert (scratch / "mine.h5").is_file(), "mine.h5 not written"
    assert ns["P"].shape[2] == ns["nt"] + 1, ns["P"].shape


SETUP: Dict[str, Callable[[str, Path, Dict[str, Path]], None]] = {
    "README.md": setup_readme,
    "cube-format.md": setup_cube_format,
}
CHECK: Dict[str, Callable[[dict, Path], None]] = {
    "README.md": check_readme,
    "python.md": check_python,
    "cube-format.md": check_cube_format,
}


def run_python(doc: Path, femto: str, work: Path, cache: Dict[str, Path]) -> bool:
    blocks = python_blocks(doc)
    if not blocks:
        return True
    rel = doc.relative_to(REPO)
    scratch = work / doc.stem
    scratch.mkdir()
    SETUP.get(doc.name, lambda *a: None)(femto, scratch, cache)
    ns: dict = {"__name__": "__main__"}
    old = os.getcwd()
    os.chdir(scratch)
    started = time.monotonic()
    try:
        for i, block in enumerate(blocks, 1):
            try:
                exec(compile(block, f"{rel} python block {i}", "exec"), ns)
            except BaseException:
                print(f"FAIL {rel}: python block {i} of {len(blocks)}:\n{block}", file=sys.stderr)
                traceback.print_exc()
                return False
        check = CHECK.get(doc.name)
        if check is not None:
            try:
                check(ns, scratch)
            except AssertionError as e:
                print(f"FAIL {rel}: what the text says its examples give: {e}", file=sys.stderr)
                return False
    finally:
        os.chdir(old)
        try:
            import matplotlib.pyplot as plt

            plt.close("all")
        except ImportError:
            pass
    print(f"ok   {rel}: {len(blocks)} python block(s) in {time.monotonic() - started:.1f} s")
    return True


def section_block(doc: Path, heading: str, lang: str = "sh") -> str:
    text = doc.read_text()
    section = text.split(f"\n## {heading}\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(rf"^```{lang}\n(.*?)^```", section, re.S | re.M)
    assert len(blocks) == 1, f"{doc}: one {lang} block under '{heading}'"
    return blocks[0]


def run_slurm() -> bool:
    doc = REPO / "docs" / "cluster.md"
    block = section_block(doc, "Try it on one machine")
    for d in re.findall(r"(/tmp/[\w.-]+)", block):
        shutil.rmtree(d, ignore_errors=True)
    prelude = "set -euo pipefail\n"
    if os.geteuid() == 0 and shutil.which("sudo") is None:
        prelude += 'sudo() { "$@"; }\n'
    started = time.monotonic()
    p = subprocess.run(["bash", "-c", prelude + block], cwd=REPO)
    if p.returncode != 0:
        print(f"FAIL docs/cluster.md, 'Try it on one machine': exit {p.returncode}",
              file=sys.stderr)
        subprocess.run(["bash", "tools/slurm/one-node.sh", "stop", "/tmp/femto-slurm"],
                       cwd=REPO)
        return False
    print(f"ok   docs/cluster.md: 'Try it on one machine' in {time.monotonic() - started:.1f} s")
    return True


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--femto", required=True, help="the femto binary (for the demo's files)")
    ap.add_argument("--slurm", action="store_true",
                    help="also run docs/cluster.md's 'Try it on one machine' block")
    ap.add_argument("--slurm-only", action="store_true",
                    help="run docs/cluster.md's 'Try it on one machine' block alone (its "
                    "`cargo build --release` needs the toolchain the python examples must not)")
    ap.add_argument("--keep", type=Path, help="scratch folder to keep (default: a temporary one)")
    args = ap.parse_args()
    if args.slurm_only:
        return 0 if run_slurm() else 1
    os.environ.setdefault("MPLBACKEND", "Agg")
    femto = str(Path(args.femto).resolve())
    work = args.keep or Path(tempfile.mkdtemp(prefix="femto-doc-examples-"))
    work.mkdir(parents=True, exist_ok=True)
    cache = {"demo": demo(femto, work / "cache")}
    ok = all([run_python(doc, femto, work, cache) for doc in documents()])
    if args.slurm:
        ok = run_slurm() and ok
    if args.keep is None:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
