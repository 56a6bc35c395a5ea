"""Bad option values through the executable, serially and on --np ranks: a value that is not a
number, a step larger than max_step, a negative Newton tolerance, and -analysis_type static on a
free-flying dynamic model (which the reader only checked for dynamics), and a factorisation package
that does not exist (-pc_factor_mat_solver_type foo, found by PETSc only at the first
factorisation; -st_pc_factor_mat_solver_type foo for an eigenanalysis), a sidecar syntax that does
not exist (-output_xdmf xdmf4), a negative -jacobian_dense_below, a negative Newton iteration
limit or tolerance of PETSc's (-snes_max_it, -snes_rtol), an unknown ordering of the LU
(-pc_factor_mat_ordering_type foo) and an integer past 32 bits each stop the run with
exit status 1 and one line 'msflex: bad option: ...' naming the option or the model's problem,
without a PETSc trace-back and without creating a result file; so does an options file that cannot be read (-options_file), in
one line 'msflex: error: ...' naming it."""

import os

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("bad option values")
bend = f"{args.source_dir}/input/bend45.yaml"
spaghetti = f"{args.source_dir}/input/flying_spaghetti.yaml"
cases = [(bend, ["-analysis_end_time", "abc"], "-analysis_end_time: 'abc' is not a number"),
         (bend, ["-analysis_end_time"], "-analysis_end_time needs a value"),
         # a file or name without its value ("the checkpoint file name is empty"), a time past double
         (bend, ["-checkpoint_file"], "-checkpoint_file needs a value (FILE)"),
         (bend, ["-checkpoint_wall_time", "1e400"], "-checkpoint_wall_time must be a finite number of seconds >= 0"),
         (bend, ["-file_read_timeout", "1e300"], "-file_read_timeout must be a positive number of seconds up to 86400"),
         (bend, ["-analysis_max_newton_iterations", "2.5"], "-analysis_max_newton_iterations: '2.5' is not an integer"),
         (bend, ["-analysis_stability", "maybe"], "-analysis_stability: 'maybe' is not a logical value"),
         (bend, ["-analysis_output_times", "0.5,x"], "-analysis_output_times: '0.5,x' is not a comma-separated list of numbers"),
         (bend, ["-analysis_initial_step", "2"], "initial_step 2 is larger than max_step 1"),
         (bend, ["-analysis_newton_atol", "-1"], "-analysis_newton_atol must be >= 0"),
         # the controlled DOF's options outside displacement control (taken without a word before)
         (bend, ["-analysis_control_node", "nope"], "-analysis_control_node applies to displacement control (-analysis_control displacement), but the control is load"),
         (spaghetti, ["-analysis_control_dof", "ux"], "-analysis_control_dof applies to displacement control"),
         (bend, ["-analysis_step_tolerance", "1"], "-analysis_step_tolerance must lie in [0, 1), got 1"),
         (spaghetti, ["-analysis_type", "static"], "with -analysis_type static: " + spaghetti + ":"),
         (bend, ["-pc_factor_mat_solver_type", "foo"], "-pc_factor_mat_solver_type foo: no LU factorisation of that name"),
         (bend, ["-output_xdmf", "xdmf4"], "-output_xdmf must be xdmf3 or xdmf2, got 'xdmf4'"),
         (bend, ["-jacobian_dense_below", "-3"], "-jacobian_dense_below -3: must be >= 0"),
         # PETSc takes these and fails later with a trace (or, for the ordering, inside the first
         # factorisation, after the result file was made)
         (bend, ["-snes_max_it", "-1"], "-snes_max_it must be at least 1, got -1"),
         (bend, ["-snes_rtol", "-1"], "-snes_rtol must not be negative, got -1"),
         (bend, ["-pc_type", "lu", "-pc_factor_mat_ordering_type", "foo"], "-pc_factor_mat_ordering_type: no ordering named 'foo'"),
         # an integer past 32 bits, which PETSc's conversion wraps (99999999999 read as 1215752191)
         (bend, ["-analysis_max_newton_iterations", "99999999999"], "-analysis_max_newton_iterations: '99999999999' is out of range"),
         (bend, ["-output_every", "2147483648"], "-output_every: '2147483648' is out of range"),
         # PETSc's own conversions name the value alone ("Input string abc has no integer value"):
         # the option is named in front
         (bend, ["-snes_max_it", "abc"], "-snes_max_it abc: Input string abc has no integer value"),
         (bend, ["-jacobian_dense_below", "abc"], "-jacobian_dense_below abc: Input string abc has no integer value"),
         (bend, ["-analysis_max_rotation_increment", "4"], "-analysis_max_rotation_increment (max_rotation_increment) must be below pi, got 4"),
         (bend, ["-file_read_timeout", "-1"], "-file_read_timeout must be a positive number of seconds up to 86400 (a day), got -1")]
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
# The eigensolver's options (-eps_*, -st_*, its factorisation package) are read before any file is
# made: one line, exit 1, no trace, no result file; and a result file already there survives even
# with -output_overwrite (it was replaced before the eigensolver found the bad value).
modes = f"{args.source_dir}/input/hinged_beam_modes.yaml"
for ranks in sorted({1, args.np}):
    output = f"{args.work_dir}/modes_bad_package.h5"
    if os.path.exists(output):
        os.remove(output)
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
    check.true(f"{label}: no result file created", not os.path.exists(output))
# An options file that cannot be read: PetscInitialize stopped on it with a trace and MPI_Abort.
for ranks in sorted({1, args.np}):
    output = f"{args.work_dir}/never_written.h5"
    if os.path.exists(output):
        os.remove(output)
    missing = f"{args.work_dir}/no_such_options.txt"
    code, _, stderr = mt.run_msflex(args, bend, output, extra=["-options_file", missing], np_ranks=ranks, expect_success=False)
    lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
    label = f"np {ranks} -options_file (missing)"
    print(f"{label}: exit {code}: {lines[0] if lines else stderr.strip()[:300]}")
    check.equal(f"{label}: exit status", code, 1)
    check.true(f"{label}: one line naming the file", len(lines) == 1 and f"cannot read the options file '{missing}'" in lines[0])
    check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)
    check.true(f"{label}: no result file created", not os.path.exists(output))
kept = f"{args.work_dir}/modes_kept.h5"
mt.run_msflex(args, modes, kept, extra=["-quiet", "-output_overwrite"])
with open(kept, "rb") as f:
    before = f.read()
for options in (["-eps_type", "foo"], ["-st_pc_factor_mat_solver_type", "foo"]):
    code, _, stderr = mt.run_msflex(args, modes, kept, extra=["-output_overwrite", *options], expect_success=False)
    lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
    label = f"modes {' '.join(options)} over an existing result"
    print(f"{label}: exit {code}: {lines[0] if lines else stderr.strip()[:300]}")
    check.equal(f"{label}: exit status", code, 1)
    check.true(f"{label}: one line naming the bad value", len(lines) == 1 and "bad option: " in lines[0] and "foo" in lines[0])
    with open(kept, "rb") as f:
        check.true(f"{label}: the earlier result file is untouched", f.read() == before)
check.finish()
