#!/usr/bin/env python3
"""Scaling study of bench_wbm: JSON results -> scaling.csv, scaling.svg, scaling.md.

Usage:
  bench_wbm --benchmark_filter='^scaling/' --benchmark_out=scaling.json --benchmark_out_format=json
  python3 bench/plot_scaling.py scaling.json bench/results/

Only the Python standard library is used (no numpy/matplotlib): the least-squares fits
solve the normal equations directly and the plot is written as SVG by hand.
"""
import csv
import json
import math
import os
import sys


def load(path):
    """Cycle results with their stage results: one dict per (sweep, case)."""
    with open(path) as f:
        doc = json.load(f)
    runs = {}
    for b in doc["benchmarks"]:
        if b.get("run_type", "iteration") != "iteration" or b.get("error_occurred"):
            continue
        parts = b["name"].replace("/manual_time", "").split("/")
        if len(parts) not in (3, 4) or parts[0] != "scaling":
            continue
        stage = parts[3] if len(parts) == 4 else "cycle"
        scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b.get("time_unit", "ns")]
        key = (parts[1], parts[2])
        r = runs.setdefault(key, {"sweep": parts[1], "name": "scaling/%s/%s" % key, "dofs": int(b["dofs"]),
                                  "joints": int(b["joints"]), "rows": int(b["rows"]), "stages": {}})
        r["stages"].setdefault(stage, []).append((float(b["p50_us"]), float(b["p99_us"]), float(b["real_time"]) * scale,
                                                  int(b["iterations"])))
        if stage == "cycle" and "damped_pct" in b:
            r["damped_pct"] = float(b["damped_pct"])
    out = []
    for r in runs.values():
        if "cycle" not in r["stages"]:
            continue
        # The least over repetitions of each statistic: the host's slow spells (seconds, up to
        # 1.5x slower; bench/README.md, "Machine") slow whole repetitions, and a point that one
        # of them hit stood out of its sweep by up to 1.9x with the median over 3 repetitions.
        for stage, values in r["stages"].items():
            least = lambda i: min(v[i] for v in values)
            prefix = "" if stage == "cycle" else stage + "_"
            r[prefix + "p50_us"], r[prefix + "p99_us"], r[prefix + "mean_us"] = least(0), least(1), least(2)
            if stage == "cycle":
                r["iterations"] = sum(v[3] for v in values)
        del r["stages"]
        out.append(r)
    out.sort(key=lambda r: (r["sweep"], r["dofs"], r["rows"]))
    return out, doc.get("context", {})


def solve(A, b):
    """Gaussian elimination with partial pivoting."""
    n = len(A)
    M = [row[:] + [b[i]] for i, row in enumerate(A)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(M[r][c]))
        M[c], M[p] = M[p], M[c]
        if abs(M[c][c]) < 1e-300:
            raise ValueError("singular normal equations")
        for r in range(c + 1, n):
            f = M[r][c] / M[c][c]
            for k in range(c, n + 1):
                M[r][k] -= f * M[c][k]
    x = [0.0] * n
    for r in reversed(range(n)):
        x[r] = (M[r][n] - sum(M[r][k] * x[k] for k in range(r + 1, n))) / M[r][r]
    return x


def fit(samples, basis, key="p50_us"):
    """Least squares t ~ sum_k c_k basis_k(n, m), relative errors (weights 1/t)."""
    X = [[f(s["dofs"], s["rows"]) / s[key] for f in basis] for s in samples]
    y = [1.0 for _ in samples]
    scale = [max(abs(row[k]) for row in X) or 1.0 for k in range(len(basis))]
    Xs = [[row[k] / scale[k] for k in range(len(basis))] for row in X]
    A = [[sum(r[i] * r[j] for r in Xs) for j in range(len(basis))] for i in range(len(basis))]
    b = [sum(r[i] * yy for r, yy in zip(Xs, y)) for i in range(len(basis))]
    c = [ci / si for ci, si in zip(solve(A, b), scale)]
    return c


def predict(c, basis, n, m):
    return sum(ci * f(n, m) for ci, f in zip(c, basis))


def rms_relative(c, basis, samples, key="p50_us"):
    return math.sqrt(sum((predict(c, basis, s["dofs"], s["rows"]) / s[key] - 1.0) ** 2 for s in samples) /
                     len(samples))


