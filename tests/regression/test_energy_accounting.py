"""Energy accounting (history series external_work, energy_balance = total - work, and
algorithmic_dissipation = work - (total - total_0)), with a joint that moves, a driven coordinate and
time-varying loads (tests/regression/inputs/pinion_torque_drive.yaml, a linear mechanism):
- newmark and genalpha with rho_infinity = 1 (the trapezoidal rule, energy-conserving for linear
  systems): the work is taken with the scheme's own quadrature, so the dissipation stays at
  round-off, |D| <= 1e-11 of the energy;
- genalpha with rho_infinity = 0.8 dissipates: D ends positive, below 1 % of the energy;
- em: energy - work constant to the Newton tolerance, |D| <= 1e-8 of the energy; the same on the
  driven rack-and-pinion example (input/rack_pinion.yaml, a flexible rack) over 1.2 s."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("energy accounting")
source = f"{args.source_dir}/tests/regression/inputs/pinion_torque_drive.yaml"
cases = [("newmark", ["-analysis_integrator", "newmark"]),
         ("genalpha, rho = 1", ["-analysis_integrator", "genalpha", "-analysis_spectral_radius", "1"]),
         ("genalpha, rho = 0.8", ["-analysis_integrator", "genalpha", "-analysis_spectral_radius", "0.8"]),
         ("em", ["-analysis_integrator", "em"])]


def series(path):
    h = mt.history(path)
    return {name: h[name] for name in ("total_energy", "external_work", "energy_balance", "algorithmic_dissipation")}


for label, options in cases:
    output = f"{args.work_dir}/pinion_{label.split(',')[0]}_{options[-1]}.h5"
    mt.run_msflex(args, source, output, extra=["-quiet", *options])
    h = series(output)
    energy, dissipation = np.abs(h["total_energy"]).max(), h["algorithmic_dissipation"]
    print(f"{label}: largest energy {energy:.6g} J, largest work {np.abs(h['external_work']).max():.6g} J, "
          f"dissipation at the end {dissipation[-1]:.3e} J, largest |D| {np.abs(dissipation).max():.3e} J")
    check.less(f"{label}: D + energy_balance - total_0 (identity)", np.abs(dissipation + h["energy_balance"] - h["total_energy"][0]).max(), 1e-12 * energy)
    if label.startswith("newmark") or "rho = 1" in label:
        check.less(f"{label}: largest |D| / energy (round-off)", np.abs(dissipation).max() / energy, 1e-11)
    elif "0.8" in label:
        check.less(f"{label}: D at the end is positive (-D / energy)", -dissipation[-1] / energy, 0.0)
        check.less(f"{label}: D at the end / energy", dissipation[-1] / energy, 1e-2)
    else:
        check.less(f"{label}: largest |D| / energy (Newton tolerance)", np.abs(dissipation).max() / energy, 1e-8)

output = f"{args.work_dir}/rack_pinion_em.h5"
mt.run_msflex(args, f"{args.source_dir}/input/rack_pinion.yaml", output, extra=["-quiet", "-analysis_end_time", "1.2"])
h = series(output)
scale = max(np.abs(h["external_work"]).max(), np.abs(h["total_energy"]).max())
print(f"rack and pinion, em: largest work {np.abs(h['external_work']).max():.6g} J, largest |D| {np.abs(h['algorithmic_dissipation']).max():.3e} J")
check.less("rack and pinion, em: largest |D| / work (Newton tolerance)", np.abs(h["algorithmic_dissipation"]).max() / scale, 1e-8)
check.finish()
