#!/usr/bin/env python3
"""Checks what bench/plot_scaling.py wrote from a scaling run (CTest bench_scaling_plot).

  python3 bench/check_scaling_outputs.py RESULTS.json OUTDIR

Fails (exit 1, with the reason) unless OUTDIR holds scaling.csv with one row per scaling
case of RESULTS.json (Google Benchmark's JSON), scaling.svg that parses as XML and draws a
curve for each sweep, and scaling.md with the table and the fitted growth; and unless
plot_scaling.py, given the same results with each run repeated 1.5x and 2x slower, gives
the same medians (the least over repetitions). Standard library only.
"""
import csv
import json
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET


def fail(message):
    print(f"check_scaling_outputs.py: {message}", file=sys.stderr)
    sys.exit(1)


def main():
    if len(sys.argv) != 3:
        fail("usage: check_scaling_outputs.py RESULTS.json OUTDIR")
    results, out = sys.argv[1], sys.argv[2]
    with open(results) as f:
        benchmarks = json.load(f)["benchmarks"]
    # The cycles' runs (scaling/<sweep>/<case>/manual_time), as plot_scaling.py reads them:
    # iterations only (repetitions add aggregate rows), no stage (.../<case>/<stage>/...).
    cases = set()
    for b in benchmarks:
        parts = b["name"].replace("/manual_time", "").split("/")
        if (parts[0] == "scaling" and len(parts) == 3 and b.get("run_type", "iteration") == "iteration"
                and not b.get("error_occurred")):
            cases.add("/".join(parts))
    if not cases:
        fail(f"{results}: no scaling cycle results")
    sweeps = {c.split("/")[1] for c in cases}

    with open(os.path.join(out, "scaling.csv")) as f:
        rows = list(csv.DictReader(f))
    names = {r["name"] for r in rows}
    if names != cases:
        fail(f"scaling.csv: {len(names)} cases, the results have {len(cases)} "
             f"(missing {sorted(cases - names)[:3]}, extra {sorted(names - cases)[:3]})")
    for r in rows:
        if not float(r["p50_us"]) > 0.0:
            fail(f"scaling.csv: {r['name']}: median {r['p50_us']} is not a positive time")

    try:
        svg = ET.parse(os.path.join(out, "scaling.svg")).getroot()
    except ET.ParseError as e:
        fail(f"scaling.svg does not parse: {e}")
    drawn = [e for e in svg.iter() if e.tag.split("}")[-1] in ("path", "polyline")]
    if len(drawn) < len(sweeps):
        fail(f"scaling.svg: {len(drawn)} curves for {len(sweeps)} sweeps")

    with open(os.path.join(out, "scaling.md")) as f:
        md = f.read()
    for needed in ["![scaling plot](scaling.svg)", "| sweep |", "fit"]:
        if needed not in md:
            fail(f"scaling.md: no '{needed}'")
    table_rows = [line for line in md.splitlines() if line.startswith("| ") and line.split("|")[1].strip() in sweeps]
    if len(table_rows) < len(cases):
        fail(f"scaling.md: {len(table_rows)} table rows for {len(cases)} cases")
    check_least_of_repetitions(results, rows)
    print(f"scaling outputs: {len(cases)} cases in {len(sweeps)} sweeps, {len(drawn)} curves")
    return 0


def check_least_of_repetitions(results, rows):
    """plot_scaling.py on the same results with every run repeated 1.5x and 2x slower (as a
    slow spell of the host makes whole repetitions) must give the same medians: the least
    over the repetitions, not their median."""
    with open(results) as f:
        doc = json.load(f)

    def slower(b, factor):
        return dict(b, **{key: float(b[key]) * factor for key in ("p50_us", "p99_us", "real_time") if key in b})

    repeated = []
    for b in doc["benchmarks"]:  # a slower repetition before and after each run
        iteration = b.get("run_type", "iteration") == "iteration"
        repeated += [slower(b, 2.0), b, slower(b, 1.5)] if iteration else [b]
    doc["benchmarks"] = repeated
    here = os.path.dirname(os.path.abspath(__file__))
    with tempfile.TemporaryDirectory() as scratch:
        path = os.path.join(scratch, "repeated.json")
        with open(path, "w") as f:
            json.dump(doc, f)
        run = subprocess.run([sys.executable, os.path.join(here, "plot_scaling.py"), path, scratch],
                             capture_output=True, text=True)
        if run.returncode != 0:
            fail(f"plot_scaling.py on the repeated results failed: {run.stderr.strip()}")
        with open(os.path.join(scratch, "scaling.csv")) as f:
            again = {r["name"]: r for r in csv.DictReader(f)}
    for r in rows:
        if again[r["name"]]["p50_us"] != r["p50_us"]:
            fail(f"{r['name']}: median {again[r['name']]['p50_us']} with slower repetitions added, "
                 f"{r['p50_us']} without: not the least over the repetitions")


if __name__ == "__main__":
    sys.exit(main())
