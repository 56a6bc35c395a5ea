"""Structural damping on a spinning beam (tests/regression/inputs/spinning_damped_beam.yaml).

A beam spinning freely about a hinge at one end, with stiffness-proportional damping: with every
integrator the run completes 4 s at dt = 1 ms and, once the damping has taken out the axial
vibration, the beam spins steadily. Closed forms (small strain): the centrifugal tension
N(x) = rhoA W^2 (L^2 - x^2)/2 stretches it by u(x) = rhoA W^2 (L^2 x - x^3/3)/(2 EA), which raises
the moment of inertia about the hinge by dJ = 4 (rhoA)^2 W^2 L^5/(15 EA); the angular momentum
H = J_0 W_0 stays, so the kinetic energy falls to KE_0 J_0/(J_0 + dJ); the stretch stores
Pi = (rhoA W^2)^2 L^5/(15 EA) and the damping dissipates the rest, KE_0 - KE - Pi (= Pi to
leading order, as for a load applied suddenly to a damped spring).
- Before: newmark's strain rates, carried by their own trapezoidal recursion, had an undamped
  alternating mode that fed energy in once the beam turned (kinetic energy 16.7 -> 2.5e5 J and a
  stop at t = 3.75 s); em's beta, a ratio of work sums whose round-off level was measured by
  sum |u.f| (~0 here: the increments run across the tension) instead of sum |u| |f|, swung to 10^3
  as the vibration died out and Newton stopped at t = 0.11 s.
- Checked: every integrator completes; the kinetic energy does not grow after the transient
  (t = 2 s -> 4 s: mc, em 1e-11 relative, measured 2e-13; newmark and genalpha with rho_inf = 1
  and 0.9: 1e-8, measured 1.4e-9 and 5.8e-9, the noise of a residual vibration that the Newmark
  family's quadrature does not damp); it and H against the closed forms (mc, em: 2e-6 and 1e-9,
  measured 2.7e-7 and 1.3e-12; the Newmark family: 2e-4 and 1e-4, measured 5e-5 and 2.5e-5, their
  own error in a transient of six steps per axial period); mc's and em's dissipated energy within
  2 % of the closed form (measured 0.3 %), and em's energy balance constant to 1e-10 J.
The consistent reactions of a damped beam under mc and em: the root reaction of a clamped rod kicked
at its tip (tests/regression/inputs/damped_tip_kick.yaml) against genalpha at a fine step,
within 0.01 N of its 16 N peak at dt = 0.5 ms and converging (before: 3.6 N at every step size).
"""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("damped spin")

rhoA, EA, L, W0, rhoJ_z = 1.0, 1.0e6, 1.0, 10.0, 5.0e-4
J0 = rhoA * L**3 / 3.0 + rhoJ_z * L
dJ = 4.0 * rhoA**2 * W0**2 * L**5 / (15.0 * EA)
KE0 = 0.5 * J0 * W0**2
KE_end = KE0 * J0 / (J0 + dJ)
Pi = (rhoA * W0**2) ** 2 * L**5 / (15.0 * EA)
H0 = J0 * W0

# integrator, options, tolerances: KE steady, KE and H against the closed forms
cases = [("newmark", [], 1e-8, 2e-4, 1e-4), ("genalpha", ["-analysis_spectral_radius", "1"], 1e-8, 2e-4, 1e-4), ("genalpha", [], 1e-8, 2e-4, 1e-4),
         ("mc", [], 1e-11, 2e-6, 1e-9), ("em", [], 1e-11, 2e-6, 1e-9)]