# Models. n = dofs of the model (incl. the 9 virtual ones), m = active rows.
FULL = ([lambda n, m: 1.0, lambda n, m: n, lambda n, m: n * m, lambda n, m: n * m * m, lambda n, m: m ** 3],
        ["c0", "n", "n*m", "n*m^2", "m^3"])
BRIEF = ([lambda n, m: 1.0, lambda n, m: n * m, lambda n, m: m ** 3], ["c0", "n*m", "m^3"])
BRIEF_N = ([lambda n, m: 1.0, lambda n, m: n, lambda n, m: n * m, lambda n, m: m ** 3], ["c0", "n", "n*m", "m^3"])


def write_csv(samples, path):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["sweep", "name", "dofs", "joints", "rows", "p50_us", "p99_us", "mean_us", "iterations",
                    "solve_p50_us", "assemble_p50_us", "damped_pct"])
        for s in samples:
            w.writerow([s["sweep"], s["name"], s["dofs"], s["joints"], s["rows"], "%.4f" % s["p50_us"],
                        "%.4f" % s["p99_us"], "%.4f" % s["mean_us"], s["iterations"],
                        "%.4f" % s.get("solve_p50_us", float("nan")), "%.4f" % s.get("assemble_p50_us", float("nan")),
                        "%.1f" % s.get("damped_pct", float("nan"))])


def nice_ticks(lo, hi, count=6):
    span = hi - lo
    step = 10 ** math.floor(math.log10(span / count))
    for mult in (1, 2, 2.5, 5, 10):
        if span / (step * mult) <= count:
            step *= mult
            break
    t = math.ceil(lo / step) * step
    ticks = []
    while t <= hi + 1e-9:
        ticks.append(t)
        t += step
    return ticks


COLORS = ["#1f77b4", "#ff7f0e", "#9467bd", "#8c564b"]
FULL_STYLE = 'stroke="%s" stroke-width="1.5"'
ISSUE_STYLE = 'stroke="%s" stroke-width="1.2" stroke-dasharray="6,4"'


def panel(out, x0, y0, w, h, title, xlabel, xkey, series):
    """One plot. series: list of (samples, color, label, curves); curves: list of (style, [(x, y)])."""
    xs = [s[xkey] for samples, _, _, _ in series for s in samples]
    ys = [s["p99_us"] for samples, _, _, _ in series for s in samples]
    ys += [y for _, _, _, curves in series for _, pts in curves for _, y in pts]
    xmin, xmax = 0.0, max(xs) * 1.05
    ymin, ymax = 0.0, max(ys) * 1.1
    px = lambda x: x0 + (x - xmin) / (xmax - xmin) * w
    py = lambda y: y0 + h - (y - ymin) / (ymax - ymin) * h
    out.append('<rect x="%g" y="%g" width="%g" height="%g" fill="none" stroke="#444"/>' % (x0, y0, w, h))
    for t in nice_ticks(xmin, xmax):
        out.append('<line x1="%.1f" y1="%g" x2="%.1f" y2="%g" stroke="#ddd"/>' % (px(t), y0, px(t), y0 + h))
        out.append('<text x="%.1f" y="%g" font-size="11" text-anchor="middle">%g</text>' % (px(t), y0 + h + 15, t))
    for t in nice_ticks(ymin, ymax):
        out.append('<line x1="%g" y1="%.1f" x2="%g" y2="%.1f" stroke="#ddd"/>' % (x0, py(t), x0 + w, py(t)))
        out.append('<text x="%g" y="%.1f" font-size="11" text-anchor="end">%g</text>' % (x0 - 5, py(t) + 4, t))
    out.append('<text x="%g" y="%g" font-size="13" text-anchor="middle" font-weight="bold">%s</text>' %
               (x0 + w / 2, y0 - 10, title))
    out.append('<text x="%g" y="%g" font-size="12" text-anchor="middle">%s</text>' % (x0 + w / 2, y0 + h + 32, xlabel))
    out.append('<text x="%g" y="%g" font-size="12" text-anchor="middle" transform="rotate(-90 %g %g)">'
               'cycle time [us]</text>' % (x0 - 38, y0 + h / 2, x0 - 38, y0 + h / 2))
    for k, (samples, color, label, curves) in enumerate(series):
        for style, pts in curves:
            d = " ".join("%s%.1f,%.1f" % ("M" if i == 0 else "L", px(x), py(y)) for i, (x, y) in enumerate(pts))
            out.append('<path d="%s" fill="none" %s/>' % (d, style % color))
        for s in samples:
            if "solve_p50_us" in s:
                x, y = px(s[xkey]), py(s["solve_p50_us"])
                out.append('<path d="M%.1f,%.1f L%.1f,%.1f M%.1f,%.1f L%.1f,%.1f" stroke="%s" stroke-width="1.3"/>' %
                           (x - 3.5, y - 3.5, x + 3.5, y + 3.5, x - 3.5, y + 3.5, x + 3.5, y - 3.5, color))
            out.append('<circle cx="%.1f" cy="%.1f" r="3.5" fill="%s"/>' % (px(s[xkey]), py(s["p50_us"]), color))
            out.append('<rect x="%.1f" y="%.1f" width="6" height="6" fill="none" stroke="%s"/>' %
                       (px(s[xkey]) - 3, py(s["p99_us"]) - 3, color))
        if label:
            out.append('<text x="%g" y="%g" font-size="12" fill="%s">%s</text>' % (x0 + 10, y0 + 18 + 16 * k, color, label))


