#!/usr/bin/env python3
"""The control cycle's cache footprint: the 64-byte lines of code and data one cycle touches.

Runs bench/trace_cycle (a shipped model's controller, as for forwarding_stalls.py) under
valgrind's lackey and counts, per cycle, the distinct 64-byte lines of the instructions it
executes and of the data it loads and stores, next to this machine's L1 caches (from
/sys/devices/system/cpu/cpu0/cache). A cycle whose code or data lines exceed its L1 cache
evicts part of itself and fetches it again from L2 in the next cycle: that cost shows in
no stage timed alone (bench/README.md, "Inside the cycle the stages cost more than
alone"). For the last cycle analysed it lists the data in contiguous regions (arrays and
objects: gaps of at most 4 lines joined), each with the functions that touch it first in
the cycle, and the code lines per function. It also counts the distinct instructions a cycle
executes (the trace program's own few hundred included): the core's op cache holds a few
thousand decoded instructions, and code it no longer holds is decoded again.

Usage: footprint.py BUILD_DIR [MODEL_ID] [--cycles N] [--skip K] [--top T]
Self-check: the trace program's planted function runs once per cycle, so its code must be
among every cycle's lines (exit 1 otherwise). Standard library only; needs valgrind and
binutils (addr2line).
"""
import collections
import os
import statistics
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from forwarding_stalls import fail, locate, records, trace_arguments, trace_cycles  # noqa: E402

LINE = 64


def cache_size(kind):
    """Size in bytes of this machine's level-1 cache of `kind` ("Data", "Instruction"), or None."""
    root = "/sys/devices/system/cpu/cpu0/cache"
    try:
        for entry in sorted(os.listdir(root)):
            path = os.path.join(root, entry)
            with open(os.path.join(path, "level")) as f:
                level = f.read().strip()
            with open(os.path.join(path, "type")) as f:
                type_ = f.read().strip()
            if level == "1" and type_ == kind:
                with open(os.path.join(path, "size")) as f:
                    text = f.read().strip()
                return int(text[:-1]) * 1024 if text.endswith("K") else int(text)
    except OSError:
        return None
    return None


Cycle = collections.namedtuple("Cycle", "code data instructions executed")


def instructions_disjoint(instructions):
    """True if no two of the instructions (address -> length) share a byte, as in compiled code."""
    ordered = sorted(instructions.items())
    return all(address + length <= following for (address, length), (following, _) in zip(ordered, ordered[1:]))


def analyse(trace_path, marker, skip):
    """Per analysed cycle: its code lines (a set), its data lines (line -> the address of the
    instruction that touched it first in the cycle), its distinct instructions (address ->
    length in bytes) and the number of instructions it executed."""
    per_cycle = []
    code, data, instructions, executed = set(), {}, {}, 0
    markers = 0
    current = 0
    for kind, address, size in records(trace_path):
        if kind == b"I":
            current = address
            if current == marker:
                if markers > skip:
                    per_cycle.append(Cycle(code, data, instructions, executed))
                markers += 1
                code, data, instructions, executed = set(), {}, {}, 0
            code.add(current // LINE)
            instructions[current] = size
            executed += 1
            continue
        for data_line in (address // LINE, (address + size - 1) // LINE):
            data.setdefault(data_line, current)
    return per_cycle  # the part after the last marker is not a whole cycle


def regions(data_lines, gap=4):
    """Contiguous runs of line numbers (gaps of at most `gap` lines joined), largest first."""
    runs, run = [], []
    for number in sorted(data_lines):
        if run and number - run[-1] > gap:
            runs.append(run)
            run = []
        run.append(number)
    if run:
        runs.append(run)
    return sorted(runs, key=len, reverse=True)


def main():
    args = trace_arguments(__doc__.split("\n\n")[0], 12, 4, 15, "regions and functions").parse_args()
    if args.cycles <= args.skip + 1:
        fail(f"--cycles ({args.cycles}) must exceed --skip ({args.skip}) by at least 2")
    with tempfile.TemporaryDirectory() as scratch:
        trace_path, library, base, marker, planted = trace_cycles(args.build_dir, args.model, args.cycles, scratch)
        print(f"analysing cycles {args.skip + 1}-{args.cycles - 1} ...", file=sys.stderr, flush=True)
        per_cycle = analyse(trace_path, marker, args.skip)
    if not per_cycle:
        fail("no whole cycle found in the trace (the marker was not executed)", 1)
    if not all(planted // LINE in cycle.code for cycle in per_cycle):  # its first instruction's line
        fail("the planted function's code is missing from a cycle's lines: the analysis is broken", 1)
    if not all(instructions_disjoint(cycle.instructions) and len(cycle.instructions) <= cycle.executed
               for cycle in per_cycle):
        fail("a cycle's distinct instructions overlap or outnumber its executed ones: the analysis is broken", 1)
    code_counts = [len(cycle.code) for cycle in per_cycle]
    data_counts = [len(cycle.data) for cycle in per_cycle]
    distinct = statistics.median(len(cycle.instructions) for cycle in per_cycle)
    distinct_bytes = statistics.median(sum(cycle.instructions.values()) for cycle in per_cycle)
    executed = statistics.median(cycle.executed for cycle in per_cycle)
    l1d, l1i = cache_size("Data"), cache_size("Instruction")

    def against(count, size):
        return f" ({count * LINE / size:.0%} of the {size // 1024} KiB L1)" if size else ""

    code_median, data_median = statistics.median(code_counts), statistics.median(data_counts)
    # Code run once per cycle has to be decoded again when the core's op cache (a few thousand
    # decoded instructions) no longer holds it: the distinct instructions, not the lines, are
    # what competes for it (bench/README.md, "Inside the cycle the stages cost more than alone").
    print(f"{args.model}: per cycle (median of {len(per_cycle)}) {code_median:.0f} lines of code, "
          f"{code_median * LINE / 1024:.1f} KiB{against(code_median, l1i)}; {data_median:.0f} lines of data, "
          f"{data_median * LINE / 1024:.1f} KiB{against(data_median, l1d)}; {distinct:.0f} distinct instructions "
          f"({distinct_bytes / 1024:.1f} KiB) of {executed:.0f} executed")

    code, data = per_cycle[-1].code, per_cycle[-1].data
    end = base + os.path.getsize(library)
    touchers = sorted({pc for pc in data.values() if base <= pc < end})
    code_in_library = sorted({line * LINE for line in code if base <= line * LINE < end})
    places = locate(library, sorted(set(pc - base for pc in touchers) | set(a - base for a in code_in_library)))

    def function(pc):
        if not base <= pc < end:
            return "(outside libwbm)"
        name = places.get(pc - base, ("?", "?"))[0].replace("(anonymous namespace)::", "")
        return name.split("(")[0].split("<")[0]

    print(f"\n  data regions of the last cycle (lines touched / lines spanned, first touched by):")
    for run in regions(data)[: args.top]:
        firsts = collections.Counter(function(data[number]) for number in run).most_common(3)
        who = ", ".join(f"{name} {count}" for name, count in firsts)
        print(f"  {len(run):5d} / {run[-1] - run[0] + 1:5d}  {who}")
    print(f"\n  code lines of the last cycle by function:")
    by_function = collections.Counter(function(line * LINE) for line in code)
    for name, count in by_function.most_common(args.top):
        print(f"  {count:5d}  {name}")


if __name__ == "__main__":
    main()
