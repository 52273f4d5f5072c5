#!/usr/bin/env python3
"""Writes a random variant of a humanoid URDF, for the per-model tests on robots nobody
has seen (CTest check_model_random_robots).

    random_robot.py BASE.urdf SEED OUT.urdf

Every movable joint of BASE gets, from a generator seeded with SEED: its origin scaled by
0.2 to 3 plus up to 5 cm, up to 0.6 rad added to each of roll, pitch and yaw, a random unit
axis, and a type: continuous (10 %), prismatic with limits of 1 to 30 cm each way (10 %,
and every prismatic joint), revolute spelled unlimited as sdformat does, +-1e16 (5 %), or
revolute with limits of 0.05 to 3 rad each way. Every mass is scaled by 0.1 to 10. Link
names, and so the hands, head and legs given to check_model.sh, stay as they are.
"""
import math
import random
import re
import sys


def joint_variant(rnd, joint):
    if 'type="fixed"' in joint or 'type="floating"' in joint:
        return joint

    def origin(m):
        values = [float(x) * rnd.uniform(0.2, 3.0) + rnd.uniform(-0.05, 0.05) for x in m.group(1).split()]
        return '<origin xyz="%s"' % " ".join("%.6g" % v for v in values)

    joint = re.sub(r'<origin xyz="([^"]*)"', origin, joint)
    joint = re.sub(r'rpy="([^"]*)"',
                   lambda m: 'rpy="%s"' % " ".join("%.6g" % (float(x) + rnd.uniform(-0.6, 0.6)) for x in m.group(1).split()),
                   joint)
    axis = [rnd.gauss(0.0, 1.0) for _ in range(3)]
    norm = math.sqrt(sum(a * a for a in axis))
    joint = re.sub(r'<axis xyz="[^"]*"', '<axis xyz="%s"' % " ".join("%.17g" % (a / norm) for a in axis), joint)
    kind = rnd.random()
    limits = r'lower="[^"]*" upper="[^"]*"'
    prismatic = 'type="prismatic"' in joint
    if kind < 0.10:
        joint = joint.replace('type="revolute"', 'type="continuous"')
    elif kind < 0.20 or prismatic:  # a prismatic joint stays one, with other limits
        joint = joint.replace('type="revolute"', 'type="prismatic"')
        joint = re.sub(limits, 'lower="%.4g" upper="%.4g"' % (-rnd.uniform(0.01, 0.3), rnd.uniform(0.01, 0.3)), joint)
    elif kind < 0.25:
        joint = re.sub(limits, 'lower="-1e16" upper="1e16"', joint)
    else:
        joint = re.sub(limits, 'lower="%.4g" upper="%.4g"' % (-rnd.uniform(0.05, 3.0), rnd.uniform(0.05, 3.0)), joint)
    return joint


def main():
    base, seed, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    rnd = random.Random(seed)
    text = open(base).read()
    text = re.sub(r"<joint .*?</joint>", lambda m: joint_variant(rnd, m.group(0)), text, flags=re.S)
    text = re.sub(r'<mass value="([^"]*)"', lambda m: '<mass value="%.5g"' % (float(m.group(1)) * rnd.uniform(0.1, 10)),
                  text)
    with open(out, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
