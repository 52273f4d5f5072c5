#!/usr/bin/env python3
"""Seeded random mutations of the shipped URDFs and scenarios through the CLI: a clear error or a clean run.

  python3 tests/mutated_inputs.py [WBM [OUT_DIR]] [--seed S] [--urdfs N] [--scenarios N]

Each URDF case is a shipped robot (models/) with one to three random changes: an attribute
set to a bad value (nan, inf, 1e400, an empty string, a word, too many or too few
numbers, another element's name), an attribute or element removed, or an element
duplicated. `wbm model info` and `wbm model fk --jacobian` run on it. Each scenario case is
a shipped scenario (scenarios/) with one or two changes to its text: a value replaced (by
nan, .inf, -1, 1e400, a word, a list, ...), a line deleted, duplicated or indented.
`wbm run` runs it. Every case must:

- exit 0 (and for a scenario, write a trajectory.csv whose rows have as many fields as its
  header and only finite numbers), or
- exit 1 or 2 with `wbm: error: FILE:LINE: ...` on stderr, naming the mutated file and a
  line, without writing the scenario's output directory;
- never crash, abort or hang (60 s per case).

Prints a line per failing case (the changes made and the message) and exits 1 if any case
failed, keeping the case as OUT_DIR/failed_<n>.urdf or .yaml (OUT_DIR: a temp dir unless
given). Such cases found a path that escaped --out, two scenarios overwriting each other and
CSV columns shifted by a name with a comma, and two URDF errors without a line. Standard
library only.
"""
import argparse
import copy
import csv
import glob
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

from out_of_reach_probe import require_program

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BAD_NUMBERS = ["nan", "inf", "-inf", "1e400", "-1", "", "abc", "1 2", "0 0 0", "1e-320", "1e308 1e308 1e308",
               "NaN NaN NaN", "0 0", "1 2 3 4", "  ", "-0", "1,2,3", "0x10", "1e5",
               "0\t0 0", "0 0\n0", "1\t", " \t1"]
BAD_VALUES = ["nan", ".nan", ".inf", "-.inf", "-1", "0", "1e400", "1e12", "-1e12", "abc", "[]", "{}", '""', "~",
              "-0.0", "1e-300", "[1, 2]", "[nan, 0, 0]", "[1, 2, 3, 4]", "true", "0x1F", "1_000", "2.5", "-3",
              "100000", "../x", "a/b", "'a,b'"]
# A YAML scalar after ':', '[', ',' or '{' and before ',', ']', '}' or the end of the line.
SCALAR = re.compile(r"(?<=[:\[,{ ])\s*(-?[0-9][0-9eE.+-]*|[A-Za-z_][A-Za-z0-9_]*)(?=\s*[,\]}]|\s*$)")
TIMEOUT = 60


def mutate_urdf(tree, rng):
    """One random change to the XML tree; returns what it did."""
    root = tree.getroot()
    elements = list(root.iter())
    parents = {child: parent for parent in elements for child in parent}
    element = rng.choice(elements)
    roll = rng.random()
    if roll < 0.55 and element.attrib:
        attribute = rng.choice(sorted(element.attrib))
        names = [e.get("name") for e in elements if e.get("name")]
        element.attrib[attribute] = rng.choice(BAD_NUMBERS + [rng.choice(names)])
        return f"<{element.tag} {attribute}={element.attrib[attribute]!r}>"
    if roll < 0.7 and element.attrib:
        attribute = rng.choice(sorted(element.attrib))
        del element.attrib[attribute]
        return f"<{element.tag}> without {attribute}"
    if element not in parents:
        return "no change"
    if roll < 0.85:
        parents[element].remove(element)
        return f"<{element.tag}> removed"
    parents[element].append(copy.deepcopy(element))
    return f"<{element.tag}> duplicated"


def mutate_scenario(lines, rng):
    """One random change to the lines of a scenario; returns what it did."""
    roll = rng.random()
    i = rng.randrange(len(lines))
    if roll < 0.7:
        scalars = [(j, m) for j, line in enumerate(lines) if not line.lstrip().startswith("#")
                   for m in SCALAR.finditer(line)]
        if not scalars:
            return "no change"
        j, m = rng.choice(scalars)
        value = rng.choice(BAD_VALUES + [m.group(1) + "x"])
        lines[j] = lines[j][:m.start(1)] + value + lines[j][m.end(1):]
        return f"line {j + 1}: {m.group(1)!r} -> {value!r}"
    if roll < 0.82:
        del lines[i]
        return f"line {i + 1} deleted"
    if roll < 0.92:
        lines.insert(i, lines[i])
        return f"line {i + 1} duplicated"
    lines[i] = " " + lines[i]
    return f"line {i + 1} indented"


