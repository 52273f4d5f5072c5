#!/usr/bin/env python3
"""Summary of scripts/check_model.sh: the tests that ran on the user's robot, from the
GoogleTest JSON reports of the test binaries.

    check_model_summary.py ROBOT.urdf REPORT.json [REPORT.json ...]

Prints one line per test (passed, skipped or FAILED, and its time) and the totals. Exit
status 1 if a test failed, a report is missing or unreadable, or no test ran at all (a
filter that matched nothing must not read as a pass); else 0.
"""
import json
import sys


def read_tests(path):
    """(suite, test name, result, seconds, failure messages) for every test in a report."""
    with open(path) as f:
        report = json.load(f)
    for suite in report.get("testsuites", []):
        for test in suite.get("testsuite", []):
            failures = [entry.get("failure", "") for entry in test.get("failures", [])]
            result = "FAILED" if failures else ("skipped" if test.get("result") == "SKIPPED" else "passed")
            seconds = float(test.get("time", "0s").rstrip("s") or 0)
            yield suite["name"].split("/")[-1], test["name"], result, seconds, failures


def main(argv):
    if len(argv) < 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    urdf, reports = argv[1], argv[2:]
    rows, problems = [], []
    for path in reports:
        try:
            rows.extend(read_tests(path))
        except (OSError, ValueError, KeyError) as e:
            problems.append(f"{path}: {e}")
    print(f"\nwbm's per-model tests on {urdf}:")
    width = max((len(f"{suite}.{name}") for suite, name, *_ in rows), default=0)
    for suite, name, result, seconds, _ in rows:
        print(f"  {result:7s} {f'{suite}.{name}':{width}s} {seconds:7.2f} s")
    counts = {r: sum(1 for row in rows if row[2] == r) for r in ("passed", "skipped", "FAILED")}
    print(f"{counts['passed']} passed, {counts['skipped']} skipped, {counts['FAILED']} failed")
    for problem in problems:
        print(f"error: cannot read the report {problem}", file=sys.stderr)
    if not rows:
        print("error: no test ran on the robot (no test name ends in /user)", file=sys.stderr)
    if counts["FAILED"]:
        print("The failures are printed above, with the configuration and the values compared.", file=sys.stderr)
    return 1 if counts["FAILED"] or problems or not rows else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
