"""Critical points along static paths and linearised buckling, against closed forms:
 - deep von Mises truss (tests/regression/inputs/deep_truss.yaml): the sway bifurcation under load
   control, lambda = 1.306858511529148, named as a bifurcation point (negative pivots 0 -> 1 while
   lambda keeps rising), located to 1e-4;
 - Euler column (euler_column.yaml): bifurcation under load control where P (1 + P/GA - P/EA) =
   pi^2 EI/L^2 (the Reissner beam's exact critical load), within 5e-3 (the issue asks 0.5 %);
   linearised buckling (type buckling) where P (1 + P/GA) = pi^2 EI/L^2 and the next mode at the
   strong axis's load, to 1e-4;
 - lateral-torsional buckling of the fork-supported strip (lateral_torsional.yaml): bifurcation
   under load control and linearised buckling at M_cr = (pi/L) sqrt(EI_weak GJ), within 5e-3 and
   1e-4 (pre-buckling curvature effect: < 1e-4 with EI_strong = 1e4 EI_weak);
 - a column of two linear elements clamped at both ends (coarse_clamped_column.yaml), whose
   geometric stiffness is only semi-definite: no buckling load, and the run says so (eigenvalues
   nu = 1/mu at round-off were reported as load factors of 1.8e24);
 - an inverted pendulum of rigid parts (a body above a hinge with a torsion spring), whose weight
   deforms nothing before buckling: k / (m g d) to 1e-10; without loads one line.
Each on --np ranks."""

import math

import numpy as np

import msflex_testing as mt


def bisect(f, low, high):
    for _ in range(200):
        middle = 0.5 * (low + high)
        if f(low) * f(middle) > 0:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


def critical_points(path, kind):
    history = mt.history(path)
    rows = history["critical_point"] == kind
    return history["critical_load_factor"][rows], history["negative_pivots"], history["load_factor"]


args = mt.parse_arguments(__doc__)
check = mt.Checker("stability")
inputs = f"{args.source_dir}/tests/regression/inputs"

# Deep truss: the horizontal stiffness of the apex vanishes at L^3 = L0 (L^2 - a^2).
a, h, EA, P_ref = 1.0, 4.0, 1.0e6, 1.0e5
L0 = math.hypot(a, h)
# The first root below L0 as the apex goes down (the cubic is positive at L0).
sway = lambda L: L**3 - L0 * (L * L - a * a)  # noqa: E731
low = L0
while sway(low) > 0:
    low -= 1e-3
L_b = bisect(sway, low, low + 1e-3)
y_b = math.sqrt(L_b**2 - a * a)
expected = 2.0 * EA * y_b * (1.0 / L_b - 1.0 / L0) / P_ref
mt.run_msflex(args, f"{inputs}/deep_truss.yaml", f"{args.work_dir}/deep_truss.h5")
found, pivots, lam = critical_points(f"{args.work_dir}/deep_truss.h5", 2)
print(f"deep truss: bifurcation at {found}, closed form {expected:.12f}")
check.equal("deep truss: bifurcations found", len(found), 1)
if len(found):
    check.less("deep truss: bifurcation load relative error", abs(found[0] / expected - 1), 1e-4)
check.true("deep truss: the load factor rises monotonically", bool(np.all(np.diff(lam) > 0)))
check.equal("deep truss: final negative pivots", pivots[-1], 1)

# Euler column.
EI2, EI3, L, GA, EA, P_ref = 2.0e5, 4.0e5, 3.0, 1.0e8, 1.0e9, 2.5e5
euler = math.pi**2 * EI2 / L**2
nonlinear = bisect(lambda P: P * (1 + P / GA - P / EA) - euler, 0.5 * euler, euler) / P_ref
linear = [bisect(lambda P, E=E: P * (1 + P / GA) - E, 0.5 * E, E) / P_ref for E in (euler, math.pi**2 * EI3 / L**2)]
mt.run_msflex(args, f"{inputs}/euler_column.yaml", f"{args.work_dir}/column.h5")
found, pivots, lam = critical_points(f"{args.work_dir}/column.h5", 2)
print(f"column: bifurcation at {found}, closed form {nonlinear:.10f}")
check.equal("column: bifurcations found", len(found), 1)
if len(found):
    check.less("column: bifurcation load relative error", abs(found[0] / nonlinear - 1), 5e-3)
