"""Relay nodes (-analysis_condensation_depth, docs/solvers.md): a chain of joints deeper than the
condensation depth keeps every depth-th slave that is a master in the linear solve, with the joint
as  du_s = C du_U  and its force  R^T lambda; eliminating them is the condensation, so the motion
is the condensed one to round-off while the cost per joint no longer grows with the chain.

1. A chain of 12 rigid bodies with offset centres of mass, each the master of the next through
   revolute, spherical, universal, screw and prismatic joints, a bushing between bodies 3 and 9
   (a force element between two slaves), a 4-element beam hanging from the last body, gravity:
   with newmark, genalpha, mc and em, condensed whole (depth 0) and with relays every 1, 3 and 8
   joints, the frames agree to 1e-9 of the chain's size and the Newton iterations per step are the
   same; em's energy balance stays constant to 1e-9 of the energy with relays too.
2. The projection of the initial velocities with relays (scripts/make-chain's rigid chain, a
   given angular velocity on its first body): the same velocities as condensed whole, to 1e-12.
3. Options that cannot serve relays are one line and exit status 1: -snes_mf_operator and
   PETSc's LU (no pivoting); a negative depth, as an option and in the input.
4. Statics without the stability account (the only statics with relays): 12 hinges of alternating
   axes in a chain, each slave held by a beam to a fixed point, a tip force; load control and arc
   length give the same path with relays every 3 joints as condensed whole, to 1e-12.
5. A chain of 12 bodies hanging from the tip of a clamped beam (fixed DOFs in the projection), an
   initial angular velocity projected: the same velocities and motion as condensed whole.
6. A chain whose last 6 joints carry no mass, only coordinate springs (the initial accelerations'
   massless unknowns below a relay): the same count of massless unknowns and the same motion.
7. -snes_linesearch_type (msflex's own line search keeps the relays' rows out of the update) is
   one line and exit status 1."""

import os
import re
import subprocess
import sys

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("relay nodes")
scripts = os.path.join(args.source_dir, "scripts")

KINDS = ["spherical", "revolute_y", "universal", "screw", "revolute_z", "prismatic"]


def chain_model(integrator, bodies=12, extra=""):
    lines = [
        "title: deep chain of mixed joints",
        "sections:",
        "  - {name: s, EA: 1.0e5, GA2: 4.0e4, GA3: 4.0e4, GJ: 50, EI2: 80, EI3: 80, rhoA: 0.5, rhoJ: [0.02, 0.01, 0.01]}",
        "nodes:",
    ]
    lines += [f"  b{k}: [{0.5 * (k + 1)}, 0, 0]" for k in range(bodies)]
    lines += [f"  t0: [{0.5 * (bodies + 1)}, 0, 0]", f"  t1: [{0.5 * (bodies + 1) + 1.0}, 0.2, 0]"]
    lines += ["beams:", "  - {name: tail, section: s, from: t0, to: t1, elements: 4}", "rigid_bodies:"]
    lines += [f"  - {{node: b{k}, mass: 1.0, inertia: [0.02, 0.03, 0.04], offset: [0.1, 0.02, 0]}}" for k in range(bodies)]
    lines += ["joints:", "  - {name: j0, type: revolute, master: ground, slave: b0, axis: [0, 0, 1]}"]
    for k in range(1, bodies):
        kind, m, s = KINDS[(k - 1) % len(KINDS)], f"b{k - 1}", f"b{k}"
        spec = {
            "spherical": "type: spherical",
            "revolute_y": "type: revolute, axis: [0, 1, 0]",
            "revolute_z": "type: revolute, axis: [0, 0, 1]",
            "universal": "type: universal, axis: [0, 0, 1], second_axis: [0, -1, 0]",
            "screw": "type: screw, axis: [1, 0, 0], pitch: 0.05",
            "prismatic": "type: prismatic, axis: [1, 0, 0]",
        }[kind]
        lines.append(f"  - {{name: j{k}, master: {m}, slave: {s}, {spec}}}")
    lines.append(f"  - {{name: jt, type: revolute, master: b{bodies - 1}, slave: t0, axis: [0, 0, 1]}}")
    lines += [
        "force_elements:",
        "  - {name: link, type: bushing, nodes: [b3, b9], stiffness: [200, 200, 200, 5, 5, 5], damping: [1, 1, 1, 0.01, 0.01, 0.01]}",
        "functions:",
        "  - {name: always, type: constant, value: 1.0}",
        "loads:",
        "  - {gravity: [0, -9.81, 0], function: always}",
        "initial_conditions:",
        "  - {nodes: b0, angular_velocity: [0, 0, 1]}",
        "analysis:",
        "  type: dynamic",
        f"  integrator: {integrator}",
        "  end_time: 0.05",
        "  initial_step: 0.005",
        "  max_step: 0.005",
        "  initial_velocities: given",
    ]
    return "\n".join(lines) + "\n" + extra


