"""Newton's direct factorisation through the executable, serially and on --np ranks
(`analysis.direct_solver`, docs/solvers.md): by default (`auto`) the sparse tangent of a chain is
banded and stored by node blocks, so one rank factors it by msflex's block LU in RCM order (-ksp_view
names it, and no package) and more ranks by MUMPS; `-pc_type lu` gives PETSc's LU instead on one
rank; `mumps`, given as an option or in the input, factors by MUMPS on any number of ranks
(-ksp_view names the package).
Both give the flying spaghetti's probe history and energies to 1e-9 of each series' largest value
(sparse tangent forced with -jacobian_dense_below 0; 0.3 s of em). An unknown value, as an option or
in the input, stops the run with exit status 1 and one line naming it (the input's with file and
line), without a PETSc trace-back. A slender cantilever with EA h^2/EI = 1.6e6 gets its exact
discrete tip deflection to 1e-7 from the default solver (the block LU's solves refined), MUMPS and
2 ranks alike. The arc-length corrector chooses its factorisation the same way, hands a failed banded LU
over to MUMPS, and follows the same path with each. A step on which Newton fails with the banded LU
is tried again with MUMPS: converged there (a banded LU failed at every pivot), MUMPS keeps the
rest of the run, said in one line and recorded in the checkpoint; failed there too (a step too
long for Newton's iteration limit), the banded LU comes back, nothing is said, and the run is
MUMPS' own to 1e-9 (before, every such failure handed the rest of the run to MUMPS: the turning arm
to t = 45 s took 3.94 s instead of 0.67)."""

import os
import re

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("direct solver")
source = f"{args.source_dir}/input/flying_spaghetti.yaml"
with open(source) as f:
    text = f.read()
assert "analysis:" in text
line = 1 + text[:text.index("analysis:")].count("\n")
given_mumps = os.path.join(args.work_dir, "given_mumps.yaml")
with open(given_mumps, "w") as f:
    f.write(text.replace("analysis:", "analysis:\n  direct_solver: mumps", 1))
SPARSE = ["-jacobian_dense_below", "0", "-analysis_end_time", "0.3"]
SERIES = ("A.position.x", "A.position.y", "A.position.z", "B.position.x", "B.position.y", "B.position.z", "B.rotation_angle", "total_energy", "kinetic_energy",
          "strain_energy")


def packages(stdout):
    return sorted(set(re.findall(r"package used to perform factorization: (\w+)", stdout)))


for ranks in sorted({1, args.np}):
    results = {}
    cases = [("default", source, [], None if ranks == 1 else "mumps"), ("option mumps", source, ["-analysis_direct_solver", "mumps"], "mumps"),
             ("input mumps", given_mumps, [], "mumps")]
    if ranks == 1:
        cases.append(("PETSc's LU by option", source, ["-pc_type", "lu"], "petsc"))
    for label, model, extra, expected in cases:
        output = f"{args.work_dir}/{label.replace(' ', '_').replace(chr(39), '')}_np{ranks}.h5"
        _, stdout, _ = mt.run_msflex(args, model, output, extra=[*SPARSE, *extra, "-ksp_view"], np_ranks=ranks)
        named = packages(stdout)
        block_lu = "msflex's block LU of 6x6 node blocks" in stdout
        check.true(f"np {ranks} {label}: -ksp_view {'names' if expected is None else 'does not name'} msflex's block LU", block_lu == (expected is None))
        check.true(f"np {ranks} {label}: -ksp_view names the factorisation package {expected} only ({named})", named == ([expected] if expected else []))
        check.equal(f"np {ranks} {label}: lines handing the LU over to MUMPS", stdout.count("MUMPS factors from here on"), 0)
        results[label] = mt.history(output)
    for label in [case[0] for case in cases[1:]]:
        worst = max(float(np.abs(results[label][s] - results["default"][s]).max() / np.abs(results["default"][s]).max()) for s in SERIES)
        print(f"np {ranks}: {label} against the default, largest difference relative to each series' largest value {worst:.2e}")
        check.less(f"np {ranks} {label}: the default's history", worst, 1e-9)


def expect_error(label, model, extra, *messages):
    code, _, stderr = mt.run_msflex(args, model, os.path.join(args.work_dir, "error.h5"), extra=extra, expect_success=False)
    lines = [entry for entry in stderr.splitlines() if entry.strip()]
    check.equal(f"{label}: exit status", code, 1)
    for message in messages:
        check.true(f"{label}: says '{message}'", any(message in entry for entry in lines))
    check.true(f"{label}: no PETSc trace-back", "PETSC ERROR" not in stderr)


