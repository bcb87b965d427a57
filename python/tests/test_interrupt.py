"""A stage stops at its next progress report when the caller interrupts it (a progress
callback raising, as KeyboardInterrupt does on Ctrl-C), and writes nothing."""

import os
import signal
import threading

import pytest

import femto


class Stop(Exception):
    pass


def test_a_raising_progress_callback_stops_the_render_and_nothing_is_written(demo, tmp_path):
    calls = []

    def stop(what, done, total):
        calls.append((what, done, total))
        raise Stop()

    out = tmp_path / "video.gif"
    with pytest.raises(Stop):
        femto.render(demo["world"], demo["calibration"], demo["mesh"], dolly=0.5,
                     size=(160, 120), frame_count=200, out=out, progress=stop)
    assert calls
    assert not out.exists()
    assert os.listdir(tmp_path) == []


def test_sigint_raises_keyboard_interrupt_during_a_stage(demo, tmp_path):
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            femto.render(demo["world"], demo["calibration"], demo["mesh"], dolly=0.5,
                         size=(160, 120), frame_count=400, out=tmp_path / "v.gif",
                         progress=False)
    finally:
        timer.cancel()
    assert os.listdir(tmp_path) == []
