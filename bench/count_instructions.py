#!/usr/bin/env python3
"""Instructions per controller cycle, by function, from valgrind's callgrind.

  python3 bench/count_instructions.py BENCH_WBM FIXTURE [FIXTURE ...] [--top N]
                                      [--min-time S] [-- BENCH_WBM_FLAGS ...]

Runs `BENCH_WBM --benchmark_filter=^FIXTURE/wbm/cycle/` under callgrind with collection
switched on only inside wbm::Controller::update, and prints the instructions executed
per call of it (one control cycle) with the functions that execute them (self cost:
inlined code counts for the function it is inlined into). The cycles counted are those
of the fixture's check (4,000 converging to a reachable configuration, 3,000 tracking the
moving targets) and the few timed ones. Unlike times, the counts are the same from run
to run of a build (within 0.1 %), so they show what a change removed or added without
the noise of a shared machine; they are not times (see bench/README.md, "Instructions
per cycle"). Flags after `--` go to bench_wbm (e.g. --wbm_urdf=... for the
fixture "custom"). Standard library only; needs valgrind (Debian package `valgrind`).
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

UPDATE = "wbm::Controller::update(wbm::Command"


def fail(message, status=1):
    print(f"count_instructions.py: {message}", file=sys.stderr)
    sys.exit(status)


def parse_callgrind(path):
    """Returns (calls of Controller::update, {function: self instructions})."""
    names = {}
    self_cost = {}
    calls_to_update = 0
    function = None
    callee = None
    skip_next_cost = False
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            line = line.rstrip("\n")
            m = re.match(r"^(c?fn)=\((\d+)\)(?: (.*))?$", line)
            if m:
                kind, key, name = m.groups()
                if name is not None:
                    names[key] = name
                if kind == "fn":
                    function = names.get(key, key)
                else:
                    callee = names.get(key, key)
                continue
            if line.startswith("calls="):
                if callee is not None and callee.startswith(UPDATE):
                    calls_to_update += int(line.split("=", 1)[1].split()[0])
                skip_next_cost = True  # the next cost line is the call's inclusive cost
                continue
            m = re.match(r"^([+-]?\d+|\*)((?: \d+)+)$", line)
            if m and function is not None:
                if skip_next_cost:
                    skip_next_cost = False
                    continue
                self_cost[function] = self_cost.get(function, 0) + int(m.group(2).split()[0])
    return calls_to_update, self_cost


def short_name(name):
    name = name.replace("(anonymous namespace)::", "")
    depth, out = 0, []
    for ch in name:  # drop argument lists, keep template arguments
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif depth == 0:
            out.append(ch)
    name = "".join(out).split(" [")[0].strip()
    name = re.sub(r" const$", "", name)
    return re.sub(r"^[\w:<>]+ (?=[\w:]+::)", "", name)  # a template's return type


def count(binary, fixture, min_time, extra, top):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "callgrind.out")
        command = ["valgrind", "--tool=callgrind", f"--toggle-collect={UPDATE.split('(')[0]}(*",
                   f"--callgrind-out-file={out}", binary, f"--benchmark_filter=^{re.escape(fixture)}/wbm/cycle/",
                   f"--benchmark_min_time={min_time}"] + extra
        run = subprocess.run(command, capture_output=True, text=True)
        if run.returncode != 0 or not os.path.exists(out):
            # bench_wbm's own messages, without valgrind's banner and summary ("==PID== ...").
            own = "\n".join(line for line in run.stderr.splitlines() if not re.match(r"==\d+==", line))
            fail(f"{fixture}: bench_wbm under valgrind failed (exit {run.returncode}):\n{own[-2000:]}")
        cycles, cost = parse_callgrind(out)
    total = sum(cost.values())
    if cycles == 0 or total == 0:
        fail(f"{fixture}: no controller cycle was run (is '{fixture}' a fixture of {binary}? "
             f"bench_wbm --benchmark_list_tests lists them)")
    if not any(name.startswith(UPDATE) for name in cost):
        fail(f"{fixture}: callgrind recorded no instructions in {UPDATE.split('(')[0]} itself; "
             f"the output format or the function's name changed")
    print(f"{fixture}: {total / cycles:.0f} instructions per controller cycle ({cycles} cycles under callgrind)")
    print(f"  {'per cycle':>9}  {'share':>6}  function (self: inlined code counts where it is inlined)")
    for name, n in sorted(cost.items(), key=lambda kv: -kv[1])[:top]:
        print(f"  {n / cycles:9.0f}  {100.0 * n / total:5.1f}%  {short_name(name)}")
    print()


def main(argv):
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    top, min_time, positional = 25, "0.02", []
    i = 0
    while i < len(argv):
        if argv[i] in ("--top", "--min-time") and i + 1 < len(argv):
            value = argv[i + 1]
            if argv[i] == "--top":
                if not (value.isdigit() and int(value) > 0):
                    fail(f"--top expects a positive integer, got '{value}'", 2)
                top = int(value)
            else:
                try:
                    valid = float(value) > 0.0
                except ValueError:
                    valid = False
                if not valid:
                    fail(f"--min-time expects seconds > 0 (e.g. 0.02), got '{value}'", 2)
                min_time = value
            i += 2
        elif argv[i] in ("-h", "--help"):
            print(__doc__)
            return 0
        elif argv[i].startswith("-"):
            fail(f"unknown option '{argv[i]}' (see --help)", 2)
        else:
            positional.append(argv[i])
            i += 1
    if len(positional) < 2:
        fail("usage: count_instructions.py BENCH_WBM FIXTURE [FIXTURE ...] [--top N] [--min-time S] [-- FLAGS]", 2)
    binary, fixtures = positional[0], positional[1:]
    if not (os.path.isfile(binary) and os.access(binary, os.X_OK)):
        fail(f"no executable bench_wbm at '{binary}'", 2)
    if shutil.which("valgrind") is None:
        fail("valgrind not found: install it (Debian: apt-get install valgrind)", 2)
    for fixture in fixtures:
        count(binary, fixture, min_time, extra, top)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