for integrator, extra, steady_tolerance, ke_tolerance, h_tolerance in cases:
    label = integrator + (" rho_inf 1" if extra else "")
    path = f"{args.work_dir}/spin_{label.replace(' ', '_')}.h5"
    mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/spinning_damped_beam.yaml", path,
                  extra=["-quiet", "-analysis_integrator", integrator] + extra)
    h = mt.history(path)
    check.true(f"{label}: completed 4 s", bool(abs(h["time"][-1] - 4.0) < 1e-9))
    ke = h["kinetic_energy"]
    settled = abs(ke[-1] - ke[mt.row_at_time(h, 2.0)]) / KE0
    check.less(f"{label}: |KE(4 s) - KE(2 s)| / KE_0 (steady spin)", settled, steady_tolerance)
    check.less(f"{label}: |KE(4 s) - KE_0 J_0/(J_0 + dJ)| / KE_0", abs(ke[-1] - KE_end) / KE0, ke_tolerance)
    check.less(f"{label}: |H_z(4 s) - J_0 W_0| / H_0", abs(h["angular_momentum_z"][-1] - H0) / H0, h_tolerance)
    if integrator in ("mc", "em"):
        dissipated = h["dissipated_energy"][-1]
        check.less(f"{label}: |dissipated - (KE_0 - KE - Pi)| / Pi", abs(dissipated - (KE0 - KE_end - Pi)) / Pi, 0.02)
    if integrator == "em":
        check.less(f"{label}: energy_balance range (J)", np.ptp(h["energy_balance"]), 1e-10)

# The consistent reactions of a damped beam under mc and em (docs/joints.md): the root reaction of
# a damped cantilever started by a tip velocity converges to genalpha's at a fine step (the
# strain rates of the acceleration problem are the BDF2 derivative of the strains; the initial
# rates, left in use, made it 3.6 N off at every step size).
source = f"{args.source_dir}/tests/regression/inputs/damped_tip_kick.yaml"
reference = f"{args.work_dir}/damped_tip_kick_genalpha.h5"
mt.run_msflex(args, source, reference, extra=["-quiet", "-analysis_integrator", "genalpha", "-analysis_initial_step", "0.00025", "-analysis_max_step", "0.00025"])
fine = mt.history(reference)
for integrator in ("em", "mc"):
    errors = []
    for step in (0.001, 0.0005):
        path = f"{args.work_dir}/damped_tip_kick_{integrator}_{step}.h5"
        mt.run_msflex(args, source, path, extra=["-quiet", "-analysis_integrator", integrator, "-analysis_initial_step", str(step), "-analysis_max_step", str(step)])
        h = mt.history(path)
        late = h["time"] > 0.05
        errors.append(np.abs(h["rr.force_y"][late] - np.interp(h["time"][late], fine["time"], fine["rr.force_y"])).max())
    print(f"damped tip kick, {integrator}: root reaction against genalpha at 0.25 ms, dt = 1, 0.5 ms: {errors[0]:.3e}, {errors[1]:.3e} N")
    check.less(f"damped tip kick, {integrator}: max |root reaction - fine genalpha| at dt = 0.5 ms (N, of a 16 N peak)", errors[1], 0.01)
    check.less(f"damped tip kick, {integrator}: error ratio on halving dt", errors[1] / errors[0], 0.5)

# The first row after the start (damped_swung_beam.yaml, a soft beam whose modes the steps resolve):
# the strain rate there is the trapezoidal one from the initial rate; a one-sided difference lagged
# by half a step (first order: 1.03, 0.62, 0.35 N at dt = 1, 0.5, 0.25 ms against 0.2-1.3 N).
source = f"{args.source_dir}/tests/regression/inputs/damped_swung_beam.yaml"
reference = f"{args.work_dir}/damped_swung_beam_fine.h5"
mt.run_msflex(args, source, reference, extra=["-quiet", "-analysis_end_time", "0.002", "-analysis_initial_step", "6.25e-5", "-analysis_max_step", "6.25e-5",
                                              "-analysis_min_step", "6.25e-5"])
fine = mt.history(reference)
for integrator in ("em", "mc"):
    first = []
    for step in (0.001, 0.0005):
        path = f"{args.work_dir}/damped_swung_beam_{integrator}_{step}.h5"
        mt.run_msflex(args, source, path, extra=["-quiet", "-analysis_integrator", integrator, "-analysis_end_time", "0.002", "-analysis_initial_step", str(step),
                                                 "-analysis_max_step", str(step), "-analysis_min_step", str(step)])
        h = mt.history(path)
        first.append(abs(h["R.force_y"][1] - np.interp(h["time"][1], fine["time"], fine["R.force_y"])))
    print(f"damped swung beam, {integrator}: first row's base reaction error at dt = 1, 0.5 ms: {first[0]:.3e}, {first[1]:.3e} N")
    check.less(f"damped swung beam, {integrator}: first-row error ratio on halving dt (second order: 0.25)", first[1] / first[0], 0.35)
check.finish()
