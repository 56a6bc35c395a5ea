"""The command line (docs/options.md, "Checking options"), serially and on --np ranks:
- a misspelt msflex option (the 18 misspellings that were once ignored silently) stops the run
  before anything runs: exit 1, one line naming the nearest msflex option, no result file;
- a bad value of a PETSc option read by a PETSc object (-snes_type, -ksp_type, -pc_type) or of
  -partitioner: exit 1, one line 'msflex: bad option: ...', no PETSc trace;
- an unused PETSc option is warned about at the end, one line, and the run completes;
- -h and --help (also after the input file) print msflex's help, with the registries' analysis
  types, integrators and joint kinds, and exit 0 without running; --version (and -version) prints
  the version; a mistyped --verison names --version; a second input file, or an input given to a
  restart, is an error (exit 1, one line), not ignored;
- msflex --help into a pipe that closes early (| head -1) exits quietly, without PETSc's
  broken-pipe trace;
- the end-of-run summary: its step and Newton counts equal the result file's history;
- PETSc's viewer options still act during the steps (the loop turns PETSc's viewer lookups off
  only when no option asks for one): -snes_converged_reason prints one line per Newton solve,
  -ksp_converged_reason one per linear solve."""

import os

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("command line")
bend = f"{args.source_dir}/input/bend45.yaml"
top = f"{args.source_dir}/input/torque_free_top.yaml"
output = f"{args.work_dir}/cli.h5"
short_top = ["-analysis_end_time", "0.05"]


def run(source, options, ranks, expect_success=False):
    if os.path.exists(output):
        os.remove(output)
    command_input = [] if source is None else [source]
    # run_msflex puts the input first; for runs without an input use the raw runner below.
    if source is None:
        import subprocess
        command = ([args.mpiexec, "-n", str(ranks)] if ranks > 1 else []) + [args.msflex] + options
        result = subprocess.run(command, capture_output=True, text=True, timeout=300)
        return result.returncode, result.stdout, result.stderr
    return mt.run_msflex(args, command_input[0], output, extra=options, np_ranks=ranks, expect_success=expect_success)


# (options after the input, the input, the option the message must suggest)
misspellings = [(["-ouput_file", "x.h5"], bend, "-output_file"),
                (["-analysis_intgrator", "mc"], bend, "-analysis_integrator"),
                (short_top + ["-analysis_intgrator", "mc"], top, "-analysis_integrator"),
                (["-output_fiel", "x.h5"], bend, "-output_file"),
                (["-outputfile", "x.h5"], bend, "-output_file"),
                (["--output_file", "x.h5"], bend, "-output_file"),
                (["-output_evry", "4"], bend, "-output_every"),
                (["-output_overwite"], bend, "-output_overwrite"),
                (["-quite"], bend, "-quiet"),
                (["-analysis_end_tim", "0.5"], bend, "-analysis_end_time"),
                (["-analysis_endtime", "0.5"], bend, "-analysis_end_time"),
                (["-analysis-end-time", "0.5"], bend, "-analysis_end_time"),
                (["-analysis_initial_stp", "0.05"], bend, "-analysis_initial_step"),
                (["-analysis_newton_rtoll", "1e-6"], bend, "-analysis_newton_rtol"),
                (short_top + ["-analysis_integrator", "genalpha", "-analysis_spectral_radious", "0.5"], top, "-analysis_spectral_radius"),
                (["-analysis_max_rotation_incr", "0.1"], bend, "-analysis_max_rotation_increment"),
                (["-progres_every", "4"], bend, "-progress_every"),
                (["-checkpoint_evry", "2"], bend, "-checkpoint_every"),
                (["-partitoner", "simple"], bend, "-partitioner")]
