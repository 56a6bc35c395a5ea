"""The work of actuators and the dissipation of dampers with the quadrature of each scheme's energy
balance (tests/regression/inputs/actuator_work.yaml: three linear mechanisms, a slider on a
prismatic joint with a spring, a damper and a harmonic actuator on its coordinate (the user's
report), a rotor on a revolute joint with a torsion spring, damper and actuator, and a slider held
by an axial spring-damper to the ground and pushed by an actuator; actuator_work_loads.yaml: the
same with the actuators as nodal loads).

Why trapezoidal Newmark conserves the energy of a linear system. Take M qdd + C qd + K q = F(t)
(M, K symmetric, C symmetric positive semi-definite) and the scheme's updates with beta = 1/4,
gamma = 1/2,
    q_{n+1} - q_n = dt (v_n + v_{n+1}) / 2,        v_{n+1} - v_n = dt (a_n + a_{n+1}) / 2,
with the equations of motion holding at every t_n: at t_{n+1} in every step, and at t_0 through the
initial-acceleration problem. Half the sum of the equations at t_n and t_{n+1}, dotted with the
increment dq = q_{n+1} - q_n, term by term:
    M (a_n + a_{n+1})/2 . dq = M (v_{n+1} - v_n)/dt . dt (v_n + v_{n+1})/2 = T_{n+1} - T_n
    K (q_n + q_{n+1})/2 . dq                                                 = V_{n+1} - V_n
    C (v_n + v_{n+1})/2 . dq = dt/4 (v_n + v_{n+1})^T C (v_n + v_{n+1})     = D_n >= 0
    (F_n + F_{n+1})/2 . dq                                                   = W_n
(T = v^T M v / 2, V = q^T K q / 2; M and K symmetric). Hence T + V - sum W_n + sum D_n is constant
exactly (to round-off and the Newton tolerance), with the work W_n and the dissipation D_n the
trapezoidal rule over the step of the applied and the damper forces. The end-point sums
F_{n+1} . dq and C v_{n+1} . dq that msflex took for actuators and dampers differ from them by
(F_{n+1} - F_n)/2 . dq = O(dt^2) per step, O(dt) over a given time: 3.3 % of the work in the
user's report (the slider `s` alone, from rest, over 30 s: a spurious algorithmic_dissipation of
1.263 J) and, from the dampers, a swing of energy_balance by 4.3e-4 J of 1 J in a free
spring-damper slider. The loads' work was already the trapezoidal rule
(Assembler::StepExternalWork, LoadContributor::AddStepWork). genalpha holds the
equations at t_{n+1} with the true accelerations vdot != a, so the same sum leaves a remainder,
the scheme's algorithmic dissipation; its loads' work is the same trapezoidal rule, so its
actuators' must be too. The mid-point schemes (mc, em) hold the mid-point equations, whose forces
times dq are exact (em's energy balance); their quadrature is unchanged.

Checks, from the history written every step (series of each actuator's force and its joint's
coordinate, the spring-dampers' forces):
(a) newmark: external_work equals the trapezoidal sum of F dq of the three actuators, at every
    step, to 1e-10 relative; each actuator's power times dt sums to its trapezoidal work;
    dissipated_energy equals the trapezoidal sum of the dampers' forces (c qdot = -force - k q on a
    coordinate, c ldot = tension - k (l - l_0) on the spring-damper) times the increments;
    energy_balance constant to 1e-9 of the energy; the same external work, dissipation and balance
    as with nodal loads;
(b) em: unchanged exactness: external_work equals the sum of the recorded (mid-point) actuator
    forces times dq, energy_balance constant to 1e-9 of the energy;
(c) genalpha (rho_infinity = 0.9): external_work equals the trapezoidal sum of F dq (the rule of
    its nodal loads); external work, dissipation and algorithmic dissipation the same as with the
    actuators as nodal loads, so energy_balance = E_0 - algorithmic dissipation is that of the
    scheme (O(dt^2): below 1e-5 of the energy at omega dt = 0.02);
(d) the beams' structural damping (damped_cantilever_energy.yaml: a clamped beam with damping_time
    in free vibration from a tip velocity, 92 % of its energy dissipated over the run): its
    dissipation in the Newmark family is the same trapezoidal rule, the mean of the start state's
    damping force C_d edot_n and the end's times the increments, so newmark's energy_balance is
    constant as above, to the Newton tolerance and round-off on a linear system. The beam is
    geometrically nonlinear: its share of the balance shrinks with the amplitude (measured drift /
    energy: 2.8e-8 at a tip velocity of 0.1 m/s, 5e-10 at 1e-2, 5e-11 at the input's 1e-3; the
    undamped beam's 1e-7 and 1e-9 at 0.1 and 1e-2), so at 1e-3 the bound 1e-9 of the energy holds
    it with a margin of 20, while the end-point count of the damping's work (msflex before) drifts
    by 7e-3 of the energy at any amplitude (an O(dt) error: (f_{n+1} - f_n)/2 . dq per step). em,
    exact, holds its balance to the same bound."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("actuator work")

# The input's actuators and the series of the coordinates they act on.
ACTUATORS = [("act", "rail.tx"), ("motor", "hinge.rx"), ("push", "track.tx")]
STEPS = 2000


def run(name, integrator):
    output = f"{args.work_dir}/{name}_{integrator}.h5"
    mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/{name}.yaml", output, extra=["-quiet", "-analysis_integrator", integrator])
    h = mt.history(output)
    check.equal(f"{name}, {integrator}: history rows (every step)", len(h["time"]), STEPS + 1)
    return h


def trapezoid_work(h):
    """The work of the actuators step by step, (F_n + F_{n+1})/2 dq, and the end-point sum F_{n+1} dq."""
    trapezoid = end_point = 0.0
    for actuator, coordinate in ACTUATORS:
        F, dq = h[f"{actuator}.force"], np.diff(h[coordinate])
        trapezoid = trapezoid + 0.5 * (F[:-1] + F[1:]) * dq
        end_point = end_point + F[1:] * dq
    return trapezoid, end_point


def cumulative(steps):
    return np.concatenate([[0.0], np.cumsum(steps)])


def energy_scale(h):
    return max(np.abs(h["total_energy"]).max(), np.abs(h["external_work"]).max(), np.abs(h["dissipated_energy"]).max())


def balance_drift(h):
    b = h["energy_balance"]
    return np.abs(b - b[0]).max() / np.abs(h["total_energy"]).max()


def same_as_loads(label, h, loads):
    scale = energy_scale(h)
    for name in ("external_work", "dissipated_energy", "algorithmic_dissipation", "energy_balance"):
        check.less(f"{label}: |{name} - with nodal loads| / energy (every step)", np.abs(h[name] - loads[name]).max() / scale, 1e-10)


# (a) newmark
h = run("actuator_work", "newmark")
loads = run("actuator_work_loads", "newmark")
trapezoid, end_point = trapezoid_work(h)
W = cumulative(trapezoid)
print(f"newmark: external work {h['external_work'][-1]:.12g} J, trapezoidal sum {W[-1]:.12g} J, end-point sum {end_point.sum():.12g} J "
      f"({end_point.sum() / W[-1] - 1:+.2e}); dissipated {h['dissipated_energy'][-1]:.12g} J; largest energy {h['total_energy'].max():.6g} J; "
      f"energy_balance range {np.ptp(h['energy_balance']):.3e} J; algorithmic dissipation {h['algorithmic_dissipation'][-1]:.3e} J")
check.less("newmark: |external_work - trapezoidal sum of F dq| / |work| (every step)", np.abs(h["external_work"] - W).max() / np.abs(W).max(), 1e-10)
dt = np.diff(h["time"])
for actuator, coordinate in ACTUATORS:
    F, dq = h[f"{actuator}.force"], np.diff(h[coordinate])
    own = cumulative(0.5 * (F[:-1] + F[1:]) * dq)
    check.less(f"newmark: |sum of {actuator}.power dt - its trapezoidal work| / |work|", np.abs(cumulative(h[f"{actuator}.power"][1:] * dt) - own).max() / np.abs(W).max(),
               1e-10)
# The dampers' forces from the recorded forces less the springs' (linear: k q, k (l - l_0)).
damper = [(-h["spr.force"] - 200.0 * h["rail.tx"], h["rail.tx"]), (-h["tor.force"] - 20.0 * h["hinge.rx"], h["hinge.rx"]),
          (h["strut.tension"] - 50.0 * (h["strut.length"] - 0.5), h["strut.length"])]
D = cumulative(sum(0.5 * (f[:-1] + f[1:]) * np.diff(x) for f, x in damper))
check.less("newmark: |dissipated_energy - trapezoidal sum of the dampers' forces times the increments| / dissipated (every step)",
           np.abs(h["dissipated_energy"] - D).max() / D[-1], 1e-10)
check.less("newmark: drift of energy_balance / energy (trapezoidal Newmark conserves a linear system's energy)", balance_drift(h), 1e-9)
same_as_loads("newmark, actuators vs loads", h, loads)

# (b) em: unchanged
h = run("actuator_work", "em")
mid = cumulative(sum(h[f"{actuator}.force"][1:] * np.diff(h[coordinate]) for actuator, coordinate in ACTUATORS))
print(f"em: external work {h['external_work'][-1]:.12g} J, sum of the mid-point forces times dq {mid[-1]:.12g} J, "
      f"energy_balance range {np.ptp(h['energy_balance']):.3e} J")
check.less("em: |external_work - sum of the mid-point actuator forces times dq| / |work| (every step)", np.abs(h["external_work"] - mid).max() / np.abs(mid).max(),
           1e-10)
check.less("em: drift of energy_balance / energy", balance_drift(h), 1e-9)

# (c) genalpha
h = run("actuator_work", "genalpha")
loads = run("actuator_work_loads", "genalpha")
trapezoid, end_point = trapezoid_work(h)
W = cumulative(trapezoid)
D = h["algorithmic_dissipation"]
print(f"genalpha: external work {h['external_work'][-1]:.12g} J, trapezoidal sum {W[-1]:.12g} J, end-point sum {end_point.sum():.12g} J; "
      f"algorithmic dissipation at the end {D[-1]:.3e} J (with nodal loads {loads['algorithmic_dissipation'][-1]:.3e} J), largest |D| {np.abs(D).max():.3e} J")
check.less("genalpha: |external_work - trapezoidal sum of F dq| / |work| (every step)", np.abs(h["external_work"] - W).max() / np.abs(W).max(), 1e-10)
same_as_loads("genalpha, actuators vs loads", h, loads)
check.less("genalpha: |D + energy_balance - total_0| / energy (identity)", np.abs(D + h["energy_balance"] - h["total_energy"][0]).max() / h["total_energy"].max(),
           1e-12)
check.less("genalpha: largest |algorithmic dissipation| / energy (O(dt^2))", np.abs(D).max() / h["total_energy"].max(), 1e-5)

# (d) the beams' structural damping: a damped cantilever in free vibration, newmark and em
for integrator in ("newmark", "em"):
    output = f"{args.work_dir}/damped_cantilever_energy_{integrator}.h5"
    mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/damped_cantilever_energy.yaml", output,
                  extra=["-quiet", "-analysis_integrator", integrator])
    h = mt.history(output)
    dissipated = h["dissipated_energy"][-1] / h["total_energy"][0]
    print(f"damped cantilever, {integrator}: initial energy {h['total_energy'][0]:.6e} J, dissipated {h['dissipated_energy'][-1]:.6e} J "
          f"({dissipated:.3f} of it), drift of energy_balance / energy {balance_drift(h):.3e}")
    check.less(f"damped cantilever, {integrator}: 1 - dissipated / initial energy (the damping is at work)", 1.0 - dissipated, 0.1)
    check.less(f"damped cantilever, {integrator}: drift of energy_balance / energy (the damping's work by the scheme's own rule)", balance_drift(h), 1e-9)
check.finish()