def unknowns(stdout):
    """The count of unknowns in the run's first line; with relays it says how many are theirs."""
    match = re.search(r" (\d+) unknowns(?: \((\d+) of them for (\d+) relay nodes, condensation depth \d+\))?;", stdout)
    if not match:
        return -1
    if match.group(2):
        check.equal("the relays' share of the unknowns is 12 per relay", int(match.group(2)), 12 * int(match.group(3)))
    return int(match.group(1))


# 1. The same motion with and without relays.
for integrator in ("newmark", "genalpha", "mc", "em"):
    path = f"{args.work_dir}/chain_{integrator}.yaml"
    with open(path, "w") as f:
        f.write(chain_model(integrator))
    runs = {}
    for depth in (0, 1, 3, 8):
        output = f"{args.work_dir}/chain_{integrator}_{depth}.h5"
        _, stdout, _ = mt.run_msflex(args, path, output, extra=["-analysis_condensation_depth", str(depth)])
        with h5py.File(output, "r") as f:
            frames = {name: f["frames"][name][()] for name in ("position", "rotation", "velocity", "angular_velocity", "body_center")}
        runs[depth] = (frames, mt.history(output), unknowns(stdout))
    reference, history_reference, unknowns_reference = runs[0]
    for depth in (1, 3, 8):
        frames, history, count = runs[depth]
        print(f"{integrator}, depth {depth}: {count} unknowns (condensed whole: {unknowns_reference})")
        check.true(f"{integrator}, depth {depth}: relays add unknowns", count > unknowns_reference)
        check.less(f"{integrator}, depth {depth}: max |x - x_condensed| / chain length", np.abs(frames["position"] - reference["position"]).max() / 7.0, 1e-9)
        check.less(f"{integrator}, depth {depth}: max |body centre difference| / chain length", np.abs(frames["body_center"] - reference["body_center"]).max() / 7.0, 1e-9)
        speed = np.abs(reference["velocity"]).max()
        check.less(f"{integrator}, depth {depth}: max |v - v_condensed| / max |v|", np.abs(frames["velocity"] - reference["velocity"]).max() / speed, 1e-8)
        check.equal(f"{integrator}, depth {depth}: Newton iterations", int(history["newton_iterations"].sum()), int(history_reference["newton_iterations"].sum()))
        if integrator == "em":
            energy = np.abs(history["total_energy"]).max()
            check.less(f"em, depth {depth}: energy balance range / energy", np.ptp(history["energy_balance"][1:]) / energy, 1e-9)

# 2. The projection of the initial velocities.
chain = f"{args.work_dir}/rigid_chain.yaml"
subprocess.run([sys.executable, os.path.join(scripts, "make-chain"), "--joints", "40", "-o", chain], check=True)
velocities = {}
for depth in (0, 1, 8):
    output = f"{args.work_dir}/rigid_chain_{depth}.h5"
    mt.run_msflex(args, chain, output, extra=["-analysis_condensation_depth", str(depth)])
    with h5py.File(output, "r") as f:
        velocities[depth] = (f["frames/velocity"][0], f["frames/angular_velocity"][0])
for depth in (1, 8):
    scale = np.abs(velocities[0][0]).max()
    check.less(f"projected velocities, depth {depth}: max |v - v_condensed| / max |v|", np.abs(velocities[depth][0] - velocities[0][0]).max() / scale, 1e-12)
    check.less(f"projected angular velocities, depth {depth}: max difference", np.abs(velocities[depth][1] - velocities[0][1]).max(), 1e-12)


