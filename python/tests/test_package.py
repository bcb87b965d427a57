"""The package as a user installs it: importable from any folder (python/ included, where
the sources sit beside the crate), a progress bar that reports shares and times, not
rates, and leaves no line behind."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

import femto

REPO = Path(__file__).resolve().parents[2]


def test_import_from_inside_the_python_folder():
    for where in (REPO / "python", REPO):
        p = subprocess.run(
            [sys.executable, "-c", "import femto; print(femto.__file__, femto.__version__)"],
            cwd=where, capture_output=True, text=True,
        )
        assert p.returncode == 0, (where, p.stderr)
        assert p.stdout.split()[1] == femto.__version__


def test_import_from_the_source_folder_says_what_to_do():
    """python/python holds the package's sources, which Python imports first from there. With
    an installed wheel they lack the compiled extension: the import fails in one message that
    says why and what to run (with `maturin develop` the extension sits in the sources and
    the import works)."""
    src = REPO / "python" / "python"
    p = subprocess.run(
        [sys.executable, "-c", "import femto; print(femto.__file__, femto.__version__)"],
        cwd=src, capture_output=True, text=True,
    )
    if list((src / "femto").glob("_femto*")):
        assert p.returncode == 0, p.stderr
        return
    assert p.returncode == 1
    last = p.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: femto: ") and "maturin develop" in last, p.stderr
    assert "Run from any other folder" in last


def test_the_default_progress_bar_shows_no_rate_and_leaves_no_line(tmp_path):
    try:
        import tqdm  # noqa: F401
    except ImportError:
        if os.environ.get("CI") == "true":
            pytest.fail("tqdm is missing (pip install './python[test]'; CI=true)")
        pytest.skip("skipped: tqdm is missing (pip install './python[progress]')")
    import fcntl
    import pty
    import struct
    import termios

    script = (
        "import femto\n"
        f"femto.simulate({str(tmp_path / 'cap')!r}, size=(64, 48), nt=64, spp=256)\n"
        "print('after')\n"
    )
    # tqdm draws to a terminal: the script runs in a pseudo-terminal, read whole.
    pid, fd = pty.fork()
    if pid == 0:
        # A terminal 100 columns wide (a new pseudo-terminal has none: tqdm draws nothing).
        fcntl.ioctl(0, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
        os.environ.update(TERM="xterm")
        os.execv(sys.executable, [sys.executable, "-c", script])
    out = bytearray()
    while True:
        try:
            data = os.read(fd, 65536)
        except OSError:
            break
        if not data:
            break
        out.extend(data)
    _, status = os.waitpid(pid, 0)
    text = out.decode(errors="replace")
    assert os.waitstatus_to_exitcode(status) == 0, text
    assert "rendering" in text or "writing" in text, repr(text)
    assert "it/s" not in text and "s/it" not in text, repr(text)
    # The bar redraws its one line (carriage returns) and clears it at the end: "after" is
    # the first line the terminal shows, with no blank line before it.
    assert text.replace("\r\n", "\n").count("\n") == 1, repr(text)