mt.run_msflex(args, f"{inputs}/euler_column.yaml", f"{args.work_dir}/column_buckling.h5", extra=["-analysis_type", "buckling", "-analysis_eigenvalues", "2"])
buckling = mt.history(f"{args.work_dir}/column_buckling.h5")["load_factor"]
print(f"column: buckling load factors {buckling}, closed form {linear}")
check.less("column: linearised buckling, first mode relative error", abs(buckling[0] / linear[0] - 1), 1e-4)
check.less("column: linearised buckling, strong-axis mode relative error", abs(buckling[1] / linear[1] - 1), 1e-4)

# Lateral-torsional buckling.
L, EI_weak, GJ, M_ref = 10.0, 1.0e3, 8.0e2, 300.0
expected = math.pi / L * math.sqrt(EI_weak * GJ) / M_ref
mt.run_msflex(args, f"{inputs}/lateral_torsional.yaml", f"{args.work_dir}/ltb.h5")
found, pivots, lam = critical_points(f"{args.work_dir}/ltb.h5", 2)
print(f"lateral-torsional: bifurcation at {found}, closed form {expected:.10f}")
check.equal("lateral-torsional: bifurcations found", len(found), 1)
if len(found):
    check.less("lateral-torsional: bifurcation load relative error", abs(found[0] / expected - 1), 5e-3)
mt.run_msflex(args, f"{inputs}/lateral_torsional.yaml", f"{args.work_dir}/ltb_buckling.h5", extra=["-analysis_type", "buckling", "-analysis_eigenvalues", "1"])
buckling = mt.history(f"{args.work_dir}/ltb_buckling.h5")["load_factor"]
print(f"lateral-torsional: buckling load factor {buckling}")
check.less("lateral-torsional: linearised buckling relative error", abs(buckling[0] / expected - 1), 1e-4)

_, stdout, _ = mt.run_msflex(args, f"{inputs}/coarse_clamped_column.yaml", f"{args.work_dir}/coarse_column.h5")
h = mt.history(f"{args.work_dir}/coarse_column.h5")
reported = h["load_factor"] if "load_factor" in h else []
check.equal("coarse clamped column: buckling loads reported", len(reported), 0)
check.true("coarse clamped column: the run says it found none", "0 buckling loads found" in stdout)

# A column on a hinge held by a torsion spring (k = 1; EI = 1, L = 1), pressed by a tip force with
# a lateral part of 0.3 %: a monotone path without critical point. Load steps of 0.2 step past the
# buckling load of the perfect column (0.7402) onto the unstable branch, bent against the lateral
# load: a jump, which the run called a limit point at 0.7405. Steps of 0.05 follow the path.
COLUMN = ("sections: [{{name: s, EA: 1.0e7, GA2: 1.0e7, GA3: 1.0e7, GJ: 1.0, EI2: 1.0, EI3: 1.0}}]\n"
          "nodes: {{root: [0, 0, 0], tip: [0, 1, 0]}}\nbeams: [{{name: col, section: s, from: root, to: tip, elements: 16, order: 2}}]\n"
          "joints: [{{name: hinge, type: revolute, master: ground, slave: root, axis: [0, 0, 1]}}]\n"
          "force_elements: [{{name: spring, type: coordinate, joint: hinge, coordinate: rotation, stiffness: {k}}}]\n"
          "loads: [{{nodes: tip, force: [{lateral}, -1.0, 0]}}]\nprobes: [{{name: tip, node: tip}}]\n"
          "analysis: {{type: static, initial_step: {step}, max_step: {step}, end_time: {end}}}\n")
