#!/usr/bin/env python3
"""Seeded random scenarios through `wbm run`: every feature at once, checked for its promises.

  python3 tests/random_scenarios.py [WBM [OUT_DIR]] [--seeds A:B] [--random-robots] [--keep]

Each seed writes one valid scenario file on the built-in paper model or a shipped robot
(tests/out_of_reach_probe.py's seven; with --random-robots a seeded variant from
tests/random_robot.py instead, for those it has): random start poses within the limits,
random task elements (hand positions, in the world or relative to the heel or the other
hand, grasp axes about x, y or z, hand attitudes, the view axis, the centre of mass, joint
rows), random filters (bandwidth 0.5-20 1/s, speed limits, orders 2-6), gains (0 to 500),
solver settings (jerk limit 0 to 100, speed limits on or off, thresholds, damping) and
cycle times (0.5-10 ms), and a timeline of one to eight events switching elements and
single rows on and off, moving targets by up to 1 km, turning axis targets, freezing and
releasing dofs, switching balance; balance and walking on from the start on some (half
of the walks with their own trigger tolerances, a third with the heel's lead bounded). Each run
(6 s, every cycle recorded) must:

- exit 0 (the generator writes only valid files);
- keep every joint within its position limits, and, with speed limits on, its speed limit;
- change no joint's rate by more than the Controller's bound k v_max per second where the
  jerk limit k > 0, but where the timeline freezes that dof or switches balance (b_C stops a
  dof at once; summary.json's max_joint_acceleration_to_bound);
- report no invalid input, command or target, and no joint clamped at a limit where k > 0
  (the braking lands on limits);
- not move a dof frozen in b_C (from the start, or by the timeline until released) that
  nothing drives (the balance module drives the upper body's x and y);
- write only finite numbers to trajectory.csv;
- while walking, keep the body (the floating heel) within walking.max_heel_lead steps of the
  feet, plus one cycle's travel and the braking distance, where speed limits are on, but
  after a walk that max_steps ended (it leaves the feet behind).

Prints one line per run and exits 1 if any run breaks a promise, naming the scenario file
it kept (OUT_DIR: a temp dir unless given). Scenarios like these found a runner crash
(balance switched off in a scenario without a balance section) and walks that stopped the
heel within a cycle (walking's heel_stop_time, docs/solver.md). Standard library only.
"""
import argparse
import csv
import json
import math
import os
import random
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import out_of_reach_probe as probe  # noqa: E402  (the robots, their hands, feet and heads)

DURATION = 6.0
RANDOM_ROBOTS = ("g1_29", "h1", "atlas", "nao", "dual")


def dof_limits(wbm, urdf, options):
    """{dof name: (lower, upper, max speed)} from `wbm model info` (the robot options as in the
    scenario; a fixed base has the same dofs, its virtual ones stay frozen)."""
    args = [wbm, "model", "info"] + ([urdf] if urdf else [])
    if "legs:" in options:
        args += ["--legs", options.split("[")[1].split("]")[0].replace(" ", "")]
    run = subprocess.run(args, capture_output=True, text=True, check=True)
    return {p[1]: (float(p[4]), float(p[5]), float(p[6])) for p in (line.split() for line in run.stdout.splitlines())
            if len(p) >= 7 and p[0].isdigit()}


