#!/bin/bash
# Usage: cli_smoke_test.sh WBM WORKDIR
# The CLI as a user runs it: JSON outputs parse with python3's json module, and an
# exported URDF imports again with the upper body as root.
set -euo pipefail
wbm=$1
work=$2
mkdir -p "$work"
json_ok() { python3 -c 'import json, sys; json.load(sys.stdin)'; }

# Outputs captured before grep -q: piped, a grep that matches and exits before the writer is
# done fails the pipeline under pipefail (SIGPIPE) now and then.
info=$("$wbm" model info)
grep -q "21 dofs" <<<"$info"
"$wbm" model info --json | json_ok
"$wbm" model fk --frames l_hand_ref --jacobian --json | json_ok
"$wbm" model fk --frames l_hand_ref --jacobian --json |
  python3 -c 'import json, sys; j = json.load(sys.stdin)["frames"]["l_hand_ref"]["jacobian"]; assert len(j) == 6 and all(len(r) == 21 for r in j), j'
rm -f "$work/paper.urdf"
"$wbm" model export -o "$work/paper.urdf"
test -s "$work/paper.urdf"
info=$("$wbm" model info "$work/paper.urdf" --root upper_body --root-height 0.6)
grep -q "21 dofs" <<<"$info"
"$wbm" model info "$work/paper.urdf" --root upper_body --root-height 0.6 --json | json_ok
echo "cli smoke test ok"
