"""Force elements, massless nodes and the pinned offset rigid body in dynamics (issue 12):
- a linear spring-mass-damper on a prismatic joint (inputs/spring_mass_damper.yaml), em at
  omega_0 dt = 0.031: damped frequency and decay rate against the closed form to 1e-4, and
  energy - work + dissipated energy constant to 1e-8 of the energy over 1000 steps;
- every kind of force element at once on a flexible arm (inputs/force_element_energy.yaml: tabulated
  torsional spring, damper and actuator on a revolute, spring-damper, bushing, structural damping),
  em over 1000 steps: energy - work + dissipated energy constant to 1e-8 of the largest of them;
- a pendulum with a massless rod on a revolute joint (input/massless_pendulum.yaml) and a massless cantilever carrying a point
  mass (no rotary inertia at the joint's node nor at the tips) run with newmark, genalpha, mc and
  em: quarter period of the pendulum and the cantilever's period against their closed forms;
- a rigid body spinning about a fixed point away from its centre of mass, no load: newmark and
  genalpha with rho = 1 keep its energy bounded (no growth), em keeps it to the Newton tolerance;
  spinning steadily about a principal axis through that point (inputs/steady_offset_spin.yaml), the
  exact motion, every integrator keeps its energy (61.2 J) to the Newton tolerance (1e-10) — the
  former centre-of-mass Newmark point lost 1.5e-3 of it in 0.7 s there;
- a drive at constant speed without initial conditions (inputs/drive_start.yaml): the projected
  initial velocities start the arm rotating rigidly with it (kinetic energy at t = 0 against the
  closed form, on 1 and 2 ranks), so it stays nearly unstrained, unlike with the given velocities;
- a node without mass between two prismatic joints (a singular mass matrix without an empty row)
  with every integrator: it runs, its joint force is the spring's, a start out of equilibrium is
  said in a warning and newmark and genalpha bring the node to equilibrium in their first step; the
  same warning for a node without mass between Cartesian springs."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("force elements in dynamics")
inputs = f"{args.source_dir}/tests/regression/inputs"


def run(name, label, options=()):
    output = f"{args.work_dir}/{name}_{label}.h5"
    folder = "input" if name == "massless_pendulum" else "tests/regression/inputs"
    mt.run_msflex(args, f"{args.source_dir}/{folder}/{name}.yaml", output, extra=["-quiet", *options])
    return mt.history(output), output


def crossings(t, x, downward):
    i = np.where((x[:-1] > 0) & (x[1:] <= 0))[0] if downward else np.where((x[:-1] < 0) & (x[1:] >= 0))[0]
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def balance_drift(h):
    b = h["energy_balance"]
    scale = max(np.abs(h["total_energy"]).max(), np.abs(h["external_work"]).max(), np.abs(h.get("dissipated_energy", np.zeros(1))).max())
    return np.abs(b - b[0]).max() / scale


# Spring-mass-damper against its closed form.
h, _ = run("spring_mass_damper", "em")
m, k, c = 2.0, 78.95683521, 0.5026548246
w0 = np.sqrt(k / m)
zeta = c / (2 * m * w0)
wd = w0 * np.sqrt(1 - zeta**2)
t, x = h["time"], h["slide.tx"]
down = crossings(t, x, True)
period = np.polyfit(np.arange(len(down)), down, 1)[0]
peaks = [i for i in range(1, len(x) - 1) if x[i] >= x[i - 1] and x[i] > x[i + 1] and x[i] > 0]
# the peaks of the sampled response, refined by a parabola through the three samples
tp, xp = [], []
for i in peaks:
    a, b, cc = np.polyfit(t[i - 1:i + 2] - t[i], x[i - 1:i + 2], 2)
    tp.append(t[i] - b / (2 * a))
    xp.append(cc - b * b / (4 * a))
decay = -np.polyfit(tp, np.log(xp), 1)[0]
print(f"spring-mass-damper: {len(t) - 1} steps, omega_d {2 * np.pi / period:.8f} (exact {wd:.8f}), decay {decay:.8f} (exact {zeta * w0:.8f})")
check.less("spring-mass-damper: |omega_d - exact| / exact", abs(2 * np.pi / period - wd) / wd, 1e-4)
check.less("spring-mass-damper: |decay - exact| / exact", abs(decay - zeta * w0) / (zeta * w0), 1e-4)
check.less("spring-mass-damper: drift of energy - work + dissipated / energy", balance_drift(h), 1e-8)
check.true(f"spring-mass-damper: at least 2000 steps ({len(t) - 1})", len(t) - 1 >= 2000)

# Every force element with em.
h, _ = run("force_element_energy", "em")
drift = balance_drift(h)
print(f"force elements, em: {len(h['time']) - 1} steps, work {h['external_work'][-1]:.6g} J, dissipated {h['dissipated_energy'][-1]:.6g} J, "
      f"relative drift {drift:.3e}")
check.less("force elements, em: drift of energy - work + dissipated / scale", drift, 1e-8)
check.less("force elements, em: the dampers dissipate (-dissipated)", -h["dissipated_energy"][-1], 0.0)
check.true(f"force elements, em: at least 1000 steps ({len(h['time']) - 1})", len(h["time"]) - 1 >= 1000)

# Massless rod pendulum: first downward zero crossing at a quarter of the period 2.011094 s.
for integrator in ("newmark", "genalpha", "mc", "em"):
    h, _ = run("massless_pendulum", integrator, ["-analysis_integrator", integrator, "-analysis_end_time", "0.8"])
    quarter = crossings(h["time"], h["hinge.rx"], True)
    value = quarter[0] if len(quarter) else np.inf
    print(f"massless pendulum, {integrator}: quarter period {value:.6f} s (exact 0.502774)")
    check.less(f"massless pendulum, {integrator}: |T/4 - exact| / exact", abs(value - 0.502774) / 0.502774, 2e-3)

# Massless cantilever with a tip mass: period 0.513793 s.
for integrator in ("newmark", "genalpha", "em"):
    _, output = run("massless_cantilever", integrator, ["-analysis_integrator", integrator])
    p = mt.probe_history(output, "tip")
    up = crossings(p["time"], p["displacement"][:, 1], False)
    value = np.mean(np.diff(up)) if len(up) > 1 else np.inf
    print(f"massless cantilever, {integrator}: period {value:.6f} s (exact 0.513793)")
    check.less(f"massless cantilever, {integrator}: |T - exact| / exact", abs(value - 0.513793) / 0.513793, 1e-4)

# Spinning offset body.
for label, options, limit in (("newmark", ["-analysis_integrator", "newmark"], 2e-5),
                              ("genalpha rho 1", ["-analysis_integrator", "genalpha", "-analysis_spectral_radius", "1"], 2e-5),
                              ("em", ["-analysis_integrator", "em"], 1e-9)):
    h, _ = run("spinning_offset_body", label.replace(" ", "_"), options)
    E = h["total_energy"]
    drift = np.abs(E - E[0]).max() / E[0]
    half = len(E) // 2
    print(f"spinning offset body, {label}: {len(E) - 1} steps, largest |E - E0| / E0 {drift:.3e}, "
          f"first half {np.abs(E[:half] - E[0]).max() / E[0]:.3e}, second half {np.abs(E[half:] - E[0]).max() / E[0]:.3e}")
    check.less(f"spinning offset body, {label}: largest |E - E0| / E0", drift, limit)

# Steady spin about a principal axis through the support: the exact motion, kept by every scheme.
for integrator in ("newmark", "genalpha", "mc", "em"):
    h, _ = run("steady_offset_spin", integrator, ["-analysis_integrator", integrator, "-analysis_spectral_radius", "1"])
    E = h["total_energy"]
    drift = np.abs(E - 61.2).max() / 61.2
    print(f"steady offset spin, {integrator}: {len(E) - 1} steps, largest |E - 61.2 J| / 61.2 J {drift:.3e}")
    check.less(f"steady offset spin, {integrator}: largest |E - E_exact| / E_exact", drift, 1e-10)

# Drive at constant speed: consistent initial velocities.
runs = {}
for label, options, ranks in (("projected", [], 1), ("projected, 2 ranks", [], 2), ("given", ["-analysis_initial_velocities", "given"], 1)):
    output = f"{args.work_dir}/drive_start_{label.replace(', ', '_').replace(' ', '')}.h5"
    mt.run_msflex(args, f"{inputs}/drive_start.yaml", output, extra=["-quiet", *options], np_ranks=ranks)
    runs[label] = mt.history(output)
    print(f"drive start, {label}: kinetic energy at t = 0 {runs[label]['kinetic_energy'][0]:.10f} J (rigid rotation 4.1791667 J), "
          f"largest strain energy {runs[label]['strain_energy'].max():.4e} J")
exact = 0.5 * 25.0 * (1.0 / 3.0 + 1e-3)
for label in ("projected", "projected, 2 ranks"):
    check.less(f"drive start, {label}: |KE_0 - rigid rotation| / rigid rotation", abs(runs[label]["kinetic_energy"][0] - exact) / exact, 1e-9)
    check.less(f"drive start, {label}: largest strain energy / KE_0", runs[label]["strain_energy"].max() / exact, 1e-4)
check.less("drive start, given: the drive's jerk strains the arm (-largest strain energy / KE_0)", -runs["given"]["strain_energy"].max() / exact, -0.1)

# Coordinate rates start their slaves also with given velocities (they were ignored: rate 0, KE 0).
for label, options in (("projected", []), ("given", ["-analysis_initial_velocities", "given"])):
    output = f"{args.work_dir}/coordinate_rates_{label}.h5"
    mt.run_msflex(args, f"{inputs}/coordinate_rates.yaml", output, extra=["-quiet", *options])
    h = mt.history(output)
    check.less(f"coordinate rates, {label}: |KE_0 - 2 J|", abs(h["kinetic_energy"][0] - 2.0), 1e-12)
    check.less(f"coordinate rates, {label}: |slide.tx_rate(0) - 1| + |hinge.rx_rate(0) - 2|", abs(h["slide.tx_rate"][0] - 1.0) + abs(h["hinge.rx_rate"][0] - 2.0), 1e-12)
# ... and carry on down a chain: a bob welded below the hinge moves with it (given velocities left
# it at rest: KE_0 = 0, the pendulum never swung, the weld violated at velocity level).
swings = {}
for label, options in (("projected", []), ("given", ["-analysis_initial_velocities", "given"])):
    output = f"{args.work_dir}/welded_pendulum_{label}.h5"
    mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/welded_pendulum.yaml", output, extra=["-quiet", "-analysis_end_time", "0.5", *options])
    swings[label] = mt.history(output)
    check.less(f"welded pendulum, {label}: |KE_0 - I_o theta'^2 / 2 = 2.7 J|", abs(swings[label]["kinetic_energy"][0] - 2.7), 1e-12)
# The projection's conjugate gradients may stop on a preconditioned residual held at round-off by
# the shifted LU of a free hinge's mode; the true residual decides (it stopped the run before).
output = f"{args.work_dir}/flexible_double_pendulum.h5"
code, stdout, stderr = mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/flexible_double_pendulum.yaml", output, expect_success=False)
print("flexible double pendulum:", [line for line in stdout.splitlines() if "initial velocities" in line][:1], stderr.strip()[-300:])
check.equal("flexible double pendulum, projected start: exit status", code, 0)
import re  # noqa: E402
reduced = re.search(r"V\^T K V ([0-9.e+-]+) -> ([0-9.e+-]+)", stdout)
check.true("flexible double pendulum: the projection lowered the strain rate V^T K V", bool(reduced) and float(reduced.group(2)) < 1e-2 * float(reduced.group(1)))
check.less("welded pendulum: max |angle given - angle projected| (rad)", np.abs(swings["given"]["hinge.rx"] - swings["projected"]["hinge.rx"]).max(), 1e-12)

# A node without mass between two prismatic joints (ground - j1 - n - j2 - body of 2 kg, springs
# k1 = 300 on j1, k2 = 600 on j2): the mass matrix of (q1, q2) is
# m [[1, 1], [1, 1]], singular without an empty row. newmark and genalpha stopped ("the initial
# accelerations could not be computed ... is every node with a DOF free given mass or stiffness?")
# and every integrator's consistent reactions failed at every step (em reported half the joint
# force). Started in equilibrium and moving (q2' = 1): every integrator runs, no warning, and the
# joints' force along the slide is the spring's, -k2 q2 (0.49 N at the first step). Started with
# j2 stretched alone (the node out of equilibrium): a warning, and newmark and genalpha bring the
# node to equilibrium in the first step (k1 q1 = k2 q2).
def chain(start, extra=""):
    return ("nodes: {n: [0, 0, 0], s: [0.5, 0, 0]}\nrigid_bodies: [{node: s, mass: 2.0, inertia: [0.1, 0.1, 0.1]}]\n"
            "joints: [{name: j1, type: prismatic, master: ground, slave: n, axis: [1, 0, 0]}, {name: j2, type: prismatic, master: n, slave: s, axis: [1, 0, 0]}]\n"
            "force_elements: [{name: k1, type: coordinate, joint: j1, coordinate: tx, stiffness: 300}, "
            "{name: k2, type: coordinate, joint: j2, coordinate: tx, stiffness: 600}]\n"
            f"initial_conditions: [{start}]\n{extra}"
            "analysis: {type: dynamic, integrator: newmark, end_time: 0.05, initial_step: 0.001, max_step: 0.001}\n")
WARNING = "msflex: warning: the part of the model without mass is not in equilibrium at t = 0"
for name, start in (("moving", "{joint: j2, coordinate: tx, value: 0.0, rate: 1.0}"), ("stretched", "{joint: j2, coordinate: tx, value: 0.01}")):
    with open(f"{args.work_dir}/massless_chain_{name}.yaml", "w") as f:
        f.write(chain(start))
    for integrator in ("newmark", "genalpha", "mc", "em"):
        output = f"{args.work_dir}/massless_chain_{name}_{integrator}.h5"
        code, stdout, _ = mt.run_msflex(args, f"{args.work_dir}/massless_chain_{name}.yaml", output, extra=["-analysis_integrator", integrator],
                                        expect_success=False)
        label = f"massless node between joints, {name}, {integrator}"
        check.equal(f"{label}: exit status", code, 0)
        if code != 0:
            continue
        h = mt.history(output)
        check.true(f"{label}: the warning {'given' if name == 'stretched' else 'absent'}", (WARNING in stdout) == (name == "stretched"))
        check.true(f"{label}: no consistent reaction failed", "could not be solved" not in stdout)
        if name == "moving":
            check.less(f"{label}: |j2.force_x + k2 q2| at the first step (N)", abs(h["j2.force_x"][1] + 600.0 * h["j2.tx"][1]), 1e-10)
        elif integrator in ("newmark", "genalpha"):
            balance = 300.0 * h["j1.tx"][1] - 600.0 * h["j2.tx"][1]
            check.less(f"{label}: |k1 q1 - k2 q2| after the first step (N)", abs(balance), 1e-9)
# The same out of balance with Cartesian springs (the node's translations a zero row of M): newmark
# gave the node the acceleration of its spring force on a unit mass; now zero, and the warning.
with open(f"{args.work_dir}/massless_springs.yaml", "w") as f:
    f.write("nodes: {a: [-0.5, 0, 0], n: [0, 0, 0], s: [0.5, 0, 0]}\nrigid_bodies: [{node: s, mass: 2.0, inertia: [0.1, 0.1, 0.1]}]\n"
            "supports: [{nodes: a, fix: all}, {nodes: [n, s], fix: [uy, uz, rx, ry, rz]}]\n"
            "force_elements: [{name: k1, type: spring_damper, nodes: [a, n], stiffness: 300}, {name: k2, type: spring_damper, nodes: [n, s], stiffness: 600}]\n"
            "initial_conditions: [{nodes: s, displacement: [0.01, 0, 0]}]\n"
            "analysis: {type: dynamic, integrator: newmark, end_time: 0.01, initial_step: 0.001, max_step: 0.001}\n")
for integrator in ("newmark", "em"):
    _, stdout, _ = mt.run_msflex(args, f"{args.work_dir}/massless_springs.yaml", f"{args.work_dir}/massless_springs_{integrator}.h5",
                                 extra=["-analysis_integrator", integrator])
    check.true(f"massless node between springs, {integrator}: the warning", WARNING in stdout)
# The mass matrix's singular solve on the parallel and sparse paths: the failed factorisation of
# the first attempt left Newton's MUMPS unusable (INFOG(1) = -3 in the next step, a rejected step),
# and on one rank it handed the run's banded LU to MUMPS.
for ranks, options in ((1, ["-jacobian_dense_below", "0"]), (2, [])):
    output = f"{args.work_dir}/massless_chain_sparse_{ranks}.h5"
    _, stdout, _ = mt.run_msflex(args, f"{args.work_dir}/massless_chain_moving.yaml", output, extra=options, np_ranks=ranks)
    label = f"massless node between joints, {' '.join(options) or 'default'}, np {ranks}"
    check.true(f"{label}: no step rejected", "0 rejected" in stdout)
    check.true(f"{label}: the run's LU not handed over", "MUMPS factors from here on" not in stdout)
    check.less(f"{label}: |j2.force_x + k2 q2| at the first step (N)", abs(mt.history(output)["j2.force_x"][1] + 600.0 * mt.history(output)["j2.tx"][1]), 1e-10)
# A support's row is its reaction, never one of the accelerations' equations, also on a node
# without mass: a fixed anchor holding a stretched spring (k1 = 300 by 0.01 m) reacts with -3 N at
# t = 0 (it read 0), and a massless support driven at 1 m/s does the work the energy balance counts
# (it missed 2 % of it in the first step).
with open(f"{args.work_dir}/massless_anchor.yaml", "w") as f:
    f.write("nodes: {a: [-0.5, 0, 0], n: [0, 0, 0]}\nrigid_bodies: [{node: n, mass: 1.0, inertia: [0.1, 0.1, 0.1]}]\n"
            "supports: [{nodes: a, fix: all}, {nodes: n, fix: [uy, uz, rx, ry, rz]}]\n"
            "force_elements: [{name: k1, type: spring_damper, nodes: [a, n], stiffness: 300}]\n"
            "initial_conditions: [{nodes: n, displacement: [0.01, 0, 0]}]\nprobes: [{name: anchor, reaction: a}]\n"
            "analysis: {type: dynamic, integrator: em, end_time: 0.002, initial_step: 0.001, max_step: 0.001}\n")
with open(f"{args.work_dir}/massless_driven_support.yaml", "w") as f:
    f.write("nodes: {a: [-0.5, 0, 0], n: [0, 0, 0]}\nrigid_bodies: [{node: n, mass: 1.0, inertia: [0.1, 0.1, 0.1]}]\n"
            "supports: [{nodes: a, fix: [uy, uz, rx, ry, rz]}, {nodes: a, prescribe: {ux: 1.0}}, {nodes: n, fix: [uy, uz, rx, ry, rz]}]\n"
            "force_elements: [{name: k1, type: spring_damper, nodes: [a, n], stiffness: 300}]\n"
            "initial_conditions: [{nodes: n, displacement: [0.05, 0, 0]}]\n"
            "analysis: {type: dynamic, integrator: newmark, end_time: 0.01, initial_step: 0.001, max_step: 0.001}\n")
for integrator in ("newmark", "em"):
    output = f"{args.work_dir}/massless_anchor_{integrator}.h5"
    mt.run_msflex(args, f"{args.work_dir}/massless_anchor.yaml", output, extra=["-quiet", "-analysis_integrator", integrator])
    check.less(f"massless fixed anchor, {integrator}: |reaction at t = 0 + 3 N|", abs(mt.history(output)["anchor.force_x"][0] + 3.0), 1e-12)
    output = f"{args.work_dir}/massless_driven_support_{integrator}.h5"
    mt.run_msflex(args, f"{args.work_dir}/massless_driven_support.yaml", output, extra=["-quiet", "-analysis_integrator", integrator])
    balance = mt.history(output)["energy_balance"]
    check.less(f"massless driven support, {integrator}: energy balance range / its value", float((balance.max() - balance.min()) / abs(balance[0])),
               1e-10)
# A light body (1e-7 kg on a spring of 1e-3 N/m stretched 1 cm) beside a massless node between
# joints carrying 1e6 kg: the singular mass matrix's least-squares solve (gelss, dense) took the
# light body's mass for round-off (a cut at 1e-12 of the largest singular value) and started it
# with zero acceleration (its joint force 0 instead of -1e-5 N).
with open(f"{args.work_dir}/light_beside_heavy.yaml", "w") as f:
    f.write("nodes: {n: [0, 0, 0], s: [0.5, 0, 0], l: [0, 1, 0]}\n"
            "rigid_bodies: [{node: s, mass: 1.0e6, inertia: [1.0e5, 1.0e5, 1.0e5]}, {node: l, mass: 1.0e-7, inertia: [1.0e-8, 1.0e-8, 1.0e-8]}]\n"
            "joints: [{name: j1, type: prismatic, master: ground, slave: n, axis: [1, 0, 0]}, {name: j2, type: prismatic, master: n, slave: s, axis: [1, 0, 0]}, "
            "{name: jl, type: prismatic, master: ground, slave: l, axis: [1, 0, 0]}]\n"
            "force_elements: [{name: k1, type: coordinate, joint: j1, coordinate: tx, stiffness: 3.0e8}, {name: k2, type: coordinate, joint: j2, coordinate: tx, stiffness: 6.0e8}, "
            "{name: kl, type: coordinate, joint: jl, coordinate: tx, stiffness: 1.0e-3}]\n"
            "initial_conditions: [{joint: j1, coordinate: tx, value: 0.02}, {joint: j2, coordinate: tx, value: 0.01}, {joint: jl, coordinate: tx, value: 0.01}]\n"
            "analysis: {type: dynamic, integrator: newmark, end_time: 0.001, initial_step: 0.0001, max_step: 0.0001}\n")
output = f"{args.work_dir}/light_beside_heavy.h5"
mt.run_msflex(args, f"{args.work_dir}/light_beside_heavy.yaml", output, extra=["-quiet"])
check.less("light body beside a singular mass matrix: |its joint force at t = 0 + 1e-5 N| (N)", abs(mt.history(output)["jl.force_x"][0] + 1e-5), 1e-12)
check.finish()