class Generator:
    def __init__(self, wbm, out, random_robots):
        self.wbm, self.out, self.random_robots = wbm, out, random_robots
        self.dofs = {}

    def robot(self, r):
        robot_id = r.choice(list(probe.ROBOTS) + ["paper"])
        if robot_id == "paper":  # the built-in model: its default feet (no foot frames)
            if robot_id not in self.dofs:
                self.dofs[robot_id] = dof_limits(self.wbm, None, "")
            return robot_id, None, "", "l_hand_ref", "r_hand_ref", "", "", "head_camera"
        urdf, options, left, right, left_foot, right_foot = probe.ROBOTS[robot_id]
        path = os.path.join(probe.MODELS, urdf)
        head = probe.HEADS[robot_id]
        if self.random_robots and robot_id in RANDOM_ROBOTS:
            variant = r.randint(1, 40)
            robot_id += f"_random{variant}"
            random_path = os.path.join(self.out, robot_id + ".urdf")
            if not os.path.exists(random_path):
                subprocess.run([sys.executable, os.path.join(probe.ROOT, "tests", "random_robot.py"), path,
                                str(variant), random_path], check=True)
            path = random_path
        if robot_id not in self.dofs:
            self.dofs[robot_id] = dof_limits(self.wbm, path, options)
        return robot_id, path, options, left, right, left_foot, right_foot, head

    def scenario(self, seed):
        """(scenario text, what the checks need to know)."""
        r = random.Random(seed)
        robot_id, path, options, left, right, left_foot, right_foot, head = self.robot(r)
        limits = self.dofs[robot_id]
        dofs = list(limits)
        fixed = "fixed_base" in options
        feet = left_foot is not None
        jerk = r.choice([0, 5, 20, 20, 100])
        limit_speeds = r.random() < 0.85
        walking = feet and r.random() < 0.3
        balance = feet and r.random() < 0.5
        dt = r.choice([0.001, 0.002, 0.004, 0.005, round(r.uniform(0.0005, 0.01), 5)])
        robot_line = f"robot: {{urdf: '{path}', {options}}}" if path else "robot: {builtin: paper}"
        lines = [f"name: random_{seed}", robot_line, f"dt: {dt}",
                 f"duration: {DURATION}", "record_every: 1",
                 f"solver: {{nullspace_gain: {r.choice([0, 0.1, 0.5, 2])}, "
                 f"singular_threshold: {r.choice([0.01, 0.04, 0.1])}, max_damping: {r.choice([0.01, 0.04, 0.2])}, "
                 f"jerk_limit: {jerk}, limit_speeds: {str(limit_speeds).lower()}}}",
                 f"criterion: {{type: {r.choice(['cubic', 'squared'])}}}"]
        # Dofs held by b_C and driven by nothing: dof -> [start, end) times; they must not move.
        virtual = [d for d in dofs if d.startswith(("heel_", "upper_body_"))]
        held_since = {d: 0.0 for d in virtual} if fixed else {}
        if not fixed:
            lines.append("frozen: []" if walking else "frozen: [heel_x, heel_y, heel_yaw]")
            if not walking:
                held_since.update({d: 0.0 for d in ("heel_x", "heel_y", "heel_yaw")})
        held = []
        if (balance or walking) and left_foot:
            lines.append(f"feet: {{length: 0.15, width: 0.07, left_frame: {left_foot}, right_frame: {right_foot}}}")
        if balance:
            lines.append(f"balance: {{enabled: true, compensate: {str(r.random() < 0.7).lower()}, "
                         f"gain: {r.choice([2, 4, 8])}}}")
        if walking:
            # Half of the walks with their own trigger tolerances (log-uniform, 0.1 mm to 5 cm
            # and 0.1 mrad to 0.1 rad); the others scaled to the robot.
            tolerances = ""
            if r.random() < 0.5:
                tolerances = (f", position_tolerance: {10 ** r.uniform(-4, math.log10(0.05)):.6g}"
                              f", angle_tolerance: {10 ** r.uniform(-4, -1):.6g}")
            # A third of the walks with the floating heel's lead bounded (1-3 steps).
            if r.random() < 1 / 3:
                tolerances += f", max_heel_lead: {r.uniform(1, 3):.3g}"
            lines.append("walking: {enabled: true" + tolerances + "}")

        joints = [d for d in dofs if not d.startswith(("heel_", "upper_body_"))]
        if joints and r.random() < 0.3:  # a start away from the home pose, within the limits
            start = {}
            for d in r.sample(joints, min(len(joints), r.randint(1, 3))):
                lower, upper = (max(x, -3.0) if i == 0 else min(x, 3.0) for i, x in enumerate(limits[d][:2]))
                start[d] = round(r.uniform(lower, upper), 4)
            lines.append("initial: {" + ", ".join(f"{d}: {v}" for d, v in start.items()) + "}")

        def filter_text():
            return (f"filter: {{bandwidth: {round(r.uniform(0.5, 20), 2)}, max_speed: {round(r.uniform(0.05, 2), 2)}, "
                    f"order: {r.randint(2, 6)}}}")

        elements = []  # (name, type, rows)
        lines.append("tasks:")
        for side, frame in (("l", left), ("r", right)):
            if r.random() < 0.8:
                other = right if frame == left else left
                reference = r.choice(["", "", "", f", reference: {other}"] + ([] if fixed else [", reference: heel"]))
                lines.append(f"  - {{name: {side}, type: position, frame: {frame}{reference}, "
                             f"gain: {r.choice([0, 1, 10, 50, 500])}, {filter_text()}}}")
                elements.append((side, "position", 3))
            if r.random() < 0.4:
                axis = r.choice(["", ", axis: [1, 0, 0]", ", axis: [0, 1, 0]"])
                lines.append(f"  - {{name: {side}a, type: axis, frame: {frame}{axis}, {filter_text()}}}")
                elements.append((side + "a", "axis", 2))
            if r.random() < 0.25:
                lines.append(f"  - {{name: {side}t, type: attitude, frame: {frame}, {filter_text()}}}")
                elements.append((side + "t", "attitude", 3))
        if head and r.random() < 0.5:
            lines.append(f"  - {{name: v, type: axis, frame: {head}, {filter_text()}}}")
            elements.append(("v", "axis", 2))
        if r.random() < 0.3:
            lines.append(f"  - {{name: c, type: com, {filter_text()}}}")
            elements.append(("c", "com", 3))
        if joints and r.random() < 0.4:
            chosen = r.sample(joints, min(len(joints), r.randint(1, 4)))
            lines.append(f"  - {{name: j, type: joints, dofs: [{', '.join(chosen)}], {filter_text()}}}")
            elements.append(("j", "joints", len(chosen)))
        if not elements:
            lines.append(f"  - {{name: l, type: position, frame: {left}}}")
            elements.append(("l", "position", 3))

        row_names = {"position": "xyz", "com": "xyz", "axis": "01"}
        stopped = set()  # dofs the timeline freezes or balance drives: b_C stops them at once
        balance_switched = False
        frozen = set()
        lines.append("timeline:")
        # Events apply at the start of a cycle: none after the last one's (the runner rejects
        # such a file; a cycle time near 10 ms put it before DURATION - 0.01 s).
        last_start = (round(DURATION / dt) - 1) * dt
        times = sorted({math.floor(r.uniform(0.0, min(DURATION - 0.01, last_start)) * 1000) / 1000
                        for _ in range(r.randint(1, 8))})
        for k, t in enumerate(times):
            parts = [f"t: {t}"]
            on = [name for name, _, _ in elements if r.random() < (0.8 if k == 0 else 0.3)]
            for name, kind, _ in elements:
                if r.random() < 0.1:
                    on.append(name + "." + (r.choice(["roll", "pitch", "yaw"]) if kind == "attitude" else
                                            r.choice(row_names[kind]) if kind in row_names else ""))
            on = [x for x in on if not x.endswith(".")]
            if on:
                parts.append(f"activate: [{', '.join(on)}]")
            off = [name for name, _, _ in elements if k > 0 and name not in on and r.random() < 0.2]
            if off:
                parts.append(f"deactivate: [{', '.join(off)}]")
            relative, targets = {}, {}
            for name, kind, rows in elements:
                if r.random() < 0.5:
                    if kind in ("position", "com"):
                        scale = r.choice([0.05, 0.2, 0.8, 0.8, 5, 1000])
                        relative[name] = [round(r.uniform(-scale, scale), 3) for _ in range(3)]
                    elif kind == "attitude":
                        scale = r.choice([0.3, 1.5, 3.5])
                        relative[name] = [round(r.uniform(-scale, scale), 3) for _ in range(3)]
                    elif kind == "joints":
                        relative[name] = [round(r.uniform(-1, 1), 3) for _ in range(rows)]
                if kind == "axis" and r.random() < 0.5:
                    targets[name] = ([round(r.uniform(-1, 1), 3) for _ in range(3)] if r.random() < 0.95
                                     else [0.0, 0.0, -3.0])
            if relative:
                parts.append("relative_targets: {" + ", ".join(f"{n}: {v}" for n, v in relative.items()) + "}")
            if targets:
                parts.append("targets: {" + ", ".join(f"{n}: {v}" for n, v in targets.items()) + "}")
            candidates = [d for d in dofs if not (fixed and d.startswith(("heel_", "upper_body_")))
                          and not (walking and d.startswith("heel_"))]
            if candidates and r.random() < 0.3:
                chosen = r.sample(candidates, r.randint(1, min(3, len(candidates))))
                parts.append(f"freeze: [{', '.join(chosen)}]")
                stopped |= set(chosen)
                frozen |= set(chosen)
                for d in chosen:
                    held_since.setdefault(d, t)
            if frozen and r.random() < 0.3:
                released = r.choice(sorted(frozen))
                parts.append(f"release: [{released}]")
                frozen.discard(released)
                if released in held_since:
                    held.append((released, held_since.pop(released), t))
            if feet and r.random() < 0.2:
                parts.append(f"balance: {str(r.random() < 0.5).lower()}")
                stopped |= {"upper_body_x", "upper_body_y"}
                balance_switched = True
            lines.append("  - {" + ", ".join(parts) + "}")
        held += [(d, since, DURATION) for d, since in held_since.items()]
        if balance or balance_switched:  # the balance module drives them while frozen
            held = [h for h in held if h[0] not in ("upper_body_x", "upper_body_y")]
        return "\n".join(lines) + "\n", {"robot": robot_id, "jerk": jerk, "limit_speeds": limit_speeds,
                                         "stopped": stopped, "held": held, "dt": dt,
                                         "heel_speed": max(limits[d][2] for d in ("heel_x", "heel_y")) if walking
                                         else 0.0}