for step, jumps in ((0.2, True), (0.05, False)):
    with open(f"{args.work_dir}/eccentric_column.yaml", "w") as f:
        f.write(COLUMN.format(k=1.0, lateral=0.003, step=step, end=1.2))
    _, stdout, _ = mt.run_msflex(args, f"{args.work_dir}/eccentric_column.yaml", f"{args.work_dir}/eccentric_column.h5")
    h = mt.history(f"{args.work_dir}/eccentric_column.h5")
    label = f"eccentric column, load steps of {step}"
    check.true(f"{label}: {'a jump onto an unstable equilibrium' if jumps else 'no critical point'} ({h['critical_point'].tolist()})",
               (3 in h["critical_point"].tolist() and "an unstable equilibrium" in stdout) if jumps else not np.any(h["critical_point"] > 0))
    check.true(f"{label}: no limit point reported", "limit point" not in stdout)
# The same column centred, k = 10: the in-plane bifurcation at alpha L tan(alpha L) = k L / EI
# (lambda = 2.0417) is located, the out-of-plane one (pi^2 EI / 4 L^2 = 2.4674, the lowest
# eigenvalue negative since the first) is said to lie in its step (it was reported at the step's
# middle, 2.45, as if located).
with open(f"{args.work_dir}/centred_column.yaml", "w") as f:
    f.write(COLUMN.format(k=10.0, lateral=0, step=0.1, end=2.6))
_, stdout, _ = mt.run_msflex(args, f"{args.work_dir}/centred_column.yaml", f"{args.work_dir}/centred_column.h5")
check.true("centred column: the in-plane bifurcation located at 2.0417", "bifurcation point at lambda = 2.0416" in stdout or "bifurcation point at lambda = 2.0417" in stdout)
check.true("centred column: the out-of-plane one placed in its step", "bifurcation point between lambda = 2.4 and 2.5 (negative pivots 1 -> 2)" in stdout)
# Both in one step of 0.65: one point named, and the line says the step holds two.
_, stdout, _ = mt.run_msflex(args, f"{args.work_dir}/centred_column.yaml", f"{args.work_dir}/centred_column.h5",
                             extra=["-analysis_initial_step", "0.65", "-analysis_max_step", "0.65"])
check.true("centred column in steps of 0.65: two critical points said to lie in the step", "(negative pivots 0 -> 2): 2 critical points in this step" in stdout)

# An inverted pendulum of rigid parts: a body 0.3 above a hinge held by a torsion spring k = 50
# under its weight m g = 2 x 9.81. The weight deforms nothing (u' = K^-1 q = 0: no moment about the
# upright hinge), but its moment grows as the offset turns (the load's stiffness -m g d): buckling
# at k / (m g d) = 8.4947 (refused before: "the loads do not deform the structure"). Without the
# weight: one line saying the loads change nothing.
pendulum = f"{args.work_dir}/inverted_pendulum.yaml"
for label, loads in (("inverted pendulum", "loads: [{gravity: [0, -9.81, 0]}]\n"), ("inverted pendulum without loads", "")):
    with open(pendulum, "w") as f:
        f.write("nodes: {s: [0, 0, 0]}\nrigid_bodies: [{node: s, mass: 2.0, inertia: [0.1, 0.1, 0.1], offset: [0, 0.3, 0]}]\n"
                "joints: [{name: h, type: revolute, master: ground, slave: s, axis: [0, 0, 1]}]\n"
                "force_elements: [{name: k, type: coordinate, joint: h, coordinate: rotation, stiffness: 50}]\n" + loads +
                "analysis: {type: buckling, eigenvalues: 1}\n")
    code, _, stderr = mt.run_msflex(args, pendulum, f"{args.work_dir}/inverted_pendulum.h5", expect_success=bool(loads))
    if loads:
        factor = mt.history(f"{args.work_dir}/inverted_pendulum.h5")["load_factor"][0]
        check.less(f"{label}: |load factor / (k / (m g d)) - 1|", abs(factor / (50.0 / (2.0 * 9.81 * 0.3)) - 1), 1e-10)
    else:
        # (on 2 ranks also the warning that one rank holds no node: the model has one)
        lines = [line for line in stderr.splitlines() if line.startswith("msflex:") and not line.startswith("msflex: warning: the partition leaves")]
        check.equal(f"{label}: exit status", code, 1)
        check.true(f"{label}: one line saying the loads change nothing", len(lines) == 1 and "neither deform the structure nor change its stiffness" in lines[0])
