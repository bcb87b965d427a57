#!/usr/bin/env python3
"""HPD-TA `.img` files both ways, checked with an independent reader (rosettasciio).

`check(femto, workdir)` returns a list of failure messages (empty: every check passed):

(a) femto -> rosettasciio: `femto simulate` (the cube scene, 32 x 24 pixels, 4 samples per
    pixel) writes every scanline as a 16-bit PNG and a 16-bit `.img` from the same counts,
    then again as a 16-bit PNG and a 32-bit `.img`. Each `.img` is read with
    `rsciio.hamamatsu.file_reader`; its counts must equal, pixel for pixel, its PNG16 twin
    (decoded here with zlib, independently of femto); its size, value range and saturated pixels must equal what
    `femto info --json` reads from the same file; its time axis must equal the manifest's
    `t0_ps + i dt_ps` (and femto's reading) within 1e-6 relative.
(b) HPD-TA -> femto: small `.img` files built here from the documented layout, as HPD-TA
    writes them (a bare sweep-range index as `Time Range`, 8-, 16- and 32-bit pixels, time
    tables in ps, ns, us and ms, a file whose rows are not calibrated), are read by
    rosettasciio (the reference) and by `femto info --json` and `femto ingest`, whose time
    axes must match the numbers put in (the uncalibrated file with `--dt-ps`, after a
    one-line refusal that asks for it).

Run alone: `python3 tools/interop/hpdta.py target/debug/femto` (needs numpy and
rosettasciio); exit code 0 when every check passes, 1 otherwise.
"""

from __future__ import annotations

import glob
import json
import logging
import os
import struct
import subprocess
import sys
import tempfile
import tomllib
import zlib

import numpy as np

REL_TOL = 1e-6