def write_svg(samples, c_full, c_issue, path):
    dofs = [s for s in samples if s["sweep"] == "dofs"]
    rows = [s for s in samples if s["sweep"].startswith("rows")]
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="960" height="460" font-family="sans-serif">',
           '<rect width="100%" height="100%" fill="white"/>']

    def curves(points):
        """points: list of (x, n, m) along the sweep."""
        return [(FULL_STYLE, [(x, predict(c_full, FULL[0], n, m)) for x, n, m in points]),
                (ISSUE_STYLE, [(x, predict(c_issue, BRIEF[0], n, m)) for x, n, m in points])]

    def span(lo, hi):
        return [lo + (hi - lo) * i / 100.0 for i in range(101)]

    if dofs:
        m = dofs[0]["rows"]
        lo, hi = min(s["dofs"] for s in dofs), max(s["dofs"] for s in dofs)
        panel(out, 70, 40, 370, 300, "cycle time vs dofs (%d rows)" % m, "dofs n (incl. 9 virtual)", "dofs",
              [(dofs, COLORS[0], "", curves([(n, n, m) for n in span(lo, hi)]))])
    if rows:
        series = []
        for k, n in enumerate(sorted({s["dofs"] for s in rows})):
            ss = [s for s in rows if s["dofs"] == n]
            lo, hi = min(s["rows"] for s in ss), max(s["rows"] for s in ss)
            series.append((ss, COLORS[(k + 1) % len(COLORS)], "n = %d dofs" % n, curves([(m, n, m) for m in span(lo, hi)])))
        panel(out, 560, 40, 370, 300, "cycle time vs active rows", "active rows m", "rows", series)
    ly = 400
    out.append('<circle cx="80" cy="%d" r="3.5" fill="#444"/><text x="90" y="%d" font-size="12">median</text>' % (ly, ly + 4))
    out.append('<rect x="147" y="%d" width="6" height="6" fill="none" stroke="#444"/>'
               '<text x="160" y="%d" font-size="12">p99</text>' % (ly - 3, ly + 4))
    out.append('<path d="M80,%d L87,%d M80,%d L87,%d" stroke="#444" stroke-width="1.3"/>'
               '<text x="93" y="%d" font-size="12">median of WholeBodySolver::solve alone</text>' %
               (ly + 16.5, ly + 23.5, ly + 23.5, ly + 16.5, ly + 24))
    out.append('<path d="M210,%d L240,%d" %s/><text x="246" y="%d" font-size="12">'
               'fit c0 + c1 n + c2 nm + c3 nm^2 + c4 m^3</text>' % (ly, ly, FULL_STYLE % "#444", ly + 4))
    out.append('<path d="M540,%d L570,%d" %s/><text x="576" y="%d" font-size="12">'
               'fit c0 + c1 nm + c2 m^3 (the issue\'s O(nm + m^3))</text>' % (ly, ly, ISSUE_STYLE % "#444", ly + 4))
    out.append('</svg>')
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