# 3. One line, exit status 1.
def one_line(label, status, stderr, text):
    lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]  # not mpiexec's own report
    check.equal(f"{label}: exit status", status, 1)
    check.equal(f"{label}: message lines", len(lines), 1)
    check.true(f"{label}: the line says why", bool(lines) and text in lines[0])
    check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)


path = f"{args.work_dir}/chain_em.yaml"
for label, extra, text in (
    ("-snes_mf_operator", ["-analysis_condensation_depth", "3", "-snes_mf_operator"], "bad option: -snes_mf_operator with relay nodes"),
    # (on several ranks PETSc's LU is refused anyway, for being sequential)
    ("PETSc's LU", ["-analysis_condensation_depth", "3", "-pc_factor_mat_solver_type", "petsc"], "bad option: -pc_factor_mat_solver_type petsc"),
    ("depth -1", ["-analysis_condensation_depth", "-1"], "-analysis_condensation_depth must lie in [0, 1000000]"),
):
    status, _, stderr = mt.run_msflex(args, path, f"{args.work_dir}/bad.h5", extra=extra, expect_success=False)
    one_line(label, status, stderr, text)
bad = f"{args.work_dir}/bad_depth.yaml"
with open(bad, "w") as f:
    f.write(chain_model("em", extra="  condensation_depth: -2\n"))
status, _, stderr = mt.run_msflex(args, bad, f"{args.work_dir}/bad.h5", expect_success=False)
one_line("input -2", status, stderr, "bad_depth.yaml:")

status, _, stderr = mt.run_msflex(args, path, f"{args.work_dir}/bad.h5", extra=["-analysis_condensation_depth", "3", "-snes_linesearch_type", "bt"], expect_success=False)
one_line("-snes_linesearch_type bt", status, stderr, "bad option: -snes_linesearch_type bt with relay nodes")


# 4. Statics.
def column_model(control):
    lines = ["title: chain of hinges held by beams", "sections:", "  - {name: s, EA: 1.0e4, GA2: 4.0e3, GA3: 4.0e3, GJ: 5, EI2: 8, EI3: 8}", "nodes:"]
    lines += [f"  b{k}: [0, {0.5 * (k + 1)}, 0]" for k in range(12)] + [f"  a{k}: [1, {0.5 * (k + 1)}, 0]" for k in range(12)]
    lines += ["beams:"] + [f"  - {{name: arm{k}, section: s, from: b{k}, to: a{k}, elements: 2}}" for k in range(12)]
    lines += ["supports:", "  - {nodes: [" + ", ".join(f"a{k}" for k in range(12)) + "], fix: all}"]
    lines += ["joints:", "  - {name: j0, type: revolute, master: ground, slave: b0, axis: [0, 0, 1]}"]
    axes = ["[0, 0, 1]", "[1, 0, 0]", "[0, 1, 0]"]
    lines += [f"  - {{name: j{k}, type: revolute, master: b{k - 1}, slave: b{k}, axis: {axes[k % 3]}}}" for k in range(1, 12)]
    lines += ["loads:", "  - {nodes: b11, force: [1, -2, 0.5]}", "analysis:", "  type: static", f"  control: {control}"]
    lines += ["  end_time: 1.0", "  initial_step: 0.25", "  max_step: 0.25", "  stability: false"]
    return "\n".join(lines) + "\n"


for control in ("load", "arc_length"):
    path = f"{args.work_dir}/column_{control}.yaml"
    with open(path, "w") as f:
        f.write(column_model(control))
    results = {}
    for depth in (0, 3):
        output = f"{args.work_dir}/column_{control}_{depth}.h5"
        _, stdout, _ = mt.run_msflex(args, path, output, extra=["-analysis_condensation_depth", str(depth)])
        with h5py.File(output, "r") as f:
            results[depth] = (f["frames/position"][()], f["frames/displacement"][()], mt.history(output), unknowns(stdout))
    (x0, u0, h0, n0), (x3, _, h3, n3) = results[0], results[3]
    check.true(f"statics, {control}: relays add unknowns ({n3} against {n0})", n3 > n0)
    check.true(f"statics, {control}: the same frames", x0.shape == x3.shape)
    if x0.shape == x3.shape:
        check.less(f"statics, {control}: max |x - x_condensed| / max |u|", np.abs(x3 - x0).max() / np.abs(u0).max(), 1e-12)
    if "load_factor" in h0 and len(h0["load_factor"]) == len(h3["load_factor"]):
        check.less(f"statics, {control}: max |load factor difference|", np.abs(h3["load_factor"] - h0["load_factor"]).max(), 1e-12)


