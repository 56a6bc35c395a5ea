"""Step control in dynamics (input/flying_spaghetti.yaml with em): a first step of 0.5 s turns
the beam by more than max_rotation_increment, so the controller halves until steps are accepted,
lands on every output time and completes; the free flight after t = 5 still conserves energy
(1e-8) and linear momentum (1e-10)."""

import re

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("dynamic step control")
output = f"{args.work_dir}/halving.h5"
_, stdout, _ = mt.run_msflex(args, f"{args.source_dir}/input/flying_spaghetti.yaml", output,
                             extra=["-analysis_initial_step", "0.5", "-analysis_max_step", "0.5", "-analysis_end_time", "7.5"])
halvings = len(re.findall(r"rejected: .*; halving", stdout))
print(f"halvings reported: {halvings}")
check.true(f"at least 1 halving reported ({halvings})", halvings >= 1)
h = mt.history(output)
for t in (2.5, 5.0, 7.5):
    mt.row_at_time(h, t)
free = h["time"] >= 5.0 - 1e-12
energy = h["total_energy"][free]
check.less("energy max deviation / energy after t = 5", np.abs(energy - energy[0]).max() / energy[0], 1e-8)
check.less("|p_x - 50| / 50 at the end", abs(h["linear_momentum_x"][-1] - 50.0) / 50.0, 1e-10)
check.finish()
