"""Statics through a joint: the roll-up beam cut in two halves joined by a rigid joint
(tests/regression/inputs/rollup_rigid_joint.yaml) gives the uncut beam's tip (input/
cantilever_rollup.yaml) to 1e-10 L at t = 0.5 and 1, with the tip back at the root and a tracked
rotation of 2 pi at t = 1; the joint holds the slave half against the end moment (it exerts
moment_z = -2 pi EI / L on the slave) and transmits no force."""

import math

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("rigid joint in statics")
mt.run_msflex(args, f"{args.source_dir}/input/cantilever_rollup.yaml", f"{args.work_dir}/uncut.h5", extra=["-quiet"])
mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/rollup_rigid_joint.yaml", f"{args.work_dir}/cut.h5", extra=["-quiet"])
uncut, cut = mt.probe_history(f"{args.work_dir}/uncut.h5", "tip"), mt.probe_history(f"{args.work_dir}/cut.h5", "tip")
for t in (0.5, 1.0):
    a, b = uncut["position"][mt.row_at_time(uncut, t)], cut["position"][mt.row_at_time(cut, t)]
    check.less(f"t = {t}: |tip cut - tip uncut| / L", np.linalg.norm(a - b) / 10.0, 1e-10)
row = mt.row_at_time(cut, 1.0)
check.less("t = 1: |tip - root| / L", np.linalg.norm(cut["position"][row]) / 10.0, 1e-6)
check.less("t = 1: |tracked rotation - 2 pi|", abs(cut["rotation_angle"][row] - 2 * math.pi), 1e-9)
h = mt.history(f"{args.work_dir}/cut.h5")
row = mt.row_at_time(h, 1.0)
check.less("joint moment_z / (-2 pi EI / L) - 1", abs(h["weld.moment_z"][row] / (-2 * math.pi * 100 / 10) - 1), 1e-9)
check.less("joint force", np.linalg.norm([h[f"weld.force_{c}"][row] for c in "xyz"]), 1e-8)
check.finish()