def error_problem(result, case):
    """What is wrong with a failed run's exit status and message, or None."""
    if result.returncode not in (1, 2) or "terminate called" in result.stderr:
        return f"exit status {result.returncode}"
    if not re.search(r"^wbm: error: ", result.stderr, re.M):
        return "no 'wbm: error:' line"
    if not re.search(re.escape(case) + r":\d+: ", result.stderr):
        return "the file and line are not named"
    return None


def trajectory_problem(path):
    """What is wrong with a successful run's trajectory.csv, or None."""
    if not os.path.exists(path):
        return "no trajectory.csv"
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if any(len(row) != len(rows[0]) for row in rows):
        return "trajectory.csv: rows of different lengths"
    for row in rows[1:]:
        if any(re.fullmatch(r"[+-]?(nan|inf)", value, re.I) for value in row):
            return "trajectory.csv: a number that is not finite"
    return None


def run(command):
    try:
        return subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        return None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("wbm", nargs="?", default=os.path.join(ROOT, "build", "wbm"))
    parser.add_argument("out", nargs="?")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--urdfs", type=int, default=200, help="URDF cases")
    parser.add_argument("--scenarios", type=int, default=200, help="scenario cases")
    options = parser.parse_args()
    require_program(options.wbm, "mutated_inputs.py")
    out = options.out or tempfile.mkdtemp(prefix="mutated_inputs_")
    os.makedirs(out, exist_ok=True)
    rng = random.Random(options.seed)
    urdfs = sorted(glob.glob(os.path.join(ROOT, "models", "**", "*.urdf"), recursive=True))
    scenarios = sorted(glob.glob(os.path.join(ROOT, "scenarios", "*.yaml")))
    failed = 0
    counts = {"clean run": 0, "clear error": 0}

    def report(n, source, changes, problem, message, keep):
        nonlocal failed
        failed += 1
        print(f"case {n} ({os.path.relpath(source, ROOT)}; {'; '.join(changes)}): {problem}; kept as {keep}\n"
              f"  {message.strip()[-400:]}")

    for n in range(options.urdfs):
        source = rng.choice(urdfs)
        tree = ET.parse(source)
        changes = [mutate_urdf(tree, rng) for _ in range(rng.randint(1, 3))]
        case = os.path.join(out, "case.urdf")
        tree.write(case)
        for command in (["model", "info", case], ["model", "fk", case, "--jacobian", "--json"]):
            result = run([options.wbm] + command)
            if result is None:
                problem = "timed out"
            else:
                problem = error_problem(result, case) if result.returncode else None
            if not problem:
                counts["clear error" if result.returncode else "clean run"] += 1
            else:
                keep = os.path.join(out, f"failed_{n}.urdf")
                shutil.copy(case, keep)
                report(n, source, changes + [" ".join(command[:2])], problem, result.stderr if result else "", keep)
                break

    for n in range(options.scenarios):
        source = rng.choice(scenarios)
        with open(source) as f:
            lines = f.read().split("\n")
        changes = [mutate_scenario(lines, rng) for _ in range(rng.randint(1, 2))]
        case = os.path.join(out, "case.yaml")
        with open(case, "w") as f:
            f.write("\n".join(lines))
        directory = os.path.join(out, "run")
        shutil.rmtree(directory, ignore_errors=True)
        result = run([options.wbm, "run", case, "--out", directory, "--no-report"])
        if result is None:
            problem = "timed out"
        elif result.returncode:
            problem = error_problem(result, case)
            if problem is None and os.path.exists(directory):
                problem = "the output directory was written"
        else:
            problem = trajectory_problem(os.path.join(directory, "trajectory.csv"))
        if not problem:
            counts["clear error" if result.returncode else "clean run"] += 1
        else:
            keep = os.path.join(out, f"failed_{n}.yaml")
            shutil.copy(case, keep)
            report(n, source, changes, problem, result.stderr if result else "", keep)
    shutil.rmtree(os.path.join(out, "run"), ignore_errors=True)
    for leftover in ("case.urdf", "case.yaml"):
        if os.path.exists(os.path.join(out, leftover)):
            os.remove(os.path.join(out, leftover))
    total = 2 * options.urdfs + options.scenarios
    print(f"{options.urdfs} URDF and {options.scenarios} scenario cases (seed {options.seed}): "
          f"{counts['clean run']} clean runs, {counts['clear error']} clear errors of {total} runs; {failed} failed")
    if failed == 0 and not options.out:
        shutil.rmtree(out, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
