"""Numerical trouble through the executable, serially and on --np ranks: a step whose residual is
NaN/Inf or overflows, and a singular tangent (factored by MUMPS, and on one rank with a dense
tangent, -jacobian_dense_below 128, by msflex's dense LU), are rejected and
halved with a message naming
the node involved, and the run then stops with exit status 1, one message naming the step's time,
the reason and the node, and the results and a checkpoint written up to the last converged state
(no PETSc trace-back, no hang). With the default choice of the direct solver a sparse tangent on one
rank is first factored by msflex's block LU (banded, by node blocks), which stops at the zero pivot;
the step is tried again with MUMPS, which fails as well, so nothing is handed over (before, the run
was handed to MUMPS and said so); with -analysis_direct_solver mumps, and on more ranks, MUMPS
factors from the start."""

import os

import h5py

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("numerical trouble reports")
MUMPS = "the tangent is singular (MUMPS INFOG(1) = -10"
DENSE = "the tangent is singular (zero pivot in column "
# (input, options, the factorisation's phrase on one rank / on more, other phrases, the failed step)
HANDOVER = "with the banded LU, which does not pivot between nodes (the tangent is singular (zero pivot in the diagonal block of unknowns"
# (input, options, the factorisation's phrase on one rank / on more, other phrases, the failed
# step, whether one rank hands the banded LU over to MUMPS)
cases = [("overflowing_load.yaml", [], None, ["the residual is NaN at node 'tip', in its load", "the residual norm overflows", "node 'tip' uy"], "t = 1",
          False),
         ("unresisted_rotation.yaml", ["-jacobian_dense_below", "128"], (DENSE, MUMPS), ["nothing resists node 'loose' rx"], "t = 0.005", False),
         ("unresisted_rotation.yaml", [], (MUMPS, MUMPS), ["nothing resists node 'loose' rx"], "t = 0.005", False),
         ("unresisted_rotation.yaml", ["-jacobian_dense_below", "0", "-analysis_direct_solver", "mumps"], (MUMPS, MUMPS),
          ["nothing resists node 'loose' rx"], "t = 0.005", False),
         # A mechanism in statics: on more ranks MUMPS factors the nearly singular tangent and the
         # step turned by 4541 rad, which the stop reported without the hint the banded LU's gave.
         ("loose_hinge_static.yaml", [], None, ["is part of the model a mechanism"], "t = ", False),
         # An error raised inside the solver (-snes_type ngmres: its SVD fails) is a failed attempt:
         # halved, then the stop (before: a PETSc trace, MPI_Abort, no history row written).
         ("beam_pendulum.yaml", ["-snes_type", "ngmres"], None, ["the nonlinear solver raised an error: SVD generated inconsistent output"], "t = ",
          False)]
for case, (name, options, factorisation, common_phrases, failed_time, hands_over) in enumerate(cases):
    source = f"{args.source_dir}/tests/regression/inputs/{name}"
    for ranks in sorted({1, args.np}):
        phrases = common_phrases + ([factorisation[0 if ranks == 1 else 1]] if factorisation else [])
        label = name + (" " + " ".join(options) if options else "")
        output = f"{args.work_dir}/{name[:-5]}_{case}_{ranks}.h5"
        code, stdout, stderr = mt.run_msflex(args, source, output, np_ranks=ranks, expect_success=False, extra=options)
        stop = [line for line in stderr.splitlines() if line.startswith("msflex:") and "stopped at" in line]
        text = stdout + stderr
        print(f"np {ranks} {label}: exit {code}: {stop[0][:400] if stop else stderr[-400:]}")
        check.equal(f"np {ranks} {label}: exit status", code, 1)
        check.equal(f"np {ranks} {label}: stop messages", len(stop), 1)
        check.equal(f"np {ranks} {label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)
        for phrase in phrases:
            check.true(f"np {ranks} {label}: the message has {phrase!r}", phrase in text)
        handovers = [line for line in stdout.splitlines() if HANDOVER in line and line.endswith("MUMPS factors from here on")]
        check.equal(f"np {ranks} {label}: lines handing the banded LU over to MUMPS", len(handovers), 1 if hands_over and ranks == 1 else 0)
        check.true(f"np {ranks} {label}: the stop message has 'the step to {failed_time}'",
                   bool(stop) and f"the step to {failed_time}" in stop[0])
        with h5py.File(output, "r") as f:
            frames = mt.frame_count(f)
        check.true(f"np {ranks} {label}: at least 1 frame in the result file ({frames})", frames >= 1)
        check.true(f"np {ranks} {label}: checkpoint written", os.path.exists(output[:-3] + ".ckpt.h5"))

# A bending stiffness of 1e308 (EI2 and EI3 alike): the stability estimate's scaled start vector has
# no finite length. It ended the run with PETSc's trace and MPI_ABORT (exit 62); the estimate is
# now unknown (NaN) and the run goes on.
for stiffness in ("EI2", "EI3"):
    model = f"{args.work_dir}/huge_{stiffness}.yaml"
    section = {"EI2": 100.0, "EI3": 100.0}
    section[stiffness] = "1e308"
    with open(model, "w") as f:
        f.write("sections:\n  - {name: rod, EA: 1.0e4, GA2: 1.0e4, GA3: 1.0e4, GJ: 200, " + f"EI2: {section['EI2']}, EI3: {section['EI3']}" + "}\n"
                "nodes: {root: [0, 0, 0], tip: [10, 0, 0]}\nbeams: [{name: arm, section: rod, from: root, to: tip, elements: 4}]\n"
                "supports: [{nodes: root, fix: all}]\nloads: [{nodes: tip, force: [0, -1, 0]}]\nanalysis: {type: static, end_time: 1.0, initial_step: 0.5}\n")
    for ranks in sorted({1, args.np}):
        code, _, stderr = mt.run_msflex(args, model, f"{args.work_dir}/huge_{stiffness}.h5", np_ranks=ranks, expect_success=False, extra=["-quiet"])
        print(f"np {ranks} {stiffness} 1e308: exit {code}, stderr {stderr.strip()[:200]!r}")
        check.true(f"np {ranks} {stiffness} 1e308: completes (exit 0)", code == 0)
        check.true(f"np {ranks} {stiffness} 1e308: no PETSc trace", "PETSC ERROR" not in stderr)
check.finish()
