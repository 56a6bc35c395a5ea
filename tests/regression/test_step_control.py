"""Step control in statics (input/cantilever_rollup.yaml):
 - with a first step larger than max_rotation_increment allows (0.5 of the roll-up turns the tip
   by pi), the controller halves until steps are accepted, still lands on every output time and
   completes with the same tip as the reference run (to 1e-9 L);
 - with min_step just below that first step, the run stops after the rejection with exit status
   1 and one message naming the time, the reason and min_step, and the result file holds the
   initial state.
And in dynamics (tests/regression/inputs/fast_hinge.yaml): a body turning freely on a hinge at
20 rad/s with steps of 0.2 s and max_rotation_increment 3: the joint's released angle counts in
the step test, so steps are halved until it turns less than 3 rad a step; the angle at t = 1 s is
then the sum of em's Cayley turns 2 atan(W h/2) over the steps taken, to 1e-9 rad (13.9 rad for
the 20 rad of the exact motion: the phase error of steps with W h up to 3; before, it read
796 rad, steps taking 2 pi k more), and the energy stays constant (1e-9 relative)."""

import re

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("step control")
rollup = f"{args.source_dir}/input/cantilever_rollup.yaml"

_, stdout, _ = mt.run_msflex(args, rollup, f"{args.work_dir}/halving.h5", extra=["-analysis_initial_step", "0.5", "-analysis_max_step", "0.5"])
halvings = len(re.findall(r"rejected: a rotation increment \(of a node, or a joint's released angle\) of \S+ rad exceeds max_rotation_increment = \S+ rad; halving", stdout))
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

_, stdout, _ = mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/fast_hinge.yaml", f"{args.work_dir}/fast_hinge.h5")
# (em measures the hinge's angle by 2 tan(dphi/2), and the message says so)
halvings = len(re.findall(r"rejected: a rotation increment \(of a node, or a joint's released angle, as 2 tan\(dphi/2\) in mc and em\) of \S+ rad exceeds", stdout))
check.true(f"fast hinge: steps halved for the joint's angle ({halvings})", halvings >= 1)
h = mt.history(f"{args.work_dir}/fast_hinge.h5")
# em turns a body spinning at a constant rate W by 2 atan(W h / 2) per step (the Cayley map).
cayley = np.sum(2.0 * np.arctan(20.0 * h["step_size"][1:] / 2.0))
check.less("fast hinge: |j.rx(1 s) - sum of 2 atan(W h / 2) over the steps|", abs(h["j.rx"][-1] - cayley), 1e-9)
check.less("fast hinge: energy_balance range / total energy", np.ptp(h["energy_balance"]) / h["total_energy"][0], 1e-9)
check.finish()
