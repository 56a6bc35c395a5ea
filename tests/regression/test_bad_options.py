"""Bad option values through the executable, serially and on --np ranks: a value that is not a
number, a step larger than max_step, a negative Newton tolerance, and -analysis_type static on a
free-flying dynamic model (which the reader only checked for dynamics), and a factorisation package
that does not exist (-pc_factor_mat_solver_type foo, found by PETSc only at the first
factorisation; -st_pc_factor_mat_solver_type foo for an eigenanalysis), a sidecar syntax that does
not exist (-output_xdmf xdmf4) and a negative -jacobian_dense_below each stop the run with
exit status 1 and one line 'msflex: bad option: ...' naming the option or the model's problem,
without a PETSc trace-back and without creating a result file."""

import os

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("bad option values")
bend = f"{args.source_dir}/input/bend45.yaml"
spaghetti = f"{args.source_dir}/input/flying_spaghetti.yaml"
cases = [(bend, ["-analysis_end_time", "abc"], "Input string abc has no numeric value"),
         (bend, ["-analysis_initial_step", "2"], "initial_step 2. is larger than max_step 1."),
         (bend, ["-analysis_newton_atol", "-1"], "-analysis_newton_atol must be >= 0"),
         (spaghetti, ["-analysis_type", "static"], "with -analysis_type static: " + spaghetti + ":"),
         (bend, ["-pc_factor_mat_solver_type", "foo"], "-pc_factor_mat_solver_type foo: no LU factorisation of that name"),
         (bend, ["-output_xdmf", "xdmf4"], "-output_xdmf must be xdmf3 or xdmf2, got 'xdmf4'"),
         (bend, ["-jacobian_dense_below", "-3"], "-jacobian_dense_below -3: must be >= 0")]
for source, options, expected in cases:
    for ranks in sorted({1, args.np}):
        output = f"{args.work_dir}/never_written.h5"
        if os.path.exists(output):
            os.remove(output)
        code, _, stderr = mt.run_msflex(args, source, output, extra=options, np_ranks=ranks, expect_success=False)
        lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
        label = f"np {ranks} {' '.join(options)}"
        print(f"{label}: exit {code}: {lines[0] if lines else stderr.strip()[:300]}")
        check.equal(f"{label}: exit status", code, 1)
        check.equal(f"{label}: message lines", len(lines), 1)
        check.true(f"{label}: the message has the expected text", bool(lines) and "bad option: " in lines[0] and expected in lines[0])
        check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)
        check.true(f"{label}: no result file created", not os.path.exists(output))
# The eigensolver's factorisation package (-st_pc_factor_mat_solver_type) is checked once SLEPc has
# read its options, after the result file (mesh only) is made: one line, exit 1, no trace.
modes = f"{args.source_dir}/input/hinged_beam_modes.yaml"
for ranks in sorted({1, args.np}):
    output = f"{args.work_dir}/modes_bad_package.h5"
    code, _, stderr = mt.run_msflex(args, modes, output, extra=["-st_pc_factor_mat_solver_type", "foo"], np_ranks=ranks,
                                    expect_success=False)
    lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
    label = f"np {ranks} modes -st_pc_factor_mat_solver_type foo"
    print(f"{label}: exit {code}: {lines[0] if lines else stderr.strip()[:300]}")
    check.equal(f"{label}: exit status", code, 1)
    check.equal(f"{label}: message lines", len(lines), 1)
    check.true(f"{label}: the message names the option",
               bool(lines) and "bad option: -st_pc_factor_mat_solver_type foo: no Cholesky factorisation of that name" in lines[0])
    check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)
check.finish()