expect_error("unknown option value", source, ["-analysis_direct_solver", "superlu"], "bad option: -analysis_direct_solver must be auto or mumps, got 'superlu'")
bad_input = os.path.join(args.work_dir, "bad.yaml")
with open(bad_input, "w") as f:
    f.write(text.replace("analysis:", "analysis:\n  direct_solver: superlu", 1))
expect_error("unknown value in the input", bad_input, [], f"bad.yaml:{line + 1}:", "unknown direct_solver 'superlu' in 'analysis'; expected auto or mumps")

# A slender cantilever whose axial and shear stiffness dwarf EI/h^2 (EA = GA = 1e8, EI = 1, 8
# linear elements, EA h^2/EI = 1.6e6) under a tip force of 1e-4: the block LU's first solve left
# 1e-2 of the right-hand side, and Newton, stopped by the round-off floor, gave a tip deflection
# 2.4e-4 off the exact discrete one, 1e-4 [(1 - 1/(4 n^2))/3 + 1/GA] (one-point shear: exact for
# linear elements); its solves are now refined (or handed to MUMPS), on 1 rank as on --np.
slender = os.path.join(args.work_dir, "slender.yaml")
with open(slender, "w") as f:
    f.write("""sections: [{name: s, EA: 1.0e8, GA2: 1.0e8, GA3: 1.0e8, GJ: 1, EI2: 1, EI3: 1}]
nodes: {root: [0, 0, 0], tip: [1, 0, 0]}
beams: [{name: b, section: s, from: root, to: tip, elements: 8, order: 1, orientation: [0, 1, 0]}]
supports: [{nodes: root, fix: all}]
loads: [{nodes: tip, force: [0, 1.0e-4, 0]}]
probes: [{name: tip, node: tip}]
analysis: {type: static, end_time: 1, initial_step: 1, max_step: 1, stability: false}
""")
exact = 1e-4 * ((1.0 - 1.0 / 256.0) / 3.0 + 1.0 / 1.0e8)
for label, options, ranks in (("default solver, 1 rank", [], 1), ("MUMPS, 1 rank", ["-analysis_direct_solver", "mumps"], 1), ("2 ranks", [], 2)):
    output = os.path.join(args.work_dir, f"slender_{ranks}_{len(options)}.h5")
    mt.run_msflex(args, slender, output, extra=["-quiet", *options], np_ranks=ranks)
    deflection = float(mt.history(output)["tip.position.y"][-1])
    check.less(f"slender cantilever, {label}: |tip deflection / exact - 1|", abs(deflection / exact - 1.0), 1e-7)

# The arc-length corrector factors as Newton does: one rank's banded tangent by PETSc's LU in RCM
# order (it stays AIJ for the stability account's Cholesky), which handed the corrector's solves of
# a 10^4-element cantilever from 2.32 to 0.32 s; more ranks and -analysis_direct_solver mumps by
# MUMPS. A failed banded factorisation (forced here: every pivot below -path_pc_factor_zeropivot)
# hands the corrector, and Newton, to MUMPS in one line, and the path is the same.
arc = os.path.join(args.work_dir, "arc.yaml")
with open(arc, "w") as f:
    f.write("""sections: [{name: s, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5}]
nodes: {root: [0, 0, 0], tip: [100, 0, 0]}
beams: [{name: beam, section: s, from: root, to: tip, elements: 200}]
supports: [{nodes: root, fix: all}]
loads: [{nodes: tip, force: [0, 300, 600]}]
probes: [{name: tip, node: tip}]
analysis: {type: static, control: arc_length, end_time: 1, initial_step: 0.05, max_step: 0.1}
""")
HANDOVER_LINE = "a linear solve of the arc-length corrector's iteration 1 failed with the banded LU, which does not pivot between nodes"
paths = {}
for label, options, ranks, package, handovers in (("default, 1 rank", [], 1, "petsc", 0), ("MUMPS, 1 rank", ["-analysis_direct_solver", "mumps"], 1, "mumps", 0),
                                                  ("failed banded LU, 1 rank", ["-path_pc_factor_zeropivot", "1e300"], 1, "mumps", 1),
                                                  ("default, 2 ranks", [], 2, "mumps", 0)):
    output = os.path.join(args.work_dir, f"arc_{len(paths)}.h5")
    _, stdout, _ = mt.run_msflex(args, arc, output, extra=[*options, "-path_ksp_view"], np_ranks=ranks)
    named = re.findall(r"package used to perform factorization: (\w+)", stdout)
    check.true(f"arc length, {label}: the corrector's last factorisation is {package}'s ({named[-1:]})", bool(named) and named[-1] == package)
    check.equal(f"arc length, {label}: lines handing the corrector's LU over to MUMPS", sum(HANDOVER_LINE in line for line in stdout.splitlines()), handovers)
    paths[label] = mt.history(output)
