"""Step control in statics (input/cantilever_rollup.yaml):
 - with a first step larger than max_rotation_increment allows (0.5 of the roll-up turns the tip
   by pi), the controller halves until steps are accepted, still lands on every output time and
   completes with the same tip as the reference run (to 1e-9 L);
 - with min_step just below that first step, the run stops after the rejection with exit status
   1 and one message naming the time, the reason and min_step, and the result file holds the
   initial state."""

import re

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("step control")
rollup = f"{args.source_dir}/input/cantilever_rollup.yaml"

_, stdout, _ = mt.run_msflex(args, rollup, f"{args.work_dir}/halving.h5", extra=["-analysis_initial_step", "0.5", "-analysis_max_step", "0.5"])
halvings = len(re.findall(r"rejected: a nodal rotation increment of \S+ rad exceeds max_rotation_increment = \S+ rad; halving", stdout))
print(f"halvings reported: {halvings}")
check.true(f"at least 1 halving reported ({halvings})", halvings >= 1)
tip = mt.probe_history(f"{args.work_dir}/halving.h5", "tip")
for t in (0.25, 0.5, 0.75, 1.0):
    mt.row_at_time(tip, t)
check.less("|tip at t = 1| / L after halvings", np.linalg.norm(tip["position"][mt.row_at_time(tip, 1.0)]) / 10.0, 1e-6)

code, _, stderr = mt.run_msflex(args, rollup, f"{args.work_dir}/stopped.h5",
                                extra=["-analysis_initial_step", "0.5", "-analysis_max_step", "0.5", "-analysis_min_step", "0.4"], expect_success=False)
message = [line for line in stderr.splitlines() if line.startswith("msflex:")]
print("stop message:", message[0] if message else stderr[:300])
check.equal("exit status", code, 1)
named = bool(message) and all(word in message[0] for word in ("stopped at t = 0", "rotation increment", "min_step = 0.4", "stopped.h5"))
check.true("the message names time, reason, min_step and file", named)
with h5py.File(f"{args.work_dir}/stopped.h5", "r") as f:
    check.equal("frames in the stopped run's file", mt.frame_count(f), 1)
check.finish()
