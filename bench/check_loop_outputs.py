#!/usr/bin/env python3
"""Checks what scripts/bench.sh --loop wrote (CTests bench_loop_short, bench_loop_user_urdf).

  python3 bench/check_loop_outputs.py --table OUTPUT.txt --starts N [--plot DIR] FIXTURE...

Fails (exit 1, with the reason) unless:
  - OUTPUT.txt (bench_wbm's stdout) has a table row for wbm and for kdl_wdls on every
    FIXTURE whose run and skipped periods add up to N (seconds x rate: the loop lasts its
    wall time, so a busy machine skips starts instead of running longer), at least one run;
  - with --plot, DIR/loop.csv holds exactly the run periods of each row, with positive
    cycle times, and DIR/loop.svg parses as XML and draws, for every fixture and solver, a
    cycle-time and a wake-up histogram whose counts are those periods.
Standard library only.
"""
import argparse
import csv
import os
import sys
import xml.etree.ElementTree as ET

SVG = "{http://www.w3.org/2000/svg}"


def fail(message):
    print("check_loop_outputs.py: %s" % message, file=sys.stderr)
    sys.exit(1)


def table_rows(path):
    """{(fixture, solver): (periods, skipped)} from the markdown table of the loop."""
    rows = {}
    with open(path) as f:
        for line in f:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) == 10 and cells[3].isdigit():
                rows[(cells[0], cells[1])] = (int(cells[3]), int(cells[8]))
    return rows


def check_plot(out, fixtures, periods):
    counts = {}
    with open(os.path.join(out, "loop.csv"), newline="") as f:
        for row in csv.DictReader(f):
            if not float(row["cycle_us"]) > 0.0 or not float(row["wake_us"]) >= 0.0:
                fail("loop.csv: a period with cycle %s us, wake-up %s us" % (row["cycle_us"], row["wake_us"]))
            key = (row["fixture"], row["solver"])
            counts[key] = counts.get(key, 0) + 1
    svg = ET.parse(os.path.join(out, "loop.svg")).getroot()
    for fixture in fixtures:
        group = svg.find("%sg[@data-fixture='%s']" % (SVG, fixture))
        if group is None:
            fail("loop.svg: no plots of %s" % fixture)
        for solver in ("wbm", "kdl_wdls"):
            expected = periods[(fixture, solver)]
            if counts.get((fixture, solver), 0) != expected:
                fail("loop.csv: %d periods of %s/%s, the table says %d" % (counts.get((fixture, solver), 0), fixture,
                                                                           solver, expected))
            for panel in ("cycle", "wake"):
                path = group.find("%spath[@data-panel='%s'][@data-solver='%s']" % (SVG, panel, solver))
                if path is None or not path.get("d", "").startswith("M"):
                    fail("loop.svg: no %s histogram of %s/%s" % (panel, fixture, solver))
                if int(path.get("data-count")) != expected:
                    fail("loop.svg: the %s histogram of %s/%s counts %s periods, %d expected" %
                         (panel, fixture, solver, path.get("data-count"), expected))


def main():
    parser = argparse.ArgumentParser(description="checks the outputs of scripts/bench.sh --loop")
    parser.add_argument("--table", required=True, help="bench_wbm's stdout")
    parser.add_argument("--starts", type=int, required=True, help="period starts per solver: seconds x rate")
    parser.add_argument("--plot", help="the --plot directory (loop.csv, loop.svg)")
    parser.add_argument("fixtures", nargs="+")
    args = parser.parse_args()
    rows = table_rows(args.table)
    periods = {}
    for fixture in args.fixtures:
        for solver in ("wbm", "kdl_wdls"):
            if (fixture, solver) not in rows:
                fail("%s: no table row for %s/%s" % (args.table, fixture, solver))
            run, skipped = rows[(fixture, solver)]
            if run < 1 or run + skipped != args.starts:
                fail("%s: %s/%s ran %d and skipped %d periods, %d starts expected" % (args.table, fixture, solver, run,
                                                                                      skipped, args.starts))
            periods[(fixture, solver)] = run
    if args.plot:
        check_plot(args.plot, args.fixtures, periods)
    print("check_loop_outputs.py: %d fixtures x 2 solvers x %d period starts%s" %
          (len(args.fixtures), args.starts, ", plotted" if args.plot else ""))


if __name__ == "__main__":
    main()