# Its modes preloaded to lambda: omega^2 = (k - m g d lambda) / (J + m d^2), negative beyond the
# buckling load; there the state is unstable, which the run says (the frequency 0 it writes read
# like a rigid mode's).
with open(pendulum, "w") as f:
    f.write("nodes: {s: [0, 0, 0]}\nrigid_bodies: [{node: s, mass: 2.0, inertia: [0.1, 0.1, 0.1], offset: [0, 0.3, 0]}]\n"
            "joints: [{name: h, type: revolute, master: ground, slave: s, axis: [0, 0, 1]}]\n"
            "force_elements: [{name: k, type: coordinate, joint: h, coordinate: rotation, stiffness: 50}]\n"
            "loads: [{gravity: [0, -9.81, 0]}]\nanalysis: {type: modes, eigenvalues: 1, preload: true}\n")
for load in (8.0, 9.0):
    _, stdout, _ = mt.run_msflex(args, pendulum, f"{args.work_dir}/inverted_pendulum_modes.h5", extra=["-analysis_end_time", str(load)])
    h = mt.history(f"{args.work_dir}/inverted_pendulum_modes.h5")
    exact = (50.0 - 2.0 * 9.81 * 0.3 * load) / (0.1 + 2.0 * 0.3**2)
    label = f"inverted pendulum's mode at lambda = {load}"
    check.less(f"{label}: |omega^2 / ((k - m g d lambda) / (J + m d^2)) - 1|", abs(h["eigenvalue"][0] / exact - 1), 1e-8)
    check.true(f"{label}: the run says {'un' if exact < 0 else ''}stable", ("is unstable" in stdout) == (exact < 0) and ("(unstable: no frequency)" in stdout) == (exact < 0))

# Lee's frame under displacement control of the loaded point's vertical displacement: the path
# turns back in that displacement (a snap-back) at v = -61.015, which displacement control cannot
# pass. The stop now says so and points to arc length (it said only that the corrector did not
# converge).
with open(f"{args.work_dir}/lee_frame.yaml", "w") as f:
    f.write("""sections: [{name: s, EA: 4320, GA2: 1384.6, GA3: 1.0e8, GJ: 1.0e8, EI2: 1.0e8, EI3: 1440}]
nodes: {A: [0, 0, 0], B: [0, 120, 0], C: [24, 120, 0], D: [120, 120, 0]}
beams:
  - {name: col, section: s, from: A, to: B, elements: 10, order: 2}
  - {name: b1, section: s, from: B, to: C, elements: 2, order: 2}
  - {name: b2, section: s, from: C, to: D, elements: 8, order: 2}
supports: [{nodes: A, fix: [ux, uy, uz, rx, ry]}, {nodes: D, fix: [ux, uy, uz, rx, ry]}]
loads: [{nodes: C, force: [0, -1, 0]}]
analysis: {type: static, control: displacement, control_node: C, control_dof: uy, control_value: -1, end_time: 90, initial_step: 1, max_step: 1}
""")
# (With min_step 1e-4 the corrector stops before the turning point, its rates growing with one
# sign; with the default 1e-6 it jumps around it and they change sign.)
for min_step in ("1e-6", "1e-4"):
    label = f"Lee frame under displacement control, min_step {min_step}"
    code, _, stderr = mt.run_msflex(args, f"{args.work_dir}/lee_frame.yaml", f"{args.work_dir}/lee_frame.h5", expect_success=False,
                                    extra=["-quiet", "-analysis_min_step", min_step])
    stop = [line for line in stderr.splitlines() if "stopped at" in line]
    print(f"{label}: exit {code}: {stop[:1]}")
    check.equal(f"{label}: exit status", code, 1)
    check.true(f"{label}: the stop names the turning point of the displacement and arc length",
               len(stop) == 1 and "stopped at t = 61.0" in stop[0] and "reaches a turning point of the path (a snap-back)" in stop[0]
               and "control: arc_length" in stop[0])
check.finish()
