"""Jacobian matrix formats through the executable, serially and on --np ranks: -jacobian_mat_type
baij (blocks of 6 on the clamped bend and the bushing mount, whose unknowns are all in nodes'
blocks, else 1; -ksp_view says) and dense on one rank give the probe histories of the default aij to 1e-9 of the largest
displacement, on input/bend45.yaml (load control), input/massless_pendulum.yaml to t = 0.5
(dynamics with a joint and a rigid body: the projection of the initial velocities and the initial
accelerations solve with the tangent's format too) and input/von_mises_truss.yaml (arc length, whose
corrector has a solver of its own) and input/bushing_mount.yaml to t = 0.1 (a bushing couples two
nodes that no element joins: baij took its pattern from the elements and stopped with "new nonzero"); -jacobian_dense_below N makes the pendulum's tangent (13
unknowns) dense from N = 13 on, not at N = 12 (-ksp_view names the type), with the same answer;
modes (input/hinged_beam_modes.yaml) and buckling (euler_column.yaml) give aij's eigenvalues to
1e-9 with baij and dense; sbaij (one triangle of a symmetric matrix; the tangent is not symmetric), sell and is (types msflex
does not assemble into) and dense on more than one rank stop the run with exit status 1 and one
line 'msflex: bad option: -jacobian_mat_type ...' giving the reason, without a PETSc trace-back or
a crash.

The default type: a banded tangent whose unknowns are all in node blocks, factored by msflex's
block LU (one rank, analysis.direct_solver auto), is seqbaij with blocks of 6 (the flying spaghetti to
t = 0.5 with -jacobian_dense_below 0, and the clamped bend with -analysis_stability false), with
the history of -jacobian_mat_type aij to 1e-9; it stays aij where MUMPS factors it: on 2 ranks,
with -analysis_direct_solver mumps, with a package named (-pc_factor_mat_solver_type mumps), and in
statics with stability (the default: MUMPS counts the tangent's negative pivots)."""

import re

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("Jacobian matrix types")


def relative_difference(got, reference):
    """max |got - reference| / max |reference|; inf when the shapes differ."""
    if got.shape != reference.shape:
        return np.inf
    return np.abs(got - reference).max() / np.abs(reference).max()


bend = f"{args.source_dir}/input/bend45.yaml"
models = (("bend45", bend, "tip", []),
          ("massless_pendulum", f"{args.source_dir}/input/massless_pendulum.yaml", "bob", ["-analysis_end_time", "0.5"]),
          ("von_mises_truss", f"{args.source_dir}/input/von_mises_truss.yaml", "apex", []),
          ("bushing_mount", f"{args.source_dir}/input/bushing_mount.yaml", "box_centre", ["-analysis_end_time", "0.1"]))
