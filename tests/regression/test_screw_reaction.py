"""The reaction of a free screw joint (tests/regression/inputs/free_screw.yaml: a body spinning and
advancing along the axis, nothing loads it; the exact reaction is zero).

By default (analysis.reactions: consistent) the reported reaction comes from the accelerations
that satisfy the equations of motion in each converged state: zero to round-off with newmark and
genalpha (1e-10 of m v / h), and with mc and em to the O(h^2) by which their end-of-step velocities
miss the joint (1e-7 of m v / h).

With analysis.reactions: scheme the reported reaction is the force that acts in the scheme. With
newmark it is zero to round-off. With mc and em the slave's translation advances by pitch * dphi while the conserving map weighs the
dependent translation by the secant (dphi/2) cot(dphi/2) ~ 1 - dphi^2/12: a velocity mismatch
v (W h)^2 / 12 that the joint removes in every step with the share I / (I + m pitch^2) of the momentum.
So the joint pushes the body along the axis by a force that alternates in sign from step to step:
its impulse over two consecutive steps is zero (to the Newton tolerance), its amplitude is
(m v W^2 h / 6) I / (I + m pitch^2) to leading order (first order in h), it does no work along the
scheme's released direction (pitch, 1) tilted by (W h)^2 / 12, and energy is conserved to the Newton
tolerance at every step size."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("free screw reaction")
source = f"{args.source_dir}/tests/regression/inputs/free_screw.yaml"
pitch, mass, inertia, speed, spin = 0.1, 1.0, 0.1, 0.5, 5.0
momentum_rate = mass * speed / 0.01  # m v / h: the scale of the forces in one step


def history(integrator, step, reactions="scheme"):
    output = f"{args.work_dir}/free_screw_{integrator}_{step}_{reactions}.h5"
    mt.run_msflex(args, source, output, extra=["-quiet", "-analysis_integrator", integrator, "-analysis_initial_step", str(step), "-analysis_max_step", str(step),
                                               "-analysis_reactions", reactions])
    h = mt.history(output)
    return {name: h[name][1:] for name in ("lead.force_z", "lead.moment_z", "lead.force_x", "lead.force_y", "total_energy")}


# mc and em: their end-of-step velocities follow the joint only to O(h^2) (the slave advances by
# pitch dphi, turns by 2 atan(W h / 2)), and the acceleration problem's velocity products see that:
# measured 1.4e-8 of m v / h (7e-7 N against the scheme's 0.019 N alternation).
for integrator, limit in (("newmark", 1e-10), ("genalpha", 1e-10), ("mc", 1e-7), ("em", 1e-7)):
    h = history(integrator, 0.01, "consistent")
    check.less(f"{integrator}, consistent reactions: largest |reaction| / (m v / h)",
               np.abs(np.concatenate([h["lead.force_z"], h["lead.force_x"], h["lead.force_y"]])).max() / momentum_rate, limit)
h = history("newmark", 0.01)
check.less("newmark, the scheme's reactions: largest |reaction| / (m v / h)", np.abs(np.concatenate([h["lead.force_z"], h["lead.force_x"], h["lead.force_y"]])).max() / momentum_rate, 1e-10)
for integrator in ("mc", "em"):
    amplitudes = []
    for step in (0.01, 0.005, 0.0025):
        h = history(integrator, step)
        force, moment = h["lead.force_z"], h["lead.moment_z"]
        amplitude = np.abs(force).max()
        amplitudes.append(amplitude)
        closed_form = mass * speed * spin**2 * step / 6 * inertia / (inertia + mass * pitch**2)
        check.less(f"{integrator}, h = {step}: |amplitude / closed form - 1|", abs(amplitude / closed_form - 1), 1e-3)
        print(f"{integrator}, h = {step}: |F_z| = {amplitude:.6e} N, two-step sums up to {np.abs(force[1:] + force[:-1]).max():.3e} N")
        check.less(f"{integrator}, h = {step}: two-step impulse / (amplitude h)", np.abs(force[1:] + force[:-1]).max() / amplitude, 1e-6)
        # Work-free along the released motion of the scheme: the conserving map of mc and em tilts the released
        # direction (pitch, 1) by the secant of the rotation, (W h)^2 / 12 to leading order.
        secant_tilt = (spin * step) ** 2 / 12
        check.less(f"{integrator}, h = {step}: |pitch F_z + M_z| / (pitch amplitude)", np.abs(pitch * force + moment).max() / (pitch * amplitude), 1.02 * secant_tilt + 1e-6)
        check.less(f"{integrator}, h = {step}: energy drift / energy", np.abs(h["total_energy"] - h["total_energy"][0]).max() / h["total_energy"][0], 1e-9)
        # Zero to the Newton tolerance: Newton stops at |R| <= 1e-10 of its first residual, which
        # is about 12 m v / h here (the predictor leaves the step's momentum change to the first
        # iteration), so 1e-8 m v / h leaves a margin of 8.
        check.less(f"{integrator}, h = {step}: transverse reaction / (m v / h)",
                   np.abs(np.concatenate([h["lead.force_x"], h["lead.force_y"]])).max() / (mass * speed / step), 1e-8)
    for coarse, fine in zip(amplitudes, amplitudes[1:]):
        check.less(f"{integrator}: |amplitude ratio on halving the step - 2| (first order)", abs(coarse / fine - 2.0), 0.02)
check.finish()
