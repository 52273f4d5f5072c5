#!/usr/bin/env python3
"""Periodic loop of bench_wbm: per-period samples (CSV) -> histograms (SVG).

Usage:
  bench_wbm --wbm_loop=10 --wbm_loop_csv=loop.csv      (or: scripts/bench.sh --loop 10 --plot DIR)
  python3 bench/plot_loop.py loop.csv loop.svg

One row of two panels per fixture: the cycle time and the wake-up latency, as histograms
with logarithmic bins (10 per decade) and counts on a logarithmic axis, wbm and KDL in the
same panel, the period as a dashed line; the legend gives median, p99 and maximum. The
tails a median hides (p99.9, host stalls) are what these plots are for. Only the Python
standard library is used.
"""
import csv
import math
import os
import sys

COLORS = {"wbm": "#1f77b4", "kdl_wdls": "#ff7f0e"}
BINS_PER_DECADE = 10
PANEL_W, PANEL_H = 380, 200
LEFT, TOP, ROW_H, COL_W = 70, 70, 315, 470


def fail(message):
    print("plot_loop.py: %s" % message, file=sys.stderr)
    sys.exit(1)


def load(path):
    """{fixture: {solver: {"wake": [...], "cycle": [...]}}} in file order, and the period [us]."""
    data, period = {}, None
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            missing = {"fixture", "solver", "period_us", "wake_us", "cycle_us"} - set(reader.fieldnames or [])
            if missing:
                fail("%s: columns %s missing (expected bench_wbm --wbm_loop_csv output)" % (path, ", ".join(sorted(missing))))
            for line, row in enumerate(reader, start=2):
                try:
                    wake, cycle, period = float(row["wake_us"]), float(row["cycle_us"]), float(row["period_us"])
                except (TypeError, ValueError):
                    fail("%s:%d: numbers expected in period_us, wake_us, cycle_us" % (path, line))
                s = data.setdefault(row["fixture"], {}).setdefault(row["solver"], {"wake": [], "cycle": []})
                s["wake"].append(wake)
                s["cycle"].append(cycle)
    except OSError as e:
        fail("%s: %s" % (path, e.strerror))
    if not data:
        fail("%s: no samples" % path)
    return data, period


def quantile(sorted_values, p):
    return sorted_values[min(len(sorted_values) - 1, int(p * len(sorted_values)))]


def histogram(values, lo_decade):
    """Counts per logarithmic bin; bin k covers [10^(lo + k/B), 10^(lo + (k+1)/B)) us."""
    counts = {}
    for v in values:
        k = math.floor((math.log10(max(v, 1e-3)) - lo_decade) * BINS_PER_DECADE)
        counts[k] = counts.get(k, 0) + 1
    return counts


