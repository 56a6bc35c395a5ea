"""The projection of the initial velocities where a free motion is left to the norm (docs/force_elements.md,
"Initial state of a dynamic analysis"): a straight arm of n elements along x on a revolute joint
to the ground about y at its root, and at its tip a second beam of n elements along y, joined
through a screw, cylindrical, cam or rack-and-pinion joint about the arm's axis whose rotation
starts at 20 rad/s. Nothing strains for any hinge rate, so the hinge rate is the one of the
minimum-norm correction: the unknowns' vector is orthogonal to the hinge's rigid mode, which moves
each independent arm node at x with (0, 0, -x) and spin (0, 1, 0), each independent node of the
spun beam at (1, y, 0) with (0, 0, -1) and (0, 1, 0), and the hinge's coordinate by 1; the spun
beam's nodes move with (0, 0, 20 y) + (the joint's translation along x) and spin (20, 0, 0), so

    hinge rate = 20 sum_y y / (1 + sum_x (x^2 + 1) + 2 n)

over the arm's nodes but the root and the spun beam's nodes but the joint's slave. Checked for
every joint kind, with n = 2 and 4, on 1 and 2 ranks (the preconditioned residual's stop let the
hinge wander: 0.0115 rad/s on one rank and -9.76 on two for the screw; the rack-and-pinion stopped
with DIVERGED_INDEFINITE_MAT)."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("velocity projection")

MODEL = """
sections:
  - {{name: s, EA: 1.0e6, GA2: 4.0e5, GA3: 4.0e5, GJ: 200, EI2: 300, EI3: 300, rhoA: 1.0, rhoJ: [0.002, 0.001, 0.001]}}
nodes: {{root: [0, 0, 0], tip: [1, 0, 0], nut: [1, 0, 0], blade: [1, 0.4, 0]}}
beams:
  - {{name: arm, section: s, from: root, to: tip, elements: {n}}}
  - {{name: spun, section: s, from: nut, to: blade, elements: {n}}}
joints:
  - {{name: hinge, type: revolute, master: ground, slave: root, axis: [0, 1, 0]}}
  - {{name: j, type: {kind}, master: tip, slave: nut, axis: [1, 0, 0]{extra}}}
initial_conditions:
  - {{joint: j, coordinate: {coordinate}, rate: 20}}
analysis: {{type: dynamic, integrator: em, end_time: 0.002, initial_step: 2.0e-3, max_step: 2.0e-3}}
"""
KINDS = {
    "screw": (", pitch: 0.01", "rotation"),
    "cylindrical": ("", "rx"),
    "cam": (", second_axis: [0, 1, 0], radius: 0.01", "rotation"),
    "rack_pinion": (", second_axis: [0, 1, 0], radius: 0.01", "rotation"),
}
for n in (2, 4):
    x = np.arange(1, n + 1) / n
    y = 0.4 * np.arange(1, n + 1) / n
    expected = 20.0 * y.sum() / (1.0 + (x**2 + 1.0).sum() + 2.0 * n)
    for kind, (extra, coordinate) in KINDS.items():
        model = f"{args.work_dir}/spun_{kind}_{n}.yaml"
        with open(model, "w") as f:
            f.write(MODEL.format(n=n, kind=kind, extra=extra, coordinate=coordinate))
        for ranks in (1, 2):
            output = f"{args.work_dir}/spun_{kind}_{n}_{ranks}.h5"
            code, stdout, stderr = mt.run_msflex(args, model, output, extra=["-quiet"], np_ranks=ranks, expect_success=False)
            label = f"{kind}, {n}+{n} elements, {ranks} rank(s)"
            check.equal(f"{label}: exit status ({stderr.strip()[-200:]})", code, 0)
            if code != 0:
                continue
            h = mt.history(output)
            check.less(f"{label}: |hinge rate - {expected:.6f}| (rad/s)", abs(h["hinge.rx_rate"][0] - expected), 1e-8)

# initial_velocities: given, a 2 kg body on a prismatic joint along x given (1, 1, 0) m/s: the slide
# takes rate 1 and the body moves at (1, 0, 0), kinetic energy 1 J, said in one line. The forbidden
# (0, 1, 0) stayed in the body's velocity, and the kinetic energy counted it for the whole run (2 J).
given = f"{args.work_dir}/given.yaml"
with open(given, "w") as f:
    f.write("nodes: {s: [0, 0, 0]}\nrigid_bodies: [{node: s, mass: 2.0, inertia: [0.1, 0.1, 0.1]}]\n"
            "joints: [{name: rail, type: prismatic, master: ground, slave: s, axis: [1, 0, 0]}]\n"
            "force_elements: [{name: spring, type: coordinate, joint: rail, coordinate: tx, stiffness: 200}]\n"
            "initial_conditions: [{nodes: s, velocity: [1, 1, 0]}]\n"
            "analysis: {type: dynamic, integrator: em, end_time: 0.01, initial_step: 0.001, max_step: 0.001, initial_velocities: given}\n")
for ranks in sorted({1, args.np}):
    output = f"{args.work_dir}/given_np{ranks}.h5"
    _, stdout, _ = mt.run_msflex(args, given, output, np_ranks=ranks)
    h = mt.history(output)
    label = f"given velocity across a prismatic joint, np {ranks}"
    check.less(f"{label}: |slide rate - 1|", abs(h["rail.tx_rate"][0] - 1.0), 1e-14)
    check.less(f"{label}: |kinetic energy at t = 0 - 1 J|", abs(h["kinetic_energy"][0] - 1.0), 1e-14)
    check.less(f"{label}: largest |total energy - 1 J|", float(np.abs(h["total_energy"] - 1.0).max()), 1e-10)
    check.true(f"{label}: one line names the joint and the change", "changed by up to 1 (joint 'rail')" in stdout)
# ... and "nearest" in the kinetic energy of the slave's body: a body (m = 1, J = 0.01) on a screw of
# pitch p = 0.005 given v = 0.01 along the axis turns at m p v / (m p^2 + J) = 4.9875e-3 rad/s, the
# same model in millimetres (pitch 5, v 10, J 1e4) alike (in the plain norm of the six velocities:
# 5e-5 and 1.92 rad/s).
for unit, scale in (("m", 1.0), ("mm", 1000.0)):
    with open(f"{args.work_dir}/screw_{unit}.yaml", "w") as f:
        f.write(f"nodes: {{s: [0, 0, 0]}}\nrigid_bodies: [{{node: s, mass: 1.0, inertia: [{0.01 * scale**2}, {0.01 * scale**2}, {0.01 * scale**2}]}}]\n"
                f"joints: [{{name: sc, type: screw, master: ground, slave: s, axis: [1, 0, 0], pitch: {0.005 * scale}}}]\n"
                f"initial_conditions: [{{nodes: s, velocity: [{0.01 * scale}, 0, 0]}}]\n"
                "analysis: {type: dynamic, integrator: newmark, end_time: 0.002, initial_step: 0.001, max_step: 0.001, initial_velocities: given}\n")
    output = f"{args.work_dir}/screw_{unit}.h5"
    mt.run_msflex(args, f"{args.work_dir}/screw_{unit}.yaml", output, extra=["-quiet"])
    rate = float(mt.history(output)["sc.rx_rate"][0])
    check.less(f"given velocity along a screw, in {unit}: |rate / (m p v / (m p^2 + J)) - 1|", abs(rate / (0.005 * 0.01 / (0.005**2 + 0.01)) - 1), 1e-12)
check.finish()