# 5 and 6. A chain on a clamped beam with a projected velocity; a chain with a massless tail.
def hanging_chain(beam, massless_tail):
    bodies = 12
    lines = ["title: chain of hinges", "sections:", "  - {name: link, EA: 1.0e6, GA2: 4.0e5, GA3: 4.0e5, GJ: 50, EI2: 80, EI3: 80, rhoA: 1.0, rhoJ: [0.02, 0.01, 0.01]}"]
    lines += ["nodes:"] + ([f"  root: [-1, 0, 0]", "  tip: [0, 0, 0]"] if beam else [])
    lines += [f"  n{k}: [{k + 1}, 0, 0]" for k in range(bodies)]
    if beam:
        lines += ["beams:", "  - {name: beam, section: link, from: root, to: tip, elements: 2}", "supports:", "  - {nodes: root, fix: all}"]
    massive = range(6) if massless_tail else range(bodies)
    lines += ["rigid_bodies:"] + [f"  - {{node: n{k}, mass: 1.0, inertia: [0.01, 0.01, 0.01]}}" for k in massive]
    lines += ["joints:", f"  - {{name: j0, type: revolute, master: {'tip' if beam else 'ground'}, slave: n0, axis: [0, 0, 1]}}"]
    lines += [f"  - {{name: j{k}, type: revolute, master: n{k - 1}, slave: n{k}, axis: [0, {k % 2}, {1 - k % 2}]}}" for k in range(1, bodies)]
    if massless_tail:
        lines += ["force_elements:"] + [f"  - {{name: s{k}, type: coordinate, joint: j{k}, coordinate: rotation, stiffness: 10, free_value: 0.1}}" for k in range(6, bodies)]
    lines += ["functions:", "  - {name: always, type: constant, value: 1.0}", "loads:", "  - {gravity: [0, -9.81, 0], function: always}"]
    if beam:
        lines += ["initial_conditions:", "  - {nodes: n0, angular_velocity: [0, 0, 0.1]}"]
    lines += ["analysis:", "  {type: dynamic, integrator: genalpha, end_time: 0.01, initial_step: 0.002, max_step: 0.002}"]
    return "\n".join(lines) + "\n"


for label, beam, massless_tail in (("clamped beam, projected velocity", True, False), ("massless tail", False, True)):
    path = f"{args.work_dir}/hanging_{int(beam)}.yaml"
    with open(path, "w") as f:
        f.write(hanging_chain(beam, massless_tail))
    results = {}
    for depth in (0, 3):
        output = f"{args.work_dir}/hanging_{int(beam)}_{depth}.h5"
        _, stdout, _ = mt.run_msflex(args, path, output, extra=["-analysis_condensation_depth", str(depth)])
        with h5py.File(output, "r") as f:
            results[depth] = (f["frames/position"][()], f["frames/velocity"][()], re.findall(r"(\d+) unknown\(s\) without mass", stdout))
    (x0, v0, massless0), (x3, v3, massless3) = results[0], results[3]
    check.true(f"{label}: the same frames", x0.shape == x3.shape)
    if x0.shape == x3.shape:
        check.less(f"{label}: max |x - x_condensed| / 12", np.abs(x3 - x0).max() / 12.0, 1e-9)
        check.less(f"{label}: max |v - v_condensed| / max |v|", np.abs(v3 - v0).max() / max(np.abs(v0).max(), 1e-300), 1e-8)
        check.less(f"{label}: initial velocities, max |v - v_condensed|", np.abs(v3[0] - v0[0]).max(), 1e-12)
    check.true(f"{label}: the same massless unknowns ({massless0} and {massless3})", massless0 == massless3)
    if massless_tail:
        check.true(f"{label}: massless unknowns found", bool(massless0) and int(massless0[0]) > 0)
check.finish()
