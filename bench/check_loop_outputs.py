#!/usr/bin/env python3
"""Checks what scripts/bench.sh --loop ... --plot DIR wrote (CTest bench_loop_plot).

  python3 bench/check_loop_outputs.py DIR EXPECTED_PERIODS FIXTURE...

Fails (exit 1, with the reason) unless DIR/loop.csv holds EXPECTED_PERIODS rows for wbm
and for kdl_wdls on every FIXTURE, with positive cycle times, and DIR/loop.svg parses as
XML and draws, for every fixture and solver, a cycle-time and a wake-up histogram whose
counts add up to those rows. Standard library only.
"""
import csv
import os
import sys
import xml.etree.ElementTree as ET

SVG = "{http://www.w3.org/2000/svg}"


def fail(message):
    print("check_loop_outputs.py: %s" % message, file=sys.stderr)
    sys.exit(1)


def main():
    if len(sys.argv) < 4:
        fail("usage: check_loop_outputs.py DIR EXPECTED_PERIODS FIXTURE...")
    out, expected, fixtures = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
    rows = {}
    with open(os.path.join(out, "loop.csv"), newline="") as f:
        for row in csv.DictReader(f):
            if not float(row["cycle_us"]) > 0.0 or not float(row["wake_us"]) >= 0.0:
                fail("loop.csv: a period with cycle %s us, wake-up %s us" % (row["cycle_us"], row["wake_us"]))
            key = (row["fixture"], row["solver"])
            rows[key] = rows.get(key, 0) + 1
    svg = ET.parse(os.path.join(out, "loop.svg")).getroot()
    for fixture in fixtures:
        group = svg.find("%sg[@data-fixture='%s']" % (SVG, fixture))
        if group is None:
            fail("loop.svg: no plots of %s" % fixture)
        for solver in ("wbm", "kdl_wdls"):
            if rows.get((fixture, solver)) != expected:
                fail("loop.csv: %d periods of %s/%s, %d expected" % (rows.get((fixture, solver), 0), fixture, solver,
                                                                     expected))
            for panel in ("cycle", "wake"):
                path = group.find("%spath[@data-panel='%s'][@data-solver='%s']" % (SVG, panel, solver))
                if path is None or not path.get("d", "").startswith("M"):
                    fail("loop.svg: no %s histogram of %s/%s" % (panel, fixture, solver))
                if int(path.get("data-count")) != expected:
                    fail("loop.svg: the %s histogram of %s/%s counts %s periods, %d expected" %
                         (panel, fixture, solver, path.get("data-count"), expected))
    print("check_loop_outputs.py: %s: %d fixtures x 2 solvers x %d periods, plotted" % (out, len(fixtures), expected))


if __name__ == "__main__":
    main()