def _run(femto: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([femto, *args], capture_output=True, text=True, timeout=600)


def _info(femto: str, path: str) -> dict:
    r = _run(femto, "info", path, "--json")
    if r.returncode != 0:
        raise RuntimeError(f"femto info {path}: exit {r.returncode}: {r.stderr.strip()}")
    return json.loads(r.stdout)


def read_png16(path: str) -> np.ndarray:
    """A 16-bit grey PNG as an (height, width) array, decoded with zlib (no image library)."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, width = 8, b"", None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if (depth, colour, interlace) != (16, 0, 0):
                raise ValueError(f"{path}: not a 16-bit grey non-interlaced PNG")
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    raw = zlib.decompress(idat)
    bpp, stride = 2, 2 * width
    out = bytearray(height * stride)
    prev = bytearray(stride)
    for row in range(height):
        start = row * (stride + 1)
        ftype, line = raw[start], bytearray(raw[start + 1 : start + 1 + stride])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 0xFF
            elif ftype == 2:
                line[i] = (line[i] + b) & 0xFF
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 0xFF
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 0xFF
            elif ftype != 0:
                raise ValueError(f"{path}: unknown PNG filter {ftype}")
        out[row * stride : (row + 1) * stride] = line
        prev = line
    return np.frombuffer(bytes(out), dtype=">u2").reshape(height, width).astype(np.int64)


def _rsciio(path: str):
    from rsciio.hamamatsu import file_reader

    # rosettasciio warns on every file that lumispy, an optional package, is absent; its
    # logger is set up when rsciio is imported, so quieten it after.
    logging.getLogger("rsciio").setLevel(logging.ERROR)

    (result,) = file_reader(path)
    return result


def _close(a, b, rel: float = REL_TOL) -> bool:
    """`a` equals `b` within `rel` relative (exactly when `b` is 0); None is never close."""
    if a is None or b is None:
        return False
    return abs(a - b) <= rel * abs(b)


def check_femto_files(femto: str, workdir: str) -> list[str]:
    """(a): femto's `.img` files read by rosettasciio, compared with femto's own numbers."""
    failures: list[str] = []
    for fmt in ("img16", "img32"):
        cap = os.path.join(workdir, fmt)
        r = _run(femto, "simulate", "--scene", "cube", "--size", "32x24", "--spp", "4",
                 "--format", f"png16,{fmt}", "--out", cap, "--force")
        if r.returncode != 0:
            failures.append(f"femto simulate --format png16,{fmt}: exit {r.returncode}: "
                            f"{r.stderr.strip()}")
            continue
        failures += _compare_capture(femto, cap)
    return failures


def _compare_capture(femto: str, cap: str) -> list[str]:
    """Every `.img` scanline of the capture `cap` against its PNG16 twin and femto info."""
    failures: list[str] = []
    manifest = tomllib.load(open(os.path.join(cap, "manifest.toml"), "rb"))
    t0_ps, dt_ps = manifest["capture"]["t0_ps"], manifest["capture"]["dt_ps"]
    pngs = sorted(glob.glob(os.path.join(cap, "scanlines", "*.png")))
    if not pngs:
        return [f"{cap}: femto simulate wrote no PNG scanlines"]
    checked = 0
    for png in pngs:
        counts = read_png16(png)
        img_path = png[: -len(".png")] + ".img"
        name = os.path.relpath(img_path, os.path.dirname(cap))
        try:
            res = _rsciio(img_path)
        except Exception as e:  # the reference reader must open the file
            failures.append(f"{name}: rosettasciio failed: {type(e).__name__}: {e}")
            continue
        data = np.asarray(res["data"]).astype(np.int64)
        if data.shape != counts.shape:
            failures.append(f"{name}: rosettasciio shape {data.shape}, PNG16 {counts.shape}")
            continue
        bad = np.argwhere(data != counts)
        if bad.size:
            t, x = bad[0]
            failures.append(
                f"{name}: {len(bad)} counts differ from the PNG16 scanline, first at "
                f"row {t} column {x}: {data[t, x]} vs {counts[t, x]}"
            )
        info = _info(femto, img_path)
        if (info["nx"], info["nt"]) != (data.shape[1], data.shape[0]):
            failures.append(f"{name}: femto reads {info['nx']} x {info['nt']}, "
                            f"rosettasciio {data.shape[1]} x {data.shape[0]}")
        vr = info["value_range"]
        if (vr["min"], vr["max"]) != (float(data.min()), float(data.max())):
            failures.append(f"{name}: femto's value range {vr}, rosettasciio's "
                            f"{data.min()}..{data.max()}")
        top = 65535 if info["pixel_type"] == "u16" else 4294967295
        if info["saturated_pixels"] != int((data >= top).sum()):
            failures.append(f"{name}: femto counts {info['saturated_pixels']} saturated "
                            f"pixels, rosettasciio {(data >= top).sum()}")
        time_axes = [a for a in res["axes"] if a.get("index_in_array") == 0]
        if len(time_axes) != 1 or "axis" not in time_axes[0]:
            failures.append(f"{name}: rosettasciio found no time table: {res['axes']}")
            continue
        ax = time_axes[0]
        if ax["units"] != "ps":
            failures.append(f"{name}: time unit {ax['units']!r}, expected 'ps'")
        times = np.asarray(ax["axis"], dtype=np.float64)
        want = t0_ps + dt_ps * np.arange(times.size)
        err = np.abs(times - want) / np.maximum(np.abs(want), dt_ps)
        if times.size != data.shape[0] or err.max() > REL_TOL:
            failures.append(f"{name}: time axis off the manifest's by {err.max():.3g} "
                            f"relative (first {times[:3]}, want {want[:3]})")
        ta = info["time_axis"] or {}
        if not (_close(ta.get("first_ps"), times[0]) and _close(ta.get("last_ps"), times[-1])):
            failures.append(f"{name}: femto's time axis {ta}, rosettasciio's "
                            f"{times[0]}..{times[-1]}")
        checked += 1
    if checked != len(pngs):
        failures.append(f"{cap}: {checked} of {len(pngs)} .img scanlines checked")
    return failures


# --- (b) files written as HPD-TA writes them -------------------------------------------

HPDTA_SECTIONS = (
    '[Application],Enconding=UTF-8,Date="29/08/2018",Time="10:11:12.000",Software="HPD-TA",'
    'Application=2,SoftwareVersion="9.3 pf5"\r\n'
    '[Acquisition],NrExposure=10,NrTrigger=0,ExposureTime=100 ms,AcqMode={acq},'
    'pntBinning="2,2",BytesPerPixel={bpp},IsLineData=0,BacksubCorr=0,ShadingCorr=0,'
    "ZAxisLabel=Intensity,ZAxisUnit=Count\r\n"
    '[Streak camera],UseDevice=-1,DeviceName="C5680",Time Range="{time_range}",'
    'Mode="{mode}",MCP Gain="40"\r\n'
)


def hpdta_img(path: str, file_type: int, counts: np.ndarray, time_range: str,
              unit: str | None, table: np.ndarray | None, mode: str = "Operate") -> None:
    """Write `counts` (rows = time) as HPD-TA does: the 64-byte header, the comment, the
    pixels, then the float32 time table in `unit` (`None`: rows not calibrated)."""
    dtype = {0: "<u1", 2: "<u2", 3: "<u4"}[file_type]
    h, w = counts.shape
    pixels = counts.astype(dtype).tobytes()
    sections = HPDTA_SECTIONS.format(acq=4, bpp=np.dtype(dtype).itemsize,
                                     time_range=time_range, mode=mode)

    def comment(offset: int) -> str:
        if table is None:
            y = ('ScalingYType=1,ScalingYScale=2,ScalingYUnit="",'
                 'ScalingYScalingFile="Focus mode"')
        else:
            y = (f'ScalingYType=2,ScalingYScale=1,ScalingYUnit="{unit}",'
                 f'ScalingYScalingFile="#{offset},{h:04d}"')
        return (sections + '[Scaling],ScalingXType=1,ScalingXScale=1,ScalingXUnit="",'
                'ScalingXScalingFile="Other",' + y + '[Comment],UserComment=""')

    text = comment(0)
    while True:
        nxt = comment(64 + len(text) + len(pixels))
        if len(nxt) == len(text):
            text = nxt
            break
        text = nxt
    header = struct.pack("<2shhhhhhihhd", b"IM", len(text), w, h, 0, 0, file_type, 0, 0, 0, 0.0)
    header = header.ljust(64, b"\0")
    tail = b"" if table is None else np.asarray(table, dtype="<f4").tobytes()
    with open(path, "wb") as f:
        f.write(header + text.encode() + pixels + tail)


def check_hpdta_files(femto: str, workdir: str) -> list[str]:
    """(b): `.img` files written as HPD-TA does, read by femto with the right axis."""
    failures: list[str] = []
    per_ps = {"ps": 1.0, "ns": 1e3, "us": 1e6, "ms": 1e9}
    h, w = 48, 5
    rows, cols = np.mgrid[0:h, 0:w]
    cases = [
        # name, file type, time range, unit, first, step (in unit), count scale
        ("ps32_index1", 3, "1", "ps", 0.0, 4.7, 70001),
        ("ns16_index4", 2, "4", "ns", 1.5, 0.1, 257),
        ("us16", 2, "20 us", "us", 0.0, 0.002, 3),
        ("ms8", 0, "100 ns", "ms", 0.0, 1e-6, 1),
    ]
    for name, file_type, time_range, unit, first, step, scale in cases:
        path = os.path.join(workdir, name + ".img")
        counts = (rows * 13 + cols * 7) * scale % {0: 251, 2: 65521, 3: 4294967291}[file_type]
        table = (np.float32(first) + np.float32(step) * np.arange(h, dtype=np.float32))
        hpdta_img(path, file_type, counts, time_range, unit, table)
        times_ps = table.astype(np.float64) * per_ps[unit]
        # The reference reader agrees with what was put in.
        res = _rsciio(path)
        if not np.array_equal(np.asarray(res["data"]).astype(np.int64), counts):
            failures.append(f"{name}: rosettasciio reads other counts than were written")
        info = _info(femto, path)
        ta = info.get("time_axis") or {}
        if not (ta.get("nt") == h and _close(ta.get("first_ps"), times_ps[0])
                and _close(ta.get("last_ps"), times_ps[-1])):
            failures.append(f"{name}: femto info time axis {ta}, put in "
                            f"{times_ps[0]}..{times_ps[-1]} ps over {h} rows")
        # femto holds samples as float32 (the cube's type): 32-bit counts above 2^24 round.
        if info["value_range"]["max"] != float(np.float32(counts.max())):
            failures.append(f"{name}: femto reads max {info['value_range']['max']}, "
                            f"put in {counts.max()}")
        failures += _ingest_axis(femto, path, [], times_ps[0],
                                 (times_ps[-1] - times_ps[0]) / (h - 1), h)

    # Rows not calibrated: refused in one line asking for --dt-ps, then read with it.
    path = os.path.join(workdir, "focus_index2.img")
    counts = (rows * 3 + cols) % 251
    hpdta_img(path, 0, counts, "2", None, None, mode="Focus")
    info = _info(femto, path)
    why = (info.get("img") or {}).get("time_uncalibrated") or ""
    if info.get("time_axis") is not None or "ScalingYType=1" not in why:
        failures.append(f"{path}: femto info should say the time axis is not calibrated: "
                        f"{info.get('time_axis')}, {why!r}")
    out = os.path.join(workdir, "refused.h5")
    r = _run(femto, "ingest", path, "-o", out)
    err = r.stderr.strip()
    if r.returncode != 2 or "--dt-ps" not in err or "ScalingYType" not in err or \
            len(err.splitlines()) != 1 or os.path.exists(out):
        failures.append(f"{path}: ingest without --dt-ps: exit {r.returncode}, {err!r}")
    failures += _ingest_axis(femto, path, ["--dt-ps", "2.5"], 0.0, 2.5, h)
    return failures


def _ingest_axis(femto: str, path: str, extra: list[str], t0_ps: float, dt_ps: float,
                 nt: int) -> list[str]:
    out = path[: -len(".img")] + ".h5"
    r = _run(femto, "ingest", path, "-o", out, "--no-jitter", *extra)
    if r.returncode != 0:
        return [f"femto ingest {path} {' '.join(extra)}: exit {r.returncode}: {r.stderr.strip()}"]
    axis = _info(femto, out)["time_axis"]
    ok = axis["nt"] == nt and _close(axis["dt_ps"], dt_ps) and _close(axis["t0_ps"], t0_ps)
    return [] if ok else [f"{path}: cube axis {axis}, want t0 {t0_ps} dt {dt_ps} nt {nt}"]


def check(femto: str, workdir: str) -> list[str]:
    """Both directions; returns the failure messages (empty: pass). A step that cannot go on
    (a command refused, a file unreadable) is one failure message, not an exception."""
    femto = os.path.abspath(femto)
    failures = []
    for name, step in (("femto_to_rsciio", check_femto_files),
                       ("hpdta_to_femto", check_hpdta_files)):
        d = os.path.join(workdir, name)
        os.makedirs(d, exist_ok=True)
        try:
            failures += step(femto, d)
        except Exception as e:
            failures.append(f"{name}: {type(e).__name__}: {e}")
    return failures


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(f"usage: {argv[0]} PATH/TO/femto", file=sys.stderr)
        return 2
    # rosettasciio warns on every file that lumispy is absent; that is not a finding here.
    import rsciio.hamamatsu._api  # noqa: F401 (its logger exists once imported)

    logging.getLogger("rsciio.hamamatsu._api").setLevel(logging.ERROR)
    with tempfile.TemporaryDirectory(prefix="femto-hpdta-") as d:
        failures = check(argv[1], d)
    for f in failures:
        print(f"FAIL: {f}")
    print("hpdta: " + ("ok" if not failures else f"{len(failures)} failures"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
