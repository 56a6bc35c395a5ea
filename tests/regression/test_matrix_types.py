"""Jacobian matrix formats through the executable (input/bend45.yaml, serially and on --np ranks):
-jacobian_mat_type baij (and dense on one rank) give the tip history of the default aij to 1e-9 of
the tip displacement; sbaij (one triangle of a symmetric matrix; the tangent is not symmetric), and
dense on more than one rank, stop the run with exit status 1 and one line
'msflex: bad option: -jacobian_mat_type ...', without a PETSc trace-back or a crash."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("Jacobian matrix types")
bend = f"{args.source_dir}/input/bend45.yaml"
for ranks in sorted({1, args.np}):
    reference = None
    for mat_type in ("aij", "baij", "dense") if ranks == 1 else ("aij", "baij"):
        output = f"{args.work_dir}/bend45_{mat_type}_np{ranks}.h5"
        mt.run_msflex(args, bend, output, extra=["-jacobian_mat_type", mat_type], np_ranks=ranks)
        tip = mt.probe_history(output, "tip")["displacement"]
        if reference is None:
            reference = tip
            continue
        difference = np.abs(tip - reference).max() / np.abs(reference).max() if tip.shape == reference.shape else np.inf
        print(f"np {ranks} {mat_type}: {tip.shape[0]} steps, largest tip difference from aij / max |u| = {difference:.3g}")
        check.less(f"np {ranks} {mat_type}: tip history difference from aij", difference, 1e-9)
    for mat_type in ("sbaij",) if ranks == 1 else ("sbaij", "dense"):
        code, _, stderr = mt.run_msflex(args, bend, f"{args.work_dir}/never.h5", extra=["-jacobian_mat_type", mat_type], np_ranks=ranks, expect_success=False)
        lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
        label = f"np {ranks} {mat_type}"
        print(f"{label}: exit {code}: {lines[0] if lines else stderr.strip()[:300]}")
        check.equal(f"{label}: exit status", code, 1)
        check.equal(f"{label}: message lines", len(lines), 1)
        check.true(f"{label}: the message names the option", bool(lines) and "bad option: -jacobian_mat_type" in lines[0])
        check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)
check.finish()