def panel(out, x0, y0, title, series, period, key):
    """series: [(solver, values)]; draws the histograms of `key` samples on shared log axes."""
    everything = [v for _, values in series for v in values]
    lo = math.floor(math.log10(max(min(everything), 1e-2)))
    hi = max(math.ceil(math.log10(max(max(everything), period if period else 1.0) * 1.0001)), lo + 1)
    hists = [(solver, values, histogram(values, lo)) for solver, values in series]
    top = max(max(h.values()) for _, _, h in hists)
    cmax = 10 ** math.ceil(math.log10(top * 1.5))
    px = lambda us: x0 + (math.log10(us) - lo) / (hi - lo) * PANEL_W
    floor = math.log10(0.5)  # the count axis starts at 0.5, so that a single period shows as a step
    py = lambda c: y0 + PANEL_H - (math.log10(c) - floor) / (math.log10(cmax) - floor) * PANEL_H if c > 0 else y0 + PANEL_H
    out.append('<rect x="%g" y="%g" width="%g" height="%g" fill="none" stroke="#444"/>' % (x0, y0, PANEL_W, PANEL_H))
    for d in range(lo, hi + 1):
        x = px(10 ** d)
        out.append('<line x1="%.1f" y1="%g" x2="%.1f" y2="%g" stroke="#ddd"/>' % (x, y0, x, y0 + PANEL_H))
        out.append('<text x="%.1f" y="%g" font-size="11" text-anchor="middle">%g</text>' % (x, y0 + PANEL_H + 15, 10 ** d))
    for d in range(0, int(round(math.log10(cmax))) + 1):
        y = py(10 ** d)
        out.append('<line x1="%g" y1="%.1f" x2="%g" y2="%.1f" stroke="#ddd"/>' % (x0, y, x0 + PANEL_W, y))
        out.append('<text x="%g" y="%.1f" font-size="11" text-anchor="end">%g</text>' % (x0 - 5, y + 4, 10 ** d))
    out.append('<text x="%g" y="%g" font-size="13" font-weight="bold" text-anchor="middle">%s</text>' %
               (x0 + PANEL_W / 2, y0 - 8, title))
    out.append('<text x="%g" y="%g" font-size="12" text-anchor="middle">[us], logarithmic bins</text>' %
               (x0 + PANEL_W / 2, y0 + PANEL_H + 32))
    out.append('<text x="%g" y="%g" font-size="12" text-anchor="middle" transform="rotate(-90 %g %g)">periods</text>' %
               (x0 - 40, y0 + PANEL_H / 2, x0 - 40, y0 + PANEL_H / 2))
    if period and lo <= math.log10(period) <= hi:
        x = px(period)
        out.append('<line x1="%.1f" y1="%g" x2="%.1f" y2="%g" stroke="#c00" stroke-dasharray="5,4"/>' %
                   (x, y0, x, y0 + PANEL_H))
        out.append('<text x="%.1f" y="%g" font-size="11" fill="#c00" text-anchor="end">period</text>' % (x - 3, y0 + 12))
    for k, (solver, values, counts) in enumerate(hists):
        color = COLORS.get(solver, "#555")
        # A step outline: up at each occupied bin's left edge, across, down at its right edge.
        d = []
        for b in sorted(counts):
            xl, xr = px(10 ** (lo + b / BINS_PER_DECADE)), px(10 ** (lo + (b + 1) / BINS_PER_DECADE))
            d.append("M%.1f,%.1f L%.1f,%.1f L%.1f,%.1f L%.1f,%.1f" % (xl, py(0), xl, py(counts[b]), xr, py(counts[b]),
                                                                    xr, py(0)))
        out.append('<path class="histogram" data-panel="%s" data-solver="%s" data-count="%d" d="%s" fill="%s" '
                   'fill-opacity="0.25" stroke="%s" stroke-width="1.2"/>' %
                   (key, solver, sum(counts.values()), " ".join(d), color, color))
        s = sorted(values)
        out.append('<text x="%g" y="%g" font-size="11" fill="%s">%s: median %.1f, p99 %.1f, max %.1f us</text>' %
                   (x0, y0 + PANEL_H + 50 + 14 * k, color, solver, quantile(s, 0.5), quantile(s, 0.99), s[-1]))


def write_svg(data, period, path):
    periods = {len(s["cycle"]) for solvers in data.values() for s in solvers.values()}
    height = TOP + ROW_H * len(data) + 10
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif">' %
           (LEFT + 2 * COL_W, height), '<rect width="100%" height="100%" fill="white"/>',
           '<text x="%g" y="28" font-size="15" font-weight="bold" text-anchor="middle">Periodic loop: %.0f Hz, %s '
           'periods per solver</text>' % ((LEFT + 2 * COL_W) / 2, 1e6 / period if period else 0,
                                          "/".join(str(p) for p in sorted(periods)))]
    for r, (fixture, solvers) in enumerate(data.items()):
        y0 = TOP + 20 + ROW_H * r
        out.append('<g class="fixture" data-fixture="%s">' % fixture)
        for c, (key, what) in enumerate((("cycle", "cycle time"), ("wake", "wake-up latency"))):
            panel(out, LEFT + COL_W * c, y0, "%s: %s" % (fixture, what),
                  [(solver, s[key]) for solver, s in solvers.items()], period, key)
        out.append('</g>')
    out.append('</svg>')
    tmp = path + ".tmp"  # written whole, then renamed: no half-written plot
    try:
        with open(tmp, "w") as f:
            f.write("\n".join(out) + "\n")
        os.replace(tmp, path)
    except OSError as e:
        fail("%s: %s" % (e.filename or path, e.strerror))


def main():
    if len(sys.argv) != 3:
        fail("usage: plot_loop.py LOOP.csv OUT.svg")
    data, period = load(sys.argv[1])
    write_svg(data, period, sys.argv[2])
    print("plot_loop.py: wrote %s (%d fixtures)" % (sys.argv[2], len(data)))


if __name__ == "__main__":
    main()
