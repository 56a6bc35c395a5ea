"""`linear_solver: multigrid` (docs/solvers.md, "Large networks in statics"): GMRES with algebraic
multigrid on the nodes' rigid-body modes gives the direct solver's answer on lattice networks, and
its misuses stop with one line.

Answers (the final frame's nodal displacements, max norm, against the direct solve of the same
run, relative to the largest displacement), on --np ranks:
  - a 4 x 4 x 4 lattice in statics (two load steps, stability account off): 1e-7;
  - the same with a spherical joint at every third vertical member: 1e-7;
  - the lattice in generalized-alpha dynamics (5 steps of 1 ms; it moves by 7e-7 m): 1e-12 of the
    lattice's size of 1.5 m, the round-off of its coordinates.
Newton's linear solves go to the tolerance 1e-6 (inexact Newton); Newton's own residual test is
unchanged, so the answers agree to Newton's tolerance, not to round-off.
The solver is what was asked for: -ksp_view names GMRES and the multigrid preconditioner, and the
tangent of the lattice without joints has blocks of 6 (so aggregation keeps a node whole).
Errors, each one line naming the setting: multigrid in statics with the stability account; with
arc-length control; with -jacobian_mat_type baij; with relay nodes (a chain of joints deeper than
-analysis_condensation_depth); an unknown -analysis_linear_solver, and an unknown `linear_solver` in
the input (with its file and line)."""

import os
import subprocess

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("multigrid linear solver")
make_network = os.path.join(args.source_dir, "scripts", "make-network")


def network(name, *options):
    path = os.path.join(args.work_dir, f"{name}.yaml")
    subprocess.run([make_network, "lattice", "--n", "4", "4", "4", "--elements", "2", "-o", path, *options], check=True, capture_output=True)
    return path


def compare(label, model, extra, relative_to_size=False):
    """relative_to_size: the difference relative to the lattice's size (1.5 m) instead of the largest
    displacement, for a motion of a few hundred nanometres, where both answers differ at the
    round-off of the coordinates."""
    direct, multigrid = (os.path.join(args.work_dir, f"{label}_{kind}.h5") for kind in ("direct", "multigrid"))
    mt.run_msflex(args, model, direct, extra=["-quiet", *extra])
    _, stdout, _ = mt.run_msflex(args, model, multigrid, extra=["-analysis_linear_solver", "multigrid", "-ksp_view", *extra])
    a, b = mt.final_frame(direct)["displacement"], mt.final_frame(multigrid)["displacement"]
    if relative_to_size:
        check.less(f"{label}: max |u multigrid - u direct| / lattice size", np.abs(a - b).max() / 1.5, 1e-12)
    else:
        check.less(f"{label}: max |u multigrid - u direct| / max |u|", np.abs(a - b).max() / np.abs(a).max(), 1e-7)
    check.true(f"{label}: -ksp_view shows GMRES", "type: gmres" in stdout)
    check.true(f"{label}: -ksp_view shows ML or GAMG", "type: ml" in stdout or "type: gamg" in stdout)
    return stdout


statics = network("statics", "--static")
stdout = compare("statics", statics, ["-analysis_stability", "false"])
check.true("statics: the tangent has blocks of 6", "bs=6" in stdout)
compare("statics with joints", network("joints", "--static", "--joint-every", "3"), ["-analysis_stability", "false"])
compare("genalpha dynamics", network("dynamics", "--integrator", "genalpha"), ["-analysis_end_time", "0.005"], relative_to_size=True)


def expect_error(label, model, extra, *messages):
    code, stdout, stderr = mt.run_msflex(args, model, os.path.join(args.work_dir, "error.h5"), extra=extra, expect_success=False)
    lines = [line for line in stderr.splitlines() if line.strip()]
    check.true(f"{label}: fails", code != 0)
    for message in messages:
        check.true(f"{label}: says '{message}'", any(message in line for line in lines))
    check.true(f"{label}: no PETSc trace-back", "PETSC ERROR" not in stderr)


expect_error("stability account", statics, ["-analysis_linear_solver", "multigrid"],
             "'linear_solver: multigrid' in statics needs 'stability: false'")
expect_error("arc length", statics, ["-analysis_linear_solver", "multigrid", "-analysis_stability", "false", "-analysis_control", "arc_length"],
             "'linear_solver: multigrid' in statics needs 'control: load', not arc_length")
expect_error("baij", statics, ["-analysis_linear_solver", "multigrid", "-analysis_stability", "false", "-jacobian_mat_type", "baij"],
             "baij with -analysis_linear_solver multigrid: algebraic multigrid needs aij")
expect_error("gamg on baij", statics, ["-analysis_stability", "false", "-jacobian_mat_type", "baij", "-pc_type", "gamg", "-ksp_type", "gmres"],
             "baij with -pc_type gamg: algebraic multigrid needs aij")
expect_error("relays", f"{args.source_dir}/input/slider_crank.yaml",
             ["-analysis_linear_solver", "multigrid", "-analysis_condensation_depth", "1", "-analysis_end_time", "0.01"],
             "-analysis_linear_solver multigrid with relay nodes")
expect_error("unknown solver", statics, ["-analysis_linear_solver", "cholesky", "-analysis_stability", "false"],
             "bad option: -analysis_linear_solver must be direct or multigrid, got 'cholesky'")
with open(statics) as f:
    text = f.read()
bad_input = os.path.join(args.work_dir, "bad.yaml")
with open(bad_input, "w") as f:
    f.write(text.replace("analysis: {type: static,", "analysis: {linear_solver: cholesky, type: static,"))
line = 1 + text[:text.index("analysis:")].count("\n")
expect_error("unknown solver in the input", bad_input, [], f"bad.yaml:{line}:", "unknown linear_solver 'cholesky' in 'analysis'; expected direct or multigrid")
check.finish()