def broken_promises(directory, info):
    """What a finished run broke (empty: nothing)."""
    problems = []
    with open(os.path.join(directory, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    limit = summary.get("min_distance_to_limit")  # absent where no joint has position limits
    if limit and limit["value"] < -1e-9:
        problems.append(f"{limit['dof']} {-limit['value']:.3g} beyond its limit")
    speed = summary["max_joint_speed"]
    if info["limit_speeds"] and speed["ratio_to_limit"] > 1 + 1e-9:
        problems.append(f"{speed['dof']} at {speed['ratio_to_limit']:.6g} of its speed limit")
    bound = summary.get("max_joint_acceleration_to_bound")
    if bound and bound["ratio"] > 1 + 1e-9 and bound["dof"] not in info["stopped"]:
        problems.append(f"{bound['dof']}'s rate changed at {bound['ratio']:.6g} x its bound k v_max")
    walk = summary.get("walking")
    if (walk and walk["walks"] > 0 and walk["steps"]["max_heel_lead"] > 0 and walk["walks_at_step_limit"] == 0
            and info["limit_speeds"]):
        # The floating heel held max_heel_lead steps ahead of the feet: beyond it by one
        # cycle's travel and the braking distance (heel_stop_time 0.25 s) at most, x and y
        # each at the heel's speed limit (a walk that max_steps ended leaves the feet behind;
        # without speed limits the heel has none either).
        reach = walk["steps"]["max_heel_lead"] * walk["steps"]["max_step_length"]
        bound = reach + math.sqrt(2) * info["heel_speed"] * (info["dt"] + 0.125) + 1e-9
        if walk["max_body_lead"] > bound:
            problems.append(f"the body {walk['max_body_lead']:.4g} m ahead of the feet, above "
                            f"{walk['steps']['max_heel_lead']:.3g} steps ({reach:.4g} m) and the braking ({bound:.4g} m)")
    cycles = summary["status_cycles"]
    for flag in ("invalid_input", "invalid_command", "invalid_target"):
        if cycles.get(flag, 0):
            problems.append(f"{cycles[flag]} cycles with {flag}")
    if info["jerk"] > 0 and cycles.get("joint_limit_clamped", 0):
        problems.append(f"{cycles['joint_limit_clamped']} cycles with a joint clamped at its limit")
    trajectory = os.path.join(directory, "trajectory.csv")
    with open(trajectory, encoding="utf-8") as f:
        rows = csv.reader(f)
        header = next(rows)
        held = [(header.index("q." + d), d, since, until) for d, since, until in info["held"]]
        first = {}  # column -> its value when the hold began
        for number, row in enumerate(rows, start=2):
            if not all(math.isfinite(float(x)) for x in row):
                problems.append(f"trajectory.csv line {number}: a number that is not finite")
                break
            time = float(row[0])
            for column, dof, since, until in held:
                if since + 2 * info["dt"] <= time < until - info["dt"]:
                    value = float(row[column])
                    if first.setdefault((column, since), value) != value:
                        problems.append(f"{dof}, frozen at {since} s, moved by {value - first[(column, since)]:.3g} "
                                        f"at {time} s")
                        held = [h for h in held if h[0] != column]
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("wbm", nargs="?", default=os.path.join(probe.ROOT, "build", "wbm"))
    parser.add_argument("out", nargs="?")
    parser.add_argument("--seeds", default="0:100", help="A:B, the seeds A to B - 1")
    parser.add_argument("--random-robots", action="store_true", help="seeded random variants of the robots")
    parser.add_argument("--keep", action="store_true", help="keep every run's outputs (removed when it passes)")
    options = parser.parse_args()
    try:
        first, end = (int(x) for x in options.seeds.split(":"))
    except ValueError:
        sys.exit(f"random_scenarios.py: --seeds {options.seeds}: expected A:B, two whole numbers")
    probe.require_program(options.wbm, "random_scenarios.py")
    out = options.out or tempfile.mkdtemp(prefix="random_scenarios_")
    os.makedirs(out, exist_ok=True)
    generator = Generator(options.wbm, out, options.random_robots)
    failed = []
    for seed in range(first, end):
        text, info = generator.scenario(seed)
        name = f"random_{seed}"
        path = os.path.join(out, name + ".yaml")
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        directory = os.path.join(out, name)
        run = subprocess.run([options.wbm, "run", path, "--out", directory, "--no-report"], capture_output=True,
                             text=True)
        if run.returncode != 0:
            problems = [f"wbm run exited {run.returncode}: {run.stderr.strip()[-300:]}"]
        else:
            problems = broken_promises(directory, info)
        print(f"{name:16s} {info['robot']:16s} {'; '.join(problems) if problems else 'ok'}", flush=True)
        if problems:
            failed.append(path)
        elif not options.keep:
            os.remove(path)
            for file in os.listdir(directory):
                os.remove(os.path.join(directory, file))
            os.rmdir(directory)
    print(f"{len(failed)} of {end - first} runs broke a promise" + (": " + ", ".join(failed) if failed else ""))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