for ranks in sorted({1, args.np}):
    for name, path, probe, extra in models:
        reference = None
        for mat_type in ("aij", "baij", "dense") if ranks == 1 else ("aij", "baij"):
            output = f"{args.work_dir}/{name}_{mat_type}_np{ranks}.h5"
            view = ["-ksp_view"] if mat_type == "baij" else []
            _, stdout, _ = mt.run_msflex(args, path, output, extra=["-jacobian_mat_type", mat_type, *extra, *view], np_ranks=ranks)
            if mat_type == "baij":
                # Blocks of 6 where every unknown is in a node's block (the clamped bend, the bushing
                # mount's clamped beam and free box): a joint's coordinate (the pendulum) or a partly
                # supported node (the truss) leaves blocks of 1.
                sizes = sorted({size or "1" for size in re.findall(r"type: (?:seq|mpi)baij\s+rows=\d+, cols=\d+(?:, bs=(\d+))?", stdout)})
                expected_size = "6" if name in ("bend45", "bushing_mount") else "1"
                check.true(f"{name}, np {ranks} baij: block size {expected_size} ({sizes})", sizes == [expected_size])
            displacement = mt.probe_history(output, probe)["displacement"]
            if reference is None:
                reference = displacement
                continue
            difference = relative_difference(displacement, reference)
            print(f"{name}, np {ranks} {mat_type}: {displacement.shape[0]} rows, largest {probe} difference from aij / max |u| = {difference:.3g}")
            check.less(f"{name}, np {ranks} {mat_type}: {probe} history difference from aij", difference, 1e-9)
    if ranks == 1:
        pendulum = f"{args.source_dir}/input/massless_pendulum.yaml"
        for below, expected in ((12, "seqaij"), (13, "seqdense")):
            output = f"{args.work_dir}/pendulum_dense_below_{below}.h5"
            _, stdout, _ = mt.run_msflex(args, pendulum, output, extra=["-analysis_end_time", "0.5", "-jacobian_dense_below", str(below), "-ksp_view"],
                                         np_ranks=1)
            types = sorted(set(re.findall(r"^\s*type: (seq\w+)", stdout, re.MULTILINE)))
            print(f"-jacobian_dense_below {below}: matrix types {types}")
            check.true(f"-jacobian_dense_below {below}: the tangent is {expected} ({types})", types == [expected])
            displacement = mt.probe_history(output, "bob")["displacement"]
            reference = mt.probe_history(f"{args.work_dir}/massless_pendulum_aij_np1.h5", "bob")["displacement"]
            difference = relative_difference(displacement, reference)
            check.less(f"-jacobian_dense_below {below}: bob history difference from aij", difference, 1e-9)
    # Eigenanalyses: the pencil assembled in the chosen format is converted for MUMPS' Cholesky
    # (it stopped with a PETSc trace-back before); the same eigenvalues as with aij.
    eigen_cases = (("modes", f"{args.source_dir}/input/hinged_beam_modes.yaml", "frequency", []),
                   ("buckling", f"{args.source_dir}/tests/regression/inputs/euler_column.yaml", "load_factor",
                    ["-analysis_type", "buckling", "-analysis_eigenvalues", "2"]))
    for name, path, series, extra in eigen_cases:
        values = {}
        for mat_type in ("aij", "baij", "dense") if ranks == 1 else ("aij", "baij"):
            output = f"{args.work_dir}/{name}_{mat_type}_np{ranks}.h5"
            mt.run_msflex(args, path, output, extra=["-jacobian_mat_type", mat_type, *extra], np_ranks=ranks)
            values[mat_type] = mt.history(output)[series]
        for mat_type in values:
            if mat_type == "aij":
                continue
            difference = relative_difference(values[mat_type], values["aij"])
            check.less(f"{name}, np {ranks} {mat_type}: {series} difference from aij (relative)", difference, 1e-9)
    for mat_type in ("sbaij", "sell", "is") if ranks == 1 else ("sbaij", "sell", "dense"):
        code, _, stderr = mt.run_msflex(args, bend, f"{args.work_dir}/never.h5", extra=["-jacobian_mat_type", mat_type], np_ranks=ranks, expect_success=False)
        lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
        label = f"np {ranks} {mat_type}"
        print(f"{label}: exit {code}: {lines[0] if lines else stderr.strip()[:300]}")
        check.equal(f"{label}: exit status", code, 1)
        check.equal(f"{label}: message lines", len(lines), 1)
        check.true(f"{label}: the message names the option", bool(lines) and "bad option: -jacobian_mat_type" in lines[0])
        reason = "not symmetric" if mat_type == "sbaij" else "runs on one rank only" if mat_type == "dense" else "assembles into aij, baij and dense only"
        check.true(f"{label}: the message gives the reason ({reason})", bool(lines) and reason in lines[0])
        check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)

# The default type: BAIJ exactly where the banded LU factors a tangent made of node blocks.
spaghetti = f"{args.source_dir}/input/flying_spaghetti.yaml"
default_cases = (("flying spaghetti", spaghetti, "B", ["-jacobian_dense_below", "0", "-analysis_end_time", "0.5"]),
                 ("bend45 without stability", bend, "tip", ["-jacobian_dense_below", "0", "-analysis_stability", "false"]))
for ranks in sorted({1, args.np}):
    for label, path, probe, extra in default_cases:
        outputs = {}
        for setting in ("default", "aij"):
            outputs[setting] = f"{args.work_dir}/default_type_{probe}_{setting}_np{ranks}.h5"
            chosen = ["-jacobian_mat_type", "aij"] if setting == "aij" else []
            _, stdout, _ = mt.run_msflex(args, path, outputs[setting], extra=[*extra, *chosen, "-ksp_view"], np_ranks=ranks)
            types = sorted(set(re.findall(r"^\s*type: ((?:seq|mpi)\w+)\s*\n\s*rows=\d+, cols=\d+(?:, bs=(\d+))?", stdout, re.MULTILINE)))
            expected = [("seqbaij", "6")] if ranks == 1 and setting == "default" else [("seqaij" if ranks == 1 else "mpiaij", "")]
            print(f"{label}, np {ranks}, {setting}: matrix types {types}")
            check.true(f"{label}, np {ranks}, {setting}: the tangent is {expected} ({types})", types == expected)
        reference = mt.probe_history(outputs["aij"], probe)["displacement"]
        displacement = mt.probe_history(outputs["default"], probe)["displacement"]
        difference = relative_difference(displacement, reference)
        check.less(f"{label}, np {ranks}: default type's {probe} history difference from aij", difference, 1e-9)
for label, extra in (("-analysis_direct_solver mumps", ["-analysis_direct_solver", "mumps"]),
                     ("-pc_factor_mat_solver_type mumps", ["-pc_factor_mat_solver_type", "mumps"]),
                     ("statics with stability", ["-analysis_stability", "true"])):
    path = bend if "stability" in label else spaghetti
    _, stdout, _ = mt.run_msflex(args, path, f"{args.work_dir}/default_type_mumps.h5",
                                 extra=["-jacobian_dense_below", "0", "-analysis_end_time", "0.5", *extra, "-ksp_view"], np_ranks=1)
    types = sorted(set(re.findall(r"^\s*type: (seq(?:b?aij|dense))\s*$", stdout, re.MULTILINE)))
    print(f"{label}: matrix types {types}")
    check.true(f"{label}: the tangent stays seqaij ({types})", types == ["seqaij"])
check.finish()