SOLVE = ([lambda n, m: 1.0, lambda n, m: n, lambda n, m: n * m, lambda n, m: n * m * m, lambda n, m: m ** 3],
         ["c0", "n", "n*m", "n*m^2", "m^3"])
ASSEMBLE = ([lambda n, m: 1.0, lambda n, m: m, lambda n, m: n * m], ["c0", "m", "n*m"])


def write_md(samples, context, fits, path):
    c_full, c_brief, c_brief_n = fits
    dofs = [s for s in samples if s["sweep"] == "dofs"]
    rows = [s for s in samples if s["sweep"].startswith("rows")]
    staged = [s for s in samples if "solve_p50_us" in s and "assemble_p50_us" in s]
    for s in staged:
        s["rest_p50_us"] = max(s["p50_us"] - s["solve_p50_us"] - s["assemble_p50_us"], 1e-3)
    L = []
    L.append("# Scaling of the controller cycle\n")
    L.append("![scaling plot](scaling.svg)\n")
    L.append("Generated by `bench/plot_scaling.py` from `bench_wbm --benchmark_filter='^scaling/'` "
             "(`scripts/bench.sh --scaling`; data: [scaling.csv](scaling.csv)). One `Controller::update()` with "
             "moving targets, median and 99th percentile of single calls (with repetitions, as `scripts/bench.sh "
             "--scaling` runs them, the least of each over the repetitions, which the host's slow spells do not "
             "reach); `solve` and `assemble` are "
             "`WholeBodySolver::solve` and `TaskStack::assemble` timed alone on 32 consecutive states recorded from the same "
             "run. Models: a torso on the paper's 9 virtual dofs (heel frozen) with serial branches of random "
             "revolute joints (random axes, bent home pose); position elements (3 rows) on branch tips, the last "
             "one partly active when m is not a multiple of 3.\n")
    L.append("- dofs sweep: 10 to 100 joints in 4 branches (n = joints + 9 = %s dofs), m = %s rows." %
             ("%d..%d" % (min(s["dofs"] for s in dofs), max(s["dofs"] for s in dofs)) if dofs else "-",
              dofs[0]["rows"] if dofs else "-"))
    L.append("- rows sweeps: m = 3 to 40 rows on trees of 60 and 100 joints in 14 branches (n = %s dofs); two "
             "tree sizes, so that the fits can tell n m^2 from m^3.\n" %
             " and ".join(str(n) for n in sorted({s["dofs"] for s in rows})))
    if context:
        L.append("Machine: %s CPUs at %s MHz (see bench/README.md), run %s.\n" %
                 (context.get("num_cpus", "?"), context.get("mhz_per_cpu", "?"), context.get("date", "?")))
    L.append("| sweep | n (dofs) | m (rows) | cycle median [us] | cycle p99 [us] | solve [us] | assemble [us] | "
             "rest [us] | damped cycles | fit [us] |")
    L.append("|---|---|---|---|---|---|---|---|---|---|")
    for s in samples:
        L.append("| %s | %d | %d | %.2f | %.2f | %s | %s | %s | %s | %.2f |" % (
            s["sweep"], s["dofs"], s["rows"], s["p50_us"], s["p99_us"],
            "%.2f" % s["solve_p50_us"] if "solve_p50_us" in s else "-",
            "%.2f" % s["assemble_p50_us"] if "assemble_p50_us" in s else "-",
            "%.2f" % s["rest_p50_us"] if "rest_p50_us" in s else "-",
            "%.0f %%" % s["damped_pct"] if "damped_pct" in s else "-",
            predict(c_full, FULL[0], s["dofs"], s["rows"])))
    L.append("")
    L.append("## Expected growth\n")
    L.append("Per cycle, with n dofs and m active rows: forward kinematics, filters and the joint-space vectors, "
             "O(n) (plus O(m) per element); the Jacobian rows (each element clears and fills its rows, the stack "
             "copies the active rows), O(n m); in the solver the scaled copy `H = W^-1/2 J^T`, `H^T W^-1/2 g`, "
             "`H y` and `H u`, O(n m) each; `A = J W^-1 J^T = H^T H`, O(n m^2) (m(m+1)/2 dot products of length n; "
             "this term is missing from the O(n m + m^3) the issue expected; the sums stop where both rows end, "
             "so on trees whose rows end early, as on these branched ones, it grows less); the L D L^T factor of "
             "A, O(m^3) (m^3/6 multiply-adds, once, twice on damped cycles); inverse iteration and the triangular "
             "solves, O(m^2).\n")
    L.append("## Fits\n")
    L.append("Least-squares fits of the medians (relative errors) over all three sweeps; n = dofs, m = rows; "
             "coefficients in ns per unit of the term.\n")
    L.append("| what | model | c0 | n | m | n m | n m^2 | m^3 | RMS rel. error |")
    L.append("|---|---|---|---|---|---|---|---|---|")

    def row(what, name, c, names, basis, data, key):
        cells = {k: "-" for k in ["c0", "n", "m", "n*m", "n*m^2", "m^3"]}
        for ci, k in zip(c, names):
            cells[k] = "%.3g" % (ci * 1e3)
        L.append("| %s | %s | %s | %s | %s | %s | %s | %s | %.1f %% |" % (
            what, name, cells["c0"], cells["n"], cells["m"], cells["n*m"], cells["n*m^2"], cells["m^3"],
            100 * rms_relative(c, basis, data, key)))
    row("cycle", "c0 + c1 n m + c2 m^3 (the issue's O(n m + m^3))", c_brief, BRIEF[1], BRIEF[0], samples, "p50_us")
    row("cycle", "c0 + c1 n + c2 n m + c4 m^3", c_brief_n, BRIEF_N[1], BRIEF_N[0], samples, "p50_us")
    row("cycle", "c0 + c1 n + c2 n m + c3 n m^2 + c4 m^3", c_full, FULL[1], FULL[0], samples, "p50_us")
    stage_fits = {}
    if len(staged) >= 6:
        for what, model, key in (("solve", SOLVE, "solve_p50_us"), ("assemble", ASSEMBLE, "assemble_p50_us")):
            c = fit(staged, model[0], key)
            stage_fits[what] = (c, model)
            row(what, " + ".join(["c0"] + ["c%d %s" % (i, k.replace("*", " ")) for i, k in enumerate(model[1]) if i]),
                c, model[1], model[0], staged, key)
    L.append("")
    # The per-dof slope at each m, from the two rows sweeps, removes everything that does not
    # depend on n (the m^3 of the factorisation): d(m) = dt/dn = c_n + c_nm m + c_nm2 m^2.
    sizes = sorted({s["dofs"] for s in rows})
    if len(sizes) >= 2:
        n1, n2 = sizes[0], sizes[-1]
        by = {(s["dofs"], s["rows"]): s for s in rows}
        ms = sorted(m for (n, m) in by if n == n1 and (n2, m) in by)
        L.append("Per-dof slope at each m, from the two rows sweeps (n = %d and %d): it removes every term that "
                 "does not grow with n, such as the m^3 of the factorisation, and so separates n, n m and n m^2 "
                 "(nearly collinear in the fits above):\n" % (n1, n2))
        L.append("| m | cycle [ns per dof] | solve [ns per dof] |")
        L.append("|---|---|---|")
        slopes = []
        for m in ms:
            a, b = by[(n1, m)], by[(n2, m)]
            dc = 1e3 * (b["p50_us"] - a["p50_us"]) / (n2 - n1)
            ds = 1e3 * (b["solve_p50_us"] - a["solve_p50_us"]) / (n2 - n1) if "solve_p50_us" in a and "solve_p50_us" in b else float("nan")
            slopes.append({"dofs": 1, "rows": m, "c": dc, "s": ds})
            L.append("| %d | %.1f | %.1f |" % (m, dc, ds))
        L.append("")
        quad = [lambda n, m: 1.0, lambda n, m: m, lambda n, m: m * m]
        for key, what in (("c", "cycle"), ("s", "solve")):
            pts = [dict(x, p=x[key]) for x in slopes if x[key] == x[key] and x[key] > 0]
            if len(pts) >= 4:
                c = fit(pts, quad, "p")
                L.append("%s: d t / d n = %.3g + %.3g m + %.4g m^2 ns, i.e. %.3g ns per n, %.3g ns per n m, "
                         "%.4g ns per n m^2." % (what, c[0], c[1], c[2], c[0], c[1], c[2]))
        L.append("")
        # Remainder without the n-dependent part: the m^3 term.
        if len(staged) >= 6:
            pts = [s for s in staged if s["sweep"].startswith("rows")]
            good = [dict(x, p=x["s"]) for x in slopes if x["s"] == x["s"] and x["s"] > 0]
            cs = fit(good, quad, "p") if len(good) >= 4 else None
            if cs is not None:
                rem = [dict(s, p=max(s["solve_p50_us"] - 1e-3 * s["dofs"] * (cs[0] + cs[1] * s["rows"] + cs[2] * s["rows"] ** 2),
                                     1e-3)) for s in pts]
                cr = fit(rem, [lambda n, m: 1.0, lambda n, m: m * m, lambda n, m: m ** 3], "p")
                L.append("solve minus its n-dependent part: %.3g us + %.3g ns m^2 + %.3g ns m^3 (the L D L^T "
                         "factor and the triangular solves)." % (cr[0], cr[1] * 1e3, cr[2] * 1e3))
                L.append("")
    for label, (n, m) in (("largest tree of the dofs sweep", (max((s["dofs"] for s in dofs), default=0),
                                                               dofs[0]["rows"] if dofs else 0)),
                          ("most rows", (max((s["dofs"] for s in rows), default=0),
                                         max((s["rows"] for s in rows), default=0)))):
        if n == 0:
            continue
        terms = [ci * f(n, m) for ci, f in zip(c_full, FULL[0])]
        total = sum(terms)
        L.append("Cycle fit at the %s, n = %d, m = %d: %.2f us = " % (label, n, m, total) +
                 " + ".join("%s %.2f (%.0f %%)" % (k, t, 100 * t / total) for k, t in zip(FULL[1], terms)) + ".\n")
        if "solve" in stage_fits:
            c, model = stage_fits["solve"]
            terms = [ci * f(n, m) for ci, f in zip(c, model[0])]
            L.append("Solve fit there: %.2f us = " % sum(terms) +
                     " + ".join("%s %.2f" % (k, t) for k, t in zip(model[1], terms)) + ".\n")
    if dofs:
        a, b = dofs[0], dofs[-1]
        L.append("dofs sweep: %.2f us at n = %d to %.2f us at n = %d, %.1f ns per added dof at m = %d "
                 "(linear in n, as expected at fixed m).\n" %
                 (a["p50_us"], a["dofs"], b["p50_us"], b["dofs"], 1e3 * (b["p50_us"] - a["p50_us"]) / (b["dofs"] - a["dofs"]),
                  a["rows"]))
    for n in sorted({s["dofs"] for s in rows}):
        ss = sorted((s for s in rows if s["dofs"] == n), key=lambda s: s["rows"])
        a, b = ss[0], ss[-1]
        L.append("rows sweep at n = %d: %.2f us at m = %d to %.2f us at m = %d: x%.1f for x%.1f rows%s.\n" %
                 (n, a["p50_us"], a["rows"], b["p50_us"], b["rows"], b["p50_us"] / a["p50_us"], b["rows"] / a["rows"],
                  "; the solve alone goes from %.2f to %.2f us (%.0f %% of the cycle at m = %d)" %
                  (a["solve_p50_us"], b["solve_p50_us"], 100 * b["solve_p50_us"] / b["p50_us"], b["rows"])
                  if "solve_p50_us" in a and "solve_p50_us" in b else ""))
    with open(path, "w") as f:
        f.write("\n".join(L) + "\n")


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    samples, context = load(sys.argv[1])
    if not samples:
        print("no scaling/ results in %s" % sys.argv[1])
        return 1
    out = sys.argv[2]
    os.makedirs(out, exist_ok=True)
    try:
        c_full = fit(samples, FULL[0])
        c_brief = fit(samples, BRIEF[0])
        c_brief_n = fit(samples, BRIEF_N[0])
    except ValueError:
        print("%s: %d scaling cases are too few to fit the growth models (run all of ^scaling/)"
              % (sys.argv[1], len(samples)), file=sys.stderr)
        return 1
    write_csv(samples, os.path.join(out, "scaling.csv"))
    write_svg(samples, c_full, c_brief, os.path.join(out, "scaling.svg"))
    write_md(samples, context, (c_full, c_brief, c_brief_n), os.path.join(out, "scaling.md"))
    print("wrote %s/scaling.{csv,svg,md}" % out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
