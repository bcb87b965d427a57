"""tools/compare_mitsuba.py runs end to end, in small: femto's `simulate --transient-only
--time-filter box` and Mitsuba + mitransient on the same scene files (peer_cornell), with a
common reference of 64 spp each; the two renderers' totals agree within 1 % and their
whole-image histograms start and peak in the same bin, and every speed ratio comes out
finite and positive. The figures of a small run mean nothing; this keeps the script working
(the real comparison: `python3 tools/compare_mitsuba.py`, figures in benches/tracer_results.md).
"""

import argparse
import math
import os
import sys

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, HERE)

import compare_mitsuba  # noqa: E402


def check(femto, work):
    args = argparse.Namespace(femto=femto, threads=2, sampler=["independent", "multijitter"], spp=[4], seeds=1,
                              ref_spp=64, timing_spp=16, timing_runs=1)
    ratios, agree = compare_mitsuba.compare_scene("peer_cornell", args, work)
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
    for r in ratios:
        if not (math.isfinite(r["ratio_cpu"]) and r["ratio_cpu"] > 0 and math.isfinite(r["ratio_wall"])):
            failures.append(f"ratio not finite and positive: {r}")
    return failures
