#!/usr/bin/env python3
"""Lit frames that `femto view` gets onto the screen of a real browser (headless Chromium).

Starts `femto view` on the given inputs and Chromium through chromedriver (W3C WebDriver,
plain HTTP; Python's standard library only). For each frame size it resets the page to the
capture view at its brightest time, waits for it to settle, and then:

- moving: strafes the camera sideways (an A or D key event every 8 ms, 10 one way and 10
  back), which keeps the scene and its light in view, for SECONDS; the events come faster
  than any frame, so the page is never waiting for one (at 30 ms, the rate was capped at
  33 frames/s);
- playing: presses Play (world time loops over the view's lit range) for SECONDS.

Per phase it prints the frames painted per second that hold light, as the page counts them
(window.femto.litFramesShown: frames whose lit fraction, pixels above 2 of 255 before any
mark, is above 0); the frames painted at all, counted by a wrapper this script injects
around the picture canvas's drawImage, and among them those at the size asked for (a
moving camera gets full-size frames unless the last two took more than 40 ms each, and
reduced ones scaled up otherwise, with a full one every second to measure again); the mean lit fraction
of the painted frames; the size of the last frame received; the femto process's CPU ms per painted frame (utime + stime,
/proc/PID/stat); Chromium's CPU share (all its processes, as a share of the machine's
CPUs); and the load average.

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


def chromium_cpu_ms():
    """CPU ms of every process whose command is Chromium's."""
    total = 0.0
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/comm") as f:
                if "chrom" not in f.read():
                    continue
            total += cpu_ms(pid)
        except OSError:
            continue
    return total


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


COUNTERS = ("const f = window.femto; return [f.litFramesShown, window.__painted || 0, "
            "f.bytesReceived, f.framesDecoded, window.__litSum || 0, window.__full || 0];")
SETTLED = "const f = window.femto; return !!(f && f.hud && f.hud.width === f.state.width && f.settled);"
# Counts every drawImage onto the picture canvas, and sums the lit fraction of the frame
# the page shows with it (read once its heads-up numbers are in, right after the draw).
INJECT = """
if (!window.__painted) {
  window.__painted = 0; window.__litSum = 0; window.__full = 0;
  const ctx = document.getElementById('view').getContext('2d');
  const draw = ctx.drawImage.bind(ctx);
  ctx.drawImage = (...a) => {
    window.__painted += 1;
    // A frame at the size asked for (not a reduced one scaled up).
    if (a[0].width === window.femto.state.width) window.__full += 1;
    setTimeout(() => { const h = window.femto.hud; if (h) window.__litSum += h.lit_fraction; }, 0);
    return draw(...a);
  };
}"""


def phase(driver, pid, seconds, start_js, stop_js):
    driver.wait(SETTLED)
    l0, p0, b0, d0, s0, f0 = driver.run(COUNTERS)
    c0, k0, t0 = cpu_ms(pid), chromium_cpu_ms(), time.time()
    driver.run(start_js)
    time.sleep(seconds)
    l1, p1, b1, d1, s1, f1 = driver.run(COUNTERS)
    c1, k1, t1 = cpu_ms(pid), chromium_cpu_ms(), time.time()
    size = driver.run("const h = window.femto.hud; return `${h.width}x${h.height}`;")
    driver.run(stop_js)
    painted = max(p1 - p0, 1)
    wall = t1 - t0
    return {"lit_per_s": (l1 - l0) / wall, "painted_per_s": (p1 - p0) / wall,
            "full_per_s": (f1 - f0) / wall,
            "lit_fraction": (s1 - s0) / painted, "received": size,
            "bytes_per_frame": (b1 - b0) / max(d1 - d0, 1), "cpu_ms_per_frame": (c1 - c0) / painted,
            "chromium_share": (k1 - k0) / (wall * 1000.0 * os.cpu_count()), "load": load()}


MOVE = """
window.__benchK = 0;
window.__bench = setInterval(() => {
  const code = (window.__benchK++ % 20) < 10 ? 'KeyD' : 'KeyA';
  document.dispatchEvent(new KeyboardEvent('keydown', {code, bubbles: true}));
}, 8);"""
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
        driver.run(INJECT)
        print(f"# femto view in headless Chromium, {args.seconds:.0f} s a phase, "
              f"JPEG quality {args.quality or 'default (85)'}; {os.cpu_count()} CPUs; "
              f"{time.strftime('%Y-%m-%d %H:%M')}")
        print("size      phase    lit frames/s  full size/s  painted/s  lit frac  last size  kB/frame  "
              "femto CPU ms/frame  Chromium CPU  load (1, 5, 15 min)")
        for size in args.sizes.split(","):
            driver.run(f"const s = document.getElementById('size'); s.value = '{size}'; "
                       "s.dispatchEvent(new Event('change', {bubbles: true}));")
            for name, start, stop in [("moving", MOVE, STOP_MOVE), ("playing", PLAY, PLAY)]:
                driver.run("document.getElementById('reset').click();")
                driver.run(f"const s = document.getElementById('size'); s.value = '{size}'; "
                           "s.dispatchEvent(new Event('change', {bubbles: true}));")
                r = phase(driver, view.pid, args.seconds, start, stop)
                print(f"{size:9} {name:8} {r['lit_per_s']:12.1f} {r['full_per_s']:12.1f} "
                      f"{r['painted_per_s']:10.1f} "
                      f"{r['lit_fraction']:9.3f} {r['received']:>10} {r['bytes_per_frame'] / 1000:9.1f} "
                      f"{r['cpu_ms_per_frame']:19.1f} {100 * r['chromium_share']:11.0f} %  {r['load']}",
                      flush=True)
    finally:
        driver.close()
        view.terminate()
        view.wait()


if __name__ == "__main__":
    main()
