#!/usr/bin/env python3
"""Loads in the control cycle that likely wait for a failed store-to-load forwarding.

Runs bench/trace_cycle (a shipped model's controller, the fixtures' elements) under
valgrind's lackey, which records the address and size of every load and store, and looks
for loads that overlap a recent store (one of the last --stores stores, within the last
--window instructions) but do not lie inside the youngest such store: a 16-byte load of two
8-byte stores, or a load straddling two 16-byte stores. x86 cores forward a store's data
to a later load only when one store holds all the load's bytes; otherwise the load waits
until the stores reach the cache, on the chain if its value is on the cycle's critical path.
The window is a model of the store buffer, not the core: a listed load is a candidate, and
whether it costs time is for an A/B of the cycle to say (bench/README.md, "Inside the
cycle").

Usage: forwarding_stalls.py BUILD_DIR [MODEL_ID] [--cycles N] [--skip K] [--top T]
Prints per load instruction how often per cycle it was flagged, with its function and
(with a build that has debug information, e.g. CMAKE_CXX_FLAGS=-g) source line. The
trace program plants one such load per cycle (wbm_trace_planted_stall); if the report does
not list it, the analysis is broken and the script exits with status 1.
Standard library only; needs valgrind and binutils (addr2line).
"""
import argparse
import collections
import os
import re
import subprocess
import sys
import tempfile


def fail(message, status=2):
    print(f"{os.path.basename(sys.argv[0])}: {message}", file=sys.stderr)
    sys.exit(status)


def records(trace_path):
    """The records of a lackey trace: (b"I", address, length) for an instruction executed,
    (b"L" | b"S" | b"M", address, size) for a load, store or modify."""
    with open(trace_path, "rb") as trace:
        for line in trace:
            if line.startswith(b"I "):
                address_text, size_text = line[3:].split(b",")
                yield b"I", int(address_text, 16), int(size_text)
            elif len(line) >= 4 and line[0:1] == b" ":
                address_text, size_text = line[3:].split(b",")
                yield line[1:2], int(address_text, 16), int(size_text)


def analyse(trace_path, marker, skip, stores_kept, window):
    """Flag counts per load instruction address, and the number of cycles analysed."""
    stores = collections.deque()
    flagged = collections.Counter()
    instruction = 0
    current = 0
    markers = 0
    for kind, address, size in records(trace_path):
        if kind == b"I":
            current = address
            instruction += 1
            if current == marker:
                markers += 1
            continue
        if kind in (b"L", b"M") and markers > skip:
            for store_address, store_size, store_instruction in reversed(stores):
                if instruction - store_instruction > window:
                    break
                if store_address < address + size and address < store_address + store_size:
                    inside = store_address <= address and address + size <= store_address + store_size
                    if not inside:
                        flagged[current] += 1
                    break
        if kind in (b"S", b"M"):
            stores.append((address, size, instruction))
            if len(stores) > stores_kept:
                stores.popleft()
    return flagged, max(markers - skip, 0)


def locate(binary, offsets):
    """Function and source line of each offset in binary (addr2line; '?' where unknown)."""
    if not offsets:
        return {}
    result = subprocess.run(["addr2line", "-f", "-C", "-e", binary] + [hex(o) for o in offsets],
                            capture_output=True, text=True)
    lines = result.stdout.splitlines()
    places = {}
    for i, offset in enumerate(offsets):
        function = lines[2 * i] if 2 * i < len(lines) else "?"
        where = lines[2 * i + 1] if 2 * i + 1 < len(lines) else "?"
        where = where.split(" (discriminator")[0]
        where = re.sub(r"^.*?/(src|include|bench|tests)/", r"\1/", where)
        places[offset] = (function, where)
    return places


