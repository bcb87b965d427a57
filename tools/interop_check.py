#!/usr/bin/env python3
"""Interop check: femto's files read by the field's own readers, and their files read by femto.

Usage: python3 tools/interop_check.py path/to/femto [workdir]

Runs `check(femto, workdir)` of every module in tools/interop/ (hpdta: rosettasciio and
HPD-TA `.img`; h5: h5py annotations; instruments: PTU, Delmic, time-first and `.npz` files
against ptufile, rosettasciio, h5py and scipy; ytal: y-tal captures; mitransient_render: transient
renders; mitsuba_compare: tools/compare_mitsuba.py in small; noise_parts: tools/noise_split.py
--by-bounce in small; no module is named like a package it
imports),
each in its own subfolder of workdir (a temporary folder by default). A check returns a list
of failure messages (empty: it passed) and prints one line per comparison with its figures.
Exit code 1 on any failure or on a module that could not be imported (a missing package is
a failure here: `.ci/run` installs them); 0 when every check passed.
"""

import importlib
import os
import pkgutil
import sys
import tempfile
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    if len(sys.argv) < 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    femto = os.path.abspath(sys.argv[1])
    if not os.access(femto, os.X_OK):
        print(f"interop_check: {femto}: not an executable femto binary", file=sys.stderr)
        return 2
    sys.path.insert(0, HERE)
    names = sorted(m.name for m in pkgutil.iter_modules([os.path.join(HERE, "interop")]))
    if not names:
        print("interop_check: no modules in tools/interop", file=sys.stderr)
        return 1
    failures = []
    with tempfile.TemporaryDirectory(prefix="femto-interop-") as tmp:
        root = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else tmp
        for name in names:
            work = os.path.join(root, name)
            os.makedirs(work, exist_ok=True)
            start = time.perf_counter()
            try:
                module = importlib.import_module(f"interop.{name}")
                found = list(module.check(femto, work))
            except Exception:  # an import or a check that crashed is a failure, not a skip
                found = [f"crashed: {traceback.format_exc().strip().splitlines()[-1]}"]
                traceback.print_exc()
            secs = time.perf_counter() - start
            status = "ok" if not found else f"FAILED ({len(found)})"
            print(f"== {name}: {status} in {secs:.1f} s")
            failures += [f"{name}: {m}" for m in found]
    for m in failures:
        print(f"FAIL {m}")
    print(f"interop_check: {len(names)} modules, {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
