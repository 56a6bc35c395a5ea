"""The generalised force of a drive, `<joint>.drive_force` (docs/joints.md), against the closed
form of tests/regression/inputs/driven_disc.yaml: a disc of J_z = 0.5 driven through
theta = 0.5 sin(2 pi t) on a revolute joint needs the torque J_z theta''.

- genalpha (rho_inf 0.8 by default), dt = 2.5 ms: at the ends of the steps, once the start's
  transient has decayed (t > 0.5 s), within 1e-3 of the amplitude (measured 4e-5).
- em and mc report their equations' mid-point torque: J_z theta'' at t - dt/2 within 1e-2 of the
  amplitude (measured 3.3e-3, O(dt)), with energy_balance constant to 1e-10 J.
- the reaction moment about the axis carries the same torque (the drive acts through the
  joint): moment_z = drive_force."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("drive force")
source = f"{args.source_dir}/tests/regression/inputs/driven_disc.yaml"
J, A, w, dt = 0.5, 0.5, 2.0 * np.pi, 0.0025
amplitude = J * A * w * w
for integrator in ("genalpha", "em", "mc"):
    path = f"{args.work_dir}/driven_disc_{integrator}.h5"
    mt.run_msflex(args, source, path, extra=["-quiet", "-analysis_integrator", integrator, "-analysis_initial_step", str(dt), "-analysis_max_step", str(dt)])
    h = mt.history(path)
    t, force = h["time"][1:], h["hinge.drive_force"][1:]
    check.less(f"{integrator}: max |drive_force - moment_z| / amplitude", np.abs(force - h["hinge.moment_z"][1:]).max() / amplitude, 1e-9)
    if integrator == "genalpha":
        late = t > 0.5
        exact = -J * A * w * w * np.sin(w * t[late])
        check.less("genalpha: max |drive_force - J theta''(t)| / amplitude, t > 0.5", np.abs(force[late] - exact).max() / amplitude, 1e-3)
    else:
        exact = -J * A * w * w * np.sin(w * (t - dt / 2))
        check.less(f"{integrator}: max |drive_force - J theta''(t - dt/2)| / amplitude", np.abs(force - exact).max() / amplitude, 1e-2)
        check.less(f"{integrator}: range of energy_balance (J)", float(np.ptp(h["energy_balance"])), 1e-10)
check.finish()
