"""Spin-up of a flexible arm (input/spin_up.yaml; Simo & Vu-Quoc 1986):
 - genalpha (the file's integrator): in steady spin (15 < t < 20, omega = 6 rad/s) the mean axial
   tip displacement in the rotating frame matches the centrifugal stretch tan(kL)/k - L =
   5.1432e-4 of a uniformly rotating bar to 1 %;
 - em: total energy minus the work of the loads, including the reaction that prescribes the
   root rotation, stays constant to 1e-8 relative to the kinetic energy over the whole run."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("spin-up")
source = f"{args.source_dir}/input/spin_up.yaml"

output = f"{args.work_dir}/genalpha.h5"
mt.run_msflex(args, source, output, extra=["-output_every", "100000", "-quiet"])
tip = mt.probe_history(output, "tip")
steady = tip["time"] >= 15.0
angle = 6.0 * tip["time"][steady] - 45.0  # the prescribed root rotation in steady spin
position = tip["position"][steady]
axial = position[:, 0] * np.cos(angle) + position[:, 1] * np.sin(angle) - 10.0
print(f"genalpha: mean axial tip displacement in the rotating frame over 15 < t < 20: {axial.mean():.5e} (exact 5.1432e-4)")
check.less("genalpha: |mean stretch / 5.1432e-4 - 1|", abs(axial.mean() / 5.1432e-4 - 1.0), 0.01)

output = f"{args.work_dir}/em.h5"
mt.run_msflex(args, source, output, extra=["-analysis_integrator", "em", "-output_every", "100000", "-quiet"])
h = mt.history(output)
balance = h["energy_balance"]
print(f"em: kinetic energy at the end {h['kinetic_energy'][-1]:.6e}, external work {h['external_work'][-1]:.6e}")
check.less("em: max |energy balance drift| / final kinetic energy", np.abs(balance - balance[0]).max() / h["kinetic_energy"][-1], 1e-8)
check.finish()