def trace_cycles(build_dir, model, cycles, scratch):
    """Runs bench/trace_cycle MODEL CYCLES under lackey into scratch/trace; returns the trace's
    path, the library's path and load address, and the marker's and the planted function's
    addresses. Exits with a message if the program is missing or fails."""
    program = os.path.join(build_dir, "bench", "trace_cycle")
    if not os.path.exists(program):
        fail(f"{program} not found: build the target trace_cycle (cmake --build {build_dir} --target trace_cycle)")
    trace_path = os.path.join(scratch, "trace")
    print(f"tracing {cycles} cycles of {model} under lackey ...", file=sys.stderr, flush=True)
    run = subprocess.run(["valgrind", "--tool=lackey", "--trace-mem=yes", f"--log-file={trace_path}", program,
                          model, str(cycles)], capture_output=True, text=True)
    if run.returncode != 0:
        fail(f"trace_cycle failed (exit {run.returncode}): {run.stderr.strip()}", 1)
    found = re.search(r"library (\S+) base (0x[0-9a-f]+) marker (0x[0-9a-f]+) planted (0x[0-9a-f]+)", run.stdout)
    if not found:
        fail(f"trace_cycle printed no addresses: {run.stdout.strip()}", 1)
    return (trace_path, found.group(1), int(found.group(2), 16), int(found.group(3), 16),
            int(found.group(4), 16))


def trace_arguments(description, cycles, skip, top, listed):
    """The arguments of a script that analyses trace_cycle: BUILD_DIR [MODEL_ID] --cycles
    --skip --top, with these defaults (`listed`: what --top counts)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("build_dir")
    parser.add_argument("model", nargs="?", default="paper")
    parser.add_argument("--cycles", type=int, default=cycles, help=f"cycles run (default {cycles})")
    parser.add_argument("--skip", type=int, default=skip, help=f"cycles not analysed at the start (default {skip})")
    parser.add_argument("--top", type=int, default=top, help=f"{listed} listed (default {top})")
    return parser


def main():
    parser = trace_arguments(__doc__.split("\n\n")[0], 130, 100, 25, "load instructions")
    parser.add_argument("--stores", type=int, default=64, help="stores kept (the store buffer; default 64)")
    parser.add_argument("--window", type=int, default=400, help="instructions a store is kept (default 400)")
    args = parser.parse_args()
    if args.cycles <= args.skip:
        fail(f"--cycles ({args.cycles}) must exceed --skip ({args.skip})")
    with tempfile.TemporaryDirectory() as scratch:
        trace_path, library, base, marker, planted = trace_cycles(args.build_dir, args.model, args.cycles, scratch)
        print(f"analysing cycles {args.skip + 1}-{args.cycles} ...", file=sys.stderr, flush=True)
        flagged, cycles = analyse(trace_path, marker, args.skip, args.stores, args.window)
    if cycles == 0:
        fail("no cycle found in the trace (the marker was not executed)", 1)
    # The library's code lies within its file's size above base (a bound, not its exact extent).
    top = flagged.most_common(args.top)
    end = base + os.path.getsize(library)
    library_offsets = [pc - base for pc, _ in top if base <= pc < end]
    places = locate(library, library_offsets)
    planted_found = any(0 <= pc - planted < 256 for pc in flagged)
    total = sum(flagged.values())
    print(f"{args.model}: {total / cycles:.1f} loads per cycle flagged over {cycles} cycles "
          f"(window: {args.stores} stores, {args.window} instructions)")
    print("  per cycle  load instruction (library offset)  function  source")
    for pc, count in top:
        if base <= pc < end:
            function, where = places.get(pc - base, ("?", "?"))
            print(f"  {count / cycles:9.2f}  {hex(pc - base):>10}  {function[:70]}  {where}")
        elif 0 <= pc - planted < 256:
            print(f"  {count / cycles:9.2f}  {'(planted)':>10}  wbm_trace_planted_stall  bench/trace_cycle.cpp")
        else:
            print(f"  {count / cycles:9.2f}  {hex(pc):>10}  (outside libwbm: libc, libstdc++ or the trace program)")
    if not planted_found:
        fail("the planted load was not flagged: the analysis is broken", 1)


if __name__ == "__main__":
    main()