for ranks in sorted({1, args.np}):
    for options, source, nearest in misspellings:
        code, stdout, stderr = run(source, options, ranks)
        lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
        label = f"np {ranks} {' '.join(options)}"
        print(f"{label}: exit {code}: {lines[0] if lines else stderr.strip()[:200]}")
        check.equal(f"{label}: exit status", code, 1)
        check.equal(f"{label}: message lines", len(lines), 1)
        check.true(f"{label}: the message names {nearest}", bool(lines) and f"did you mean {nearest}?" in lines[0])
        check.equal(f"{label}: steps run (progress lines)", sum(line.startswith("step ") for line in stdout.splitlines()), 0)
        check.true(f"{label}: no result file created", not os.path.exists(output))

    for options, what in [(["-snes_type", "nonsense"], "SNES"), (["-ksp_type", "nonsense"], "KSP"), (["-pc_type", "nonsense"], "PC"),
                          (["-partitioner", "nonsense"], "-partitioner")]:
        code, _, stderr = run(bend, options, ranks)
        # Under mpiexec, mpiexec adds its own report of the exit status; msflex's lines are its own.
        lines = [line for line in stderr.splitlines() if line.strip() and (ranks == 1 or line.startswith("msflex:"))]
        label = f"np {ranks} {' '.join(options)}"
        print(f"{label}: exit {code}: {lines[0] if lines else ''}")
        check.equal(f"{label}: exit status", code, 1)
        check.equal(f"{label}: stderr lines", len(lines), 1)
        check.true(f"{label}: the line is 'msflex: bad option: ...' naming the value",
                   bool(lines) and lines[0].startswith("msflex: bad option: ") and "nonsense" in lines[0] and what in lines[0])
        check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)

    code, _, stderr = run(bend, ["-snes_monitr"], ranks, expect_success=True)
    warnings = [line for line in stderr.splitlines() if line.startswith("msflex: warning:")]
    print(f"np {ranks} -snes_monitr: exit {code}: {warnings}")
    check.equal(f"np {ranks} unused PETSc option: exit status", code, 0)
    check.equal(f"np {ranks} unused PETSc option: warning lines", len(warnings), 1)
    check.true(f"np {ranks} unused PETSc option: the warning names it", bool(warnings) and "-snes_monitr" in warnings[0])

    for options, source in [(["-h"], None), (["--help"], None), (["-h"], bend), (["--help"], bend)]:
        code, stdout, stderr = run(source, options, ranks)
        label = f"np {ranks} {'INPUT ' if source else ''}{' '.join(options)}"
        print(f"{label}: exit {code}, {len(stdout.splitlines())} lines")
        check.equal(f"{label}: exit status", code, 0)
        for word in ["Usage: msflex INPUT.yaml", "-output_file", "-analysis_end_time", "Integrators", "genalpha", "Joint kinds", "revolute", "screw", "buckling"]:
            check.true(f"{label}: the help has '{word}'", word in stdout)
        check.equal(f"{label}: copies of the help printed", stdout.count("Usage: msflex"), 1)
        check.equal(f"{label}: steps run (progress lines)", sum(line.startswith("step ") for line in stdout.splitlines()), 0)
        check.true(f"{label}: no result file created", not os.path.exists(output))

    code, stdout, _ = run(None, ["--version"], ranks)
    print(f"np {ranks} --version: exit {code}: {stdout.strip()}")
    check.equal(f"np {ranks} --version: exit status", code, 0)
    check.true(f"np {ranks} --version: one line 'msflex VERSION (git HASH)'",
               len(stdout.splitlines()) == 1 and stdout.startswith("msflex ") and "(git " in stdout)

    code, stdout, stderr = run(None, ["-version"], ranks)
    check.true(f"np {ranks} -version: exit 0 with msflex's version line", code == 0 and any(line.startswith("msflex ") and "(git " in line
                                                                                         for line in stdout.splitlines()))
    # A misspelt word with two dashes after the input file ran the whole model (PETSc warned at the end).
    for options, fragment in [(["--verison"], "unknown argument --verison; did you mean --version?"),
                              ([bend, "--verison"], "unknown argument --verison; did you mean --version?"),
                              ([bend, "--threads", "4"], "unknown argument --threads: msflex's options have one dash"),
                              ([bend, bend], f"unexpected argument '{bend}': msflex takes one input file"),
                              (["--restart", "none.ckpt.h5", bend], f"unexpected argument '{bend}': a restart takes its input from the checkpoint")]:
        code, _, stderr = run(None, options, ranks)
        lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
        label = f"np {ranks} {' '.join(os.path.basename(o) for o in options)}"
        print(f"{label}: exit {code}: {lines}")
        check.equal(f"{label}: exit status", code, 1)
        check.true(f"{label}: one line saying what is wrong", len(lines) == 1 and fragment in lines[0])
        check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)

    # The summary against the result file.
    code, stdout, _ = run(top, short_top + ["-analysis_initial_step", "0.01"], ranks, expect_success=True)
    summary = stdout[stdout.index("msflex: summary"):] if "msflex: summary" in stdout else ""
    print(summary)
    h = mt.history(output)
    steps = len(h["time"]) - 1
    newton = int(np.sum(h["newton_iterations"]))
    balance = h["energy_balance"]
    check.true(f"np {ranks} summary printed", bool(summary))
    check.true(f"np {ranks} summary: steps = history rows - 1 ({steps})",
               f"steps              {steps} accepted, 0 rejected" in summary)
    check.true(f"np {ranks} summary: Newton iterations = sum of the history's ({newton})",
               f"Newton iterations  {newton} in accepted steps" in summary)
    for word in ["Krylov iterations", "energy drift", "wall time", "LinearSolve", "Output", "CPU time", "peak memory"]:
        check.true(f"np {ranks} summary has '{word}'", word in summary)
    drift = float(summary.split("energy drift")[1].split()[0]) if "energy drift" in summary else np.inf
    check.less(f"np {ranks} summary: |energy drift - history's| ({balance[-1] - balance[0]:.4g})", abs(drift - (balance[-1] - balance[0])),
               1e-3 * abs(balance[-1] - balance[0]) + 1e-12)
    code, stdout, _ = run(top, short_top + ["-quiet"], ranks, expect_success=True)
    check.equal(f"np {ranks} -quiet: summary lines", stdout.count("summary"), 0)

    # Viewer options during the steps: a line per solve (the initial accelerations' solve too).
    code, stdout, _ = run(top, short_top + ["-analysis_initial_step", "0.01", "-snes_converged_reason", "-ksp_converged_reason"], ranks,
                          expect_success=True)
    h = mt.history(output)
    steps, newton = len(h["time"]) - 1, int(np.sum(h["newton_iterations"]))
    nonlinear = stdout.count("Nonlinear solve converged")
    linear = stdout.count("Linear solve converged")
    print(f"np {ranks} -snes_converged_reason -ksp_converged_reason: {nonlinear} nonlinear and {linear} linear lines, {steps} steps, "
          f"{newton} Newton iterations")
    check.true(f"np {ranks} -snes_converged_reason: a line per step at least ({nonlinear} >= {steps})", nonlinear >= steps)
    check.true(f"np {ranks} -ksp_converged_reason: a line per Newton iteration at least ({linear} >= {newton})", linear >= newton)
# A reader closing the pipe early: PETSc's signal handler once printed a broken-pipe trace and
# aborted (one run in three to ten); twenty runs, every one quiet with exit status 0.
import subprocess  # noqa: E402
statuses, traces = [], 0
for _ in range(20):
    piped = subprocess.run(["bash", "-c", f"'{args.msflex}' --help 2>&1 | head -1 >/dev/null; echo ${{PIPESTATUS[0]}}"], capture_output=True,
                           text=True)
    statuses.append(piped.stdout.strip())
    traces += piped.stderr.count("PETSC ERROR")
print(f"msflex --help | head -1: exit statuses {statuses}")
check.true("msflex --help | head -1: exit status 0 every time", statuses == ["0"] * 20)
check.equal("msflex --help | head -1: PETSc trace-back lines", traces, 0)
check.finish()