for label in list(paths)[1:]:
    worst = max(float(np.abs(paths[label][s] - paths["default, 1 rank"][s]).max() / np.abs(paths["default, 1 rank"][s]).max())
                for s in ("tip.position.x", "tip.position.y", "tip.position.z", "load_factor"))
    print(f"arc length, {label} against the default: largest difference relative to each series' largest value {worst:.2e}")
    check.less(f"arc length, {label}: the default's path", worst, 1e-9)

# Newton's retry with MUMPS, on one rank (more ranks factor by MUMPS from the start).
NEWTON_HANDOVER = "with the banded LU, which does not pivot between nodes"
pendulum = f"{args.source_dir}/tests/regression/inputs/beam_pendulum.yaml"
arm = f"{args.source_dir}/input/turning_arm_screw.yaml"
LONG_STEPS = ["-jacobian_dense_below", "0", "-analysis_max_newton_iterations", "3", "-analysis_initial_step", "0.05", "-analysis_max_step", "0.05"]
retries, newton_all = {}, {}
for label, model, options, hands_over in (("a banded LU failed at every pivot", arm, ["-analysis_end_time", "0.1", "-pc_factor_zeropivot", "1e300"], True),
                                          ("steps too long for 3 iterations", pendulum, LONG_STEPS, False),
                                          ("steps too long for 3 iterations, MUMPS", pendulum, [*LONG_STEPS, "-analysis_direct_solver", "mumps"], None)):
    output = os.path.join(args.work_dir, f"retry_{len(retries)}.h5")
    _, stdout, _ = mt.run_msflex(args, model, output, extra=[*options, "-checkpoint_every", "1"], np_ranks=1)
    summary = re.search(r"steps\s+(\d+) accepted, (\d+) rejected", stdout)
    rejected = int(summary.group(2)) if summary else -1
    attempts = re.search(r"Newton iterations\s+\d+ in accepted steps, (\d+) in all attempts", stdout)
    newton_all[label] = int(attempts.group(1)) if attempts else -1
    lines = [line for line in stdout.splitlines() if NEWTON_HANDOVER in line]
    print(f"Newton retry, {label}: {rejected} rejected; {lines}")
    retries[label] = mt.history(output)
    if hands_over is None:
        continue
    check.equal(f"Newton retry, {label}: lines handing the LU over to MUMPS", len(lines), 1 if hands_over else 0)
    check.true(f"Newton retry, {label}: the line ends 'MUMPS converged: MUMPS factors from here on'",
               all(line.endswith("and MUMPS converged: MUMPS factors from here on") for line in lines))
    if not hands_over:
        check.greater(f"Newton retry, {label}: rejected steps", rejected, 0)
    with h5py.File(output[:-3] + ".ckpt.h5", "r") as f:
        recorded = bool(f["run/pivoting_lu"][0])
    check.true(f"Newton retry, {label}: the checkpoint records MUMPS ({recorded}) exactly when it took over", recorded == hands_over)
both = ("steps too long for 3 iterations", "steps too long for 3 iterations, MUMPS")
worst = max(float(np.abs(retries[both[0]][s] - retries[both[1]][s]).max() / np.abs(retries[both[1]][s]).max()) for s in ("tip.position.x", "tip.position.y"))
check.less("Newton retry, steps too long: the tip's path against MUMPS' own run", worst, 1e-9)
# Each rejected step was tried with the banded LU, then with MUMPS: more Newton iterations in all
# attempts than MUMPS' own run, which tries each once.
check.greater("Newton retry, steps too long: Newton iterations in all attempts beyond MUMPS' own run", newton_all[both[0]] - newton_all[both[1]], 0)
check.finish()
