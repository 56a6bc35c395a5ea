"""Torque-free symmetric top (input/torque_free_top.yaml): J = diag(1, 1, 0.5),
Omega(0) = (0.5, 0.5, 1). Closed form: R(t) = exp(t hat(pi)/A) exp(-lambda t hat(e3)),
pi = (0.5, 0.5, 0.5), A = 1, lambda = Omega_3 (C - A)/A = -0.5 (precession about pi at |pi|/A,
constant nutation angle).
For every integrator: the rotation at t = 5 matches the closed form to 1e-6 with dt = 1e-3, and
the error ratio when dt halves from 0.02 to 0.01 is that of a second-order scheme (3.5 to 4.5).
For mc and em: kinetic energy and angular momentum constant to 1e-12."""

import numpy as np

import msflex_testing as mt


def exact(t):
    return mt.expm(t * np.array([0.5, 0.5, 0.5])) @ mt.expm(0.5 * t * np.array([0.0, 0.0, 1.0]))


args = mt.parse_arguments(__doc__)
check = mt.Checker("torque-free top")
source = f"{args.source_dir}/input/torque_free_top.yaml"


def run(integrator, dt):
    output = f"{args.work_dir}/{integrator}_{dt}.h5"
    mt.run_msflex(args, source, output, extra=["-analysis_integrator", integrator, "-analysis_initial_step", str(dt), "-analysis_max_step", str(dt),
                                               "-analysis_end_time", "5", "-output_every", "100000", "-quiet"])
    probe, h = mt.probe_history(output, "top"), mt.history(output)
    row = mt.row_at_time(probe, 5.0)
    return np.abs(mt.quaternion_matrix(probe["rotation"][row]) - exact(5.0)).max(), h


for integrator in ("newmark", "genalpha", "mc", "em"):
    coarse, _ = run(integrator, 0.02)
    fine, h = run(integrator, 0.01)
    small, _ = run(integrator, 0.001)
    print(f"{integrator}: max |R - R_exact| at t = 5: dt 0.02 {coarse:.3e}, dt 0.01 {fine:.3e} (ratio {coarse / fine:.3f}), dt 0.001 {small:.3e}")
    check.less(f"{integrator}: error with dt = 1e-3", small, 1e-6)
    check.less(f"{integrator}: |error ratio - 4| (second order)", abs(coarse / fine - 4.0), 0.5)
    if integrator in ("mc", "em"):
        energy = h["kinetic_energy"]
        L = np.stack([h[f"angular_momentum_{c}"] for c in "xyz"], axis=1)
        check.less(f"{integrator}: kinetic energy max deviation / energy", np.abs(energy - energy[0]).max() / energy[0], 1e-12)
        check.less(f"{integrator}: angular momentum max deviation / |L|", np.abs(L - L[0]).max() / np.linalg.norm(L[0]), 1e-12)
check.finish()
