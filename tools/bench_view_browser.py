#!/usr/bin/env python3
"""Frames that `femto view` gets onto the screen of a real browser (headless Chromium).

Starts `femto view` on the given inputs and Chromium through chromedriver (W3C WebDriver,
plain HTTP; Python's standard library only), then for each frame size flies the camera for
SECONDS (a W key press every 20 ms, alternating with S, so the page asks for moving frames)
and plays for SECONDS (Play: full-size frames), and prints per phase: frames decoded and
drawn per second (the page's counters, window.femto), bytes per frame, and the femto
process's CPU milliseconds per frame (utime + stime from /proc/PID/stat). The machine's
load average (/proc/loadavg) is printed beside every figure.

    tools/bench_view_browser.py --femto target/release/femto --cube world.h5 \
        --calibration cube.calibration.toml --mesh cap/scene.glb [--quality 85]

Figures: docs/view.md ("Frame rate in the browser").
"""

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cpu_ms(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    ticks = int(fields[11]) + int(fields[12])  # utime, stime (fields 14 and 15)
    return ticks * 1000.0 / os.sysconf("SC_CLK_TCK")


def load():
    with open("/proc/loadavg") as f:
        return "load " + " ".join(f.read().split()[:3])


class Driver:
    def __init__(self, chromium, width, height):
        self.port = free_port()
        self.proc = subprocess.Popen(
            [shutil.which("chromedriver"), f"--port={self.port}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.base = f"http://127.0.0.1:{self.port}"
        self.profile = tempfile.mkdtemp(prefix="femto-bench-")
        for _ in range(200):
            try:
                urllib.request.urlopen(self.base + "/status", timeout=1)
                break
            except OSError:
                time.sleep(0.1)
        caps = {"capabilities": {"alwaysMatch": {"browserName": "chrome", "goog:chromeOptions": {
            "binary": chromium,
            "args": ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                     "--disable-background-networking", f"--window-size={width},{height}",
                     f"--user-data-dir={self.profile}"]}}}}
        self.base += "/session/" + self.call("POST", "/session", caps)["sessionId"]

    def call(self, method, path, body=None):
        data = None if method in ("GET", "DELETE") else json.dumps(body or {}).encode()
        req = urllib.request.Request(self.base + path, data=data, method=method,
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=120) as r:
            return json.loads(r.read())["value"]

    def run(self, script):
        return self.call("POST", "/execute/sync", {"script": script, "args": []})

    def wait(self, script, seconds=120):
        t = time.time()
        while not self.run(script):
            if time.time() - t > seconds:
                sys.exit(f"timed out waiting for: {script}")
            time.sleep(0.05)

    def close(self):
        try:
            self.call("DELETE", "")
        finally:
            self.proc.kill()
            self.proc.wait()
            shutil.rmtree(self.profile, ignore_errors=True)


COUNTERS = "const f = window.femto; return [f.framesDecoded, f.framesShown, f.bytesReceived];"
SETTLED = "const f = window.femto; return !!(f && f.hud && f.hud.width === f.state.width && f.settled);"


def phase(driver, pid, seconds, start_js, stop_js):
    driver.wait(SETTLED)
    d0, s0, b0 = driver.run(COUNTERS)
    c0, t0 = cpu_ms(pid), time.time()
    driver.run(start_js)
    time.sleep(seconds)
    driver.run(stop_js)
    d1, s1, b1 = driver.run(COUNTERS)
    c1, t1 = cpu_ms(pid), time.time()
    frames = max(s1 - s0, 1)
    return {"decoded_per_s": (d1 - d0) / (t1 - t0), "drawn_per_s": (s1 - s0) / (t1 - t0),
            "bytes_per_frame": (b1 - b0) / max(d1 - d0, 1), "cpu_ms_per_frame": (c1 - c0) / frames,
            "load": load()}


MOVE = """
window.__benchW = 0;
window.__bench = setInterval(() => {
  const code = (window.__benchW++ % 40) < 20 ? 'KeyW' : 'KeyS';
  document.dispatchEvent(new KeyboardEvent('keydown', {code, bubbles: true}));
}, 20);"""
STOP_MOVE = "clearInterval(window.__bench);"
PLAY = "document.getElementById('play').click();"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--femto", default="target/release/femto")
    ap.add_argument("--cube", required=True)
    ap.add_argument("--calibration", required=True)
    ap.add_argument("--mesh", required=True)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--sizes", default="640x480,320x240")
    ap.add_argument("--quality", type=int, default=None, help="JPEG quality (default: the server's)")
    args = ap.parse_args()
    chromium = next(filter(None, map(shutil.which, ["chromium", "chromium-browser", "google-chrome"])), None)
    if not chromium or not shutil.which("chromedriver"):
        sys.exit("needs chromium and chromedriver (apt-get install chromium chromium-driver)")
    view = subprocess.Popen([args.femto, "view", "--cube", args.cube, "--calibration", args.calibration,
                             "--mesh", args.mesh, "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    url = view.stdout.readline().strip()
    if not url.startswith("http"):
        view.kill()
        sys.exit(f"femto view did not print its URL: {url!r}")
    driver = Driver(chromium, 1280, 800)
    try:
        driver.call("POST", "/url", {"url": url})
        driver.wait(SETTLED)
        if args.quality:
            driver.run(f"window.femto.quality = {args.quality};")
        print(f"# femto view in headless Chromium, {args.seconds:.0f} s a phase, "
              f"JPEG quality {args.quality or 'default (85)'}; {os.cpu_count()} CPUs")
        print("size      phase    decoded/s  drawn/s  kB/frame  femto CPU ms/frame  load (1, 5, 15 min)")
        for size in args.sizes.split(","):
            driver.run(f"const s = document.getElementById('size'); s.value = '{size}'; "
                       "s.dispatchEvent(new Event('change', {bubbles: true}));")
            for name, start, stop in [("moving", MOVE, STOP_MOVE), ("playing", PLAY, PLAY)]:
                r = phase(driver, view.pid, args.seconds, start, stop)
                print(f"{size:9} {name:8} {r['decoded_per_s']:9.1f} {r['drawn_per_s']:8.1f} "
                      f"{r['bytes_per_frame'] / 1000:9.1f} {r['cpu_ms_per_frame']:19.1f}  {r['load']}",
                      flush=True)
    finally:
        driver.close()
        view.terminate()
        view.wait()


if __name__ == "__main__":
    main()
