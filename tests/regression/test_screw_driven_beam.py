"""A flexible beam driven along its axis by a screw at a constant angular acceleration, with
structural damping (tests/regression/inputs/screw_driven_beam.yaml; an exact check of the
dependent-DOF joint with a flexible body):
 - every step converges (3000 steps at 1 ms; with structural damping the residual's round-off floor
   is raised by the viscous forces on the strain rates, which the convergence test now counts:
   before, Newton stalled in the first step);
 - after the damped start, the section forces are the quasi-static closed forms N(x) = -rhoA a (L - x)
   and M1(x) = -rhoJ1 alpha (L - x), a = k alpha, at the element midpoints (to 1e-6 of their
   largest value), and the shear forces and bending moments vanish (below 1e-9 of it);
 - the screw's translation is pitch x angle, and the angle is alpha t^2 / 2 (to 1e-12)."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("screw-driven beam")
output, h = mt.run_input(args, "screw_driven_beam")
t = h["time"]
check.true(f"the run reaches t = 3 in 3000 steps ({t[-1]:.6g}, {len(t) - 1})", abs(t[-1] - 3.0) < 1e-9 and len(t) - 1 == 3000)
L, rhoA, rhoJ1, pitch, alpha = 2.0, 1.0, 0.02, 0.1, 4.0
check.less("screw angle - alpha t^2 / 2, largest", float(np.abs(h["screw.rx"] - 0.5 * alpha * t * t).max()), 1e-12 * 0.5 * alpha * 9)
check.less("screw translation - pitch x angle, largest", float(np.abs(h["screw.tx"] - pitch * h["screw.rx"]).max()), 1e-12)
frame = mt.final_frame(output)
resultants = frame["element_resultants"]
n = resultants.shape[0]
x = (np.arange(n) + 0.5) * L / n
N_exact = -rhoA * pitch * alpha * (L - x)
M_exact = -rhoJ1 * alpha * (L - x)
check.less("axial force N1 against -rhoA a (L - x), largest relative difference", float(np.abs(resultants[:, 0] - N_exact).max() / np.abs(N_exact).max()), 1e-6)
check.less("torque M1 against -rhoJ1 alpha (L - x), largest relative difference", float(np.abs(resultants[:, 3] - M_exact).max() / np.abs(M_exact).max()), 1e-6)
check.less("shear forces and bending moments, largest relative to N", float(np.abs(resultants[:, [1, 2, 4, 5]]).max() / np.abs(N_exact).max()), 1e-9)
check.finish()
