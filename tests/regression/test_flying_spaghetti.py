"""Conservation on the free-flying beam (input/flying_spaghetti.yaml, 10 elements, dt = 0.01):
after the load ends at t = 5 there are 1000 steps to t = 15.
 - em: total energy constant to 1e-8 relative, linear and angular momentum constant to 1e-10
   relative to their magnitude; the impulse gives p = (50, 0, 0) and J_x = 0 (to 1e-10).
 - mc: both momenta constant to 1e-10 (energy not claimed; its drift is printed).
 - newmark: the energy and momentum drifts are printed (no conservation claimed).
 - em with the paper's correction (N_d, 0) (-analysis_em_correction forces): energy and momenta
   conserved as well (1e-8, 1e-10), beta larger than with the default (N_d, M_d) (printed, with
   the Newton iterations, for docs/dynamics.md)."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("flying spaghetti")
source = f"{args.source_dir}/input/flying_spaghetti.yaml"


def free_flight(integrator, end_time, options=()):
    output = f"{args.work_dir}/{integrator}{''.join(options[1:2])}.h5"
    mt.run_msflex(args, source, output,
                  extra=["-analysis_integrator", integrator, "-analysis_end_time", str(end_time), "-output_every", "1000", "-quiet", *options])
    h = mt.history(output)
    free = h["time"] >= 5.0 - 1e-12
    print(f"{integrator}: {int(free.sum()) - 1} steps of free flight, Newton iterations per step {h['newton_iterations'][1:].mean():.2f}")
    return h, free


def momentum_drift(h, free, kind):
    p = np.stack([h[f"{kind}_momentum_{c}"][free] for c in "xyz"], axis=1)
    return np.abs(p - p[0]).max() / np.linalg.norm(p[0]), p[0]


h, free = free_flight("em", 15.0)
h_em = h
check.less("em: steps of free flight >= 1000 (1000 / steps)", 1000.0 / (free.sum() - 1), 1.0 + 1e-12)
energy = h["total_energy"][free]
check.less("em: total energy max deviation / energy", np.abs(energy - energy[0]).max() / energy[0], 1e-8)
drift, p = momentum_drift(h, free, "linear")
check.less("em: linear momentum max deviation / |p|", drift, 1e-10)
check.less("em: |p - (50, 0, 0)| / 50", np.linalg.norm(p - np.array([50.0, 0, 0])) / 50.0, 1e-10)
drift, J = momentum_drift(h, free, "angular")
check.less("em: angular momentum max deviation / |J|", drift, 1e-10)
check.less("em: |J_x| / |J|", abs(J[0]) / np.linalg.norm(J), 1e-10)
print(f"em: max |beta| = {np.abs(h['energy_correction']).max():.3e}")

h, free = free_flight("mc", 10.0)
for kind in ("linear", "angular"):
    drift, _ = momentum_drift(h, free, kind)
    check.less(f"mc: {kind} momentum max deviation / magnitude", drift, 1e-10)
energy = h["total_energy"][free]
print(f"mc: energy drift over free flight {(energy[-1] - energy[0]) / energy[0]:.3e} (not claimed)")

h, free = free_flight("newmark", 10.0)
energy = h["total_energy"][free]
print(f"newmark: energy drift over free flight {(energy[-1] - energy[0]) / energy[0]:.3e}, "
      f"angular momentum drift {momentum_drift(h, free, 'angular')[0]:.3e} (not claimed)")
check.true("newmark: completes with finite energy", bool(np.all(np.isfinite(energy))))
h_default = h_em
h, free = free_flight("em", 15.0, ["-analysis_em_correction", "forces"])
energy = h["total_energy"][free]
print(f"em correction (N_d, M_d): max |beta| {np.abs(h_default['energy_correction']).max():.3g}, steps {len(h_default['time']) - 1}; "
      f"(N_d, 0): max |beta| {np.abs(h['energy_correction']).max():.3g}, steps {len(h['time']) - 1}, "
      f"Newton iterations per step {h['newton_iterations'][1:].mean():.2f} (largest {int(h['newton_iterations'][1:].max())})")
check.less("em (N_d, 0): total energy max deviation / energy", np.abs(energy - energy[0]).max() / energy[0], 1e-8)
drift, _ = momentum_drift(h, free, "linear")
check.less("em (N_d, 0): linear momentum max deviation / |p|", drift, 1e-10)
drift, _ = momentum_drift(h, free, "angular")
check.less("em (N_d, 0): angular momentum max deviation / |J|", drift, 1e-10)
check.finish()
