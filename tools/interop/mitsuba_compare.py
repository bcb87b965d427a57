"""tools/compare_mitsuba.py runs end to end, in small, as a user runs it (its own process: a
Mitsuba variant is chosen once per process, and other checks choose another): femto's
`simulate --transient-only --time-filter box` and Mitsuba + mitransient on the same scene
files (peer_cornell), with a common reference of 64 spp each. The two renderers' totals
agree within 1 %, their whole-image histograms start and peak in the same bin, and every
speed ratio comes out finite and positive. The figures of a small run mean nothing; this
keeps the script working (the real comparison: `python3 tools/compare_mitsuba.py`, figures
in benches/tracer_results.md).
"""

import json
import math
import os
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "compare_mitsuba.py")


def check(femto, work):
    out = os.path.join(work, "compare.json")
    cmd = [sys.executable, SCRIPT, "--femto", femto, "--scenes", "peer_cornell", "--sampler", "independent,multijitter",
           "--spp", "4", "--seeds", "1", "--ref-spp", "64", "--timing-spp", "16,256", "--timing-runs", "1", "--no-other-roulette", "--json", out]
    r = subprocess.run(cmd, capture_output=True, text=True)
    print("\n".join(ln for ln in r.stdout.splitlines() if "equal transient" in ln or "reference:" in ln))
    if r.returncode != 0:
        return [f"compare_mitsuba.py exited {r.returncode}: {r.stderr.strip().splitlines()[-1:]}"]
    with open(out) as f:
        found = json.load(f)
    agree, ratios = found["agreement"]["peer_cornell"], found["ratios"]
    failures = []
    rel = agree["total_femto"] / agree["total_mitsuba"] - 1.0
    print(f"totals femto {agree['total_femto']:.5g} Mitsuba {agree['total_mitsuba']:.5g} ({100 * rel:+.3f} %), "
          f"first lit bins {agree['first_lit_bin']}, peak bins {agree['peak_bin']}")
    if abs(rel) > 0.01:
        failures.append(f"totals differ by {100 * rel:.3f} % (more than 1 %)")
    for key in ("first_lit_bin", "peak_bin"):
        a, b = agree[key]
        if a != b:
            failures.append(f"{key}: femto {a}, Mitsuba {b}")
    if len(ratios) != 4:
        failures.append(f"{len(ratios)} ratios, expected 4 (2 samplers x 2 quantities)")
    for x in ratios:
        if not (math.isfinite(x["ratio_cpu"]) and x["ratio_cpu"] > 0 and math.isfinite(x["ratio_wall"])):
            failures.append(f"ratio not finite and positive: {x}")
    return failures
