"""tools/noise_split.py --by-bounce runs end to end, in small, as a user runs it: femto's
per-bin variance of peer_cornell split by bounce count, from renders cut at 1, 2, 3 and all
bounces with the same seeds. The parts are differences of those renders, so their totals must
add up to the whole light's total (to float rounding); each part's share and the allocation
bound must be finite, the bound at least 1. The figures of a small run mean nothing; this keeps
the script working (the real split: `python3 tools/noise_split.py --by-bounce`, figures in
benches/tracer_results.md).
"""

import math
import os
import re
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "noise_split.py")
NUMBER = r"([-+0-9.eE]+|nan|inf)"


def check(femto, work):
    cmd = [sys.executable, SCRIPT, "--by-bounce", "--femto", femto, "--scenes", "peer_cornell",
           "--spp", "4", "--seeds", "3"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    print(r.stdout.strip())
    if r.returncode != 0:
        return [f"noise_split.py exited {r.returncode}: {r.stderr.strip().splitlines()[-1:]}"]
    failures = []
    whole = re.search(rf"whole light: per-bin variance {NUMBER}, total {NUMBER}", r.stdout)
    parts = re.findall(rf"bounces?: per-bin variance {NUMBER} \(\s*{NUMBER} %\), total {NUMBER}", r.stdout)
    bound = re.search(rf"at most {NUMBER}x", r.stdout)
    if not (whole and bound) or len(parts) != 4:
        return [f"unexpected output ({len(parts)} parts, expected 4): {r.stdout[-400:]}"]
    total = float(whole.group(2))
    summed = sum(float(p[2]) for p in parts)
    if not math.isclose(summed, total, rel_tol=1e-4):
        failures.append(f"the parts' totals add to {summed}, the whole's is {total}")
    for var, share, _ in parts:
        if not (math.isfinite(float(var)) and float(var) >= 0 and math.isfinite(float(share))):
            failures.append(f"part variance {var}, share {share} %: not finite")
    if not (math.isfinite(float(bound.group(1))) and float(bound.group(1)) >= 1.0):
        failures.append(f"allocation bound {bound.group(1)}x: not finite and at least 1")
    return failures
