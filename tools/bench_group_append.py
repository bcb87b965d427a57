#!/usr/bin/env python3
"""Time and bytes written by `femto pyramid CUBE.h5` (adding the `pyramid` group to a cube),
for one or more femto binaries on copies of the same cube.

    python3 tools/bench_group_append.py CUBE.h5 FEMTO [FEMTO ...] [--runs N]

For each binary and run: a fresh copy of CUBE.h5, then `femto pyramid` on it, timed (wall
clock), and once more under strace to sum the bytes of every write/pwrite the process and
its threads make. Prints the median time, the bytes written and the file's growth.
"""

import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def bytes_written(cmd):
    with tempfile.NamedTemporaryFile(suffix=".strace") as log:
        subprocess.run(["strace", "-f", "-qq", "-e", "trace=write,pwrite64,pwritev,pwritev2,"
                        "writev,copy_file_range", "-o", log.name, *cmd], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        total = 0
        for line in open(log.name, errors="replace"):
            m = re.search(r"=\s+(\d+)\s*$", line)
            if m and ("write" in line or "copy_file_range" in line):
                # stdout/stderr writes (fd 1, 2) are the progress lines: not file bytes.
                if re.search(r"\bwritev?\((1|2),", line):
                    continue
                total += int(m.group(1))
        return total


def main(argv):
    runs = 3
    if "--runs" in argv:
        i = argv.index("--runs")
        runs = int(argv[i + 1])
        del argv[i:i + 2]
    cube, femtos = argv[1], argv[2:]
    work = tempfile.mkdtemp(prefix="bench-append-", dir=os.path.dirname(os.path.abspath(cube)))
    try:
        for femto in femtos:
            times = []
            for _ in range(runs):
                c = os.path.join(work, "cube.h5")
                shutil.copyfile(cube, c)
                os.sync()
                t = time.perf_counter()
                subprocess.run([femto, "pyramid", c], check=True, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
                times.append(time.perf_counter() - t)
                grown = os.path.getsize(c) - os.path.getsize(cube)
            c = os.path.join(work, "cube.h5")
            shutil.copyfile(cube, c)
            written = bytes_written([femto, "pyramid", c])
            print(f"{femto}: {statistics.median(times):.2f} s median of {runs} "
                  f"({', '.join(f'{x:.2f}' for x in times)}), {written / 1e6:.1f} MB written, "
                  f"file {os.path.getsize(cube) / 1e6:.1f} -> "
                  f"{(os.path.getsize(cube) + grown) / 1e6:.1f} MB")
    finally:
        shutil.rmtree(work)


if __name__ == "__main__":
    main(sys.argv)
