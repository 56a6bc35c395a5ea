"""Modified Newton (-analysis_jacobian_reuse, docs/solvers.md) gives the same motion with fewer
factorisations.

A dynamic cantilever of 40 two-node elements (scripts/bench-dynamics' model: tip force switched on
in 1 ms, 20 steps of 10 ms, 3-4 full Newton iterations per step), with genalpha and em, once with
a new tangent every iteration and once with the factored tangent kept while each iteration cuts
the residual by 0.1 or more:
- the frames agree to 1e-6 of the largest displacement (both converge to the Newton tolerance);
- em's energy balance (energy - external work) stays constant to 1e-9 of the energy either way;
- the full run factors one tangent per Newton iteration, the modified run at most half as many
  (counted by -log_view's MatLUFactorNum or BlockLUFactor in the LinearSolve stage) and its summary line counts
  the tangents assembled and reused alike;
- a run that writes checkpoints starts on a new tangent after each, as its restart does: continued
  from its last checkpoint with `msflex --restart`, the result file is bitwise the uninterrupted
  one;
- a factor outside [0, 1) is one line and exit status 1, as an option and in the input."""

import re
import shutil

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("Jacobian reuse")


def factorisations(stdout):
    """Numeric LU factorisations in the LinearSolve stage of a -log_view report."""
    stage = stdout.split("--- Event Stage")
    for part in stage:
        if part.lstrip().split(":")[0].strip().isdigit() and "LinearSolve" in part.split("\n")[0]:
            # PETSc's or MUMPS' LU, or msflex's block LU (a banded tangent by node blocks, one rank)
            return sum(int(count) for count in re.findall(r"^(?:MatLUFactorNum|BlockLUFactor)\s+(\d+)", part, re.MULTILINE))
    raise SystemExit("no LinearSolve stage in -log_view")


for integrator in ("genalpha", "em"):
    path = mt.write_dynamic_cantilever(f"{args.work_dir}/cantilever_{integrator}.yaml", integrator)
    results = {}
    for label, extra in (("full", []), ("modified", ["-analysis_jacobian_reuse", "0.1"])):
        output = f"{args.work_dir}/cantilever_{integrator}_{label}.h5"
        _, stdout, _ = mt.run_msflex(args, path, output, extra=["-log_view"] + extra)
        history = mt.history(output)
        with h5py.File(output, "r") as f:
            position = f["frames/position"][()]
            displacement = f["frames/displacement"][()]
        iterations = int(history["newton_iterations"].sum())
        factored = factorisations(stdout)
        results[label] = (position, displacement, history, iterations, factored, stdout)
        print(f"{integrator} {label}: {iterations} Newton iterations, {factored} factorisations")
    position_full, displacement, history_full, iterations_full, factored_full, _ = results["full"]
    position_modified, _, history_modified, iterations_modified, factored_modified, stdout_modified = results["modified"]
    scale = np.abs(displacement).max()
    check.less(f"{integrator}: frames, max |x_modified - x_full| / max |u|", np.abs(position_modified - position_full).max() / scale, 1e-6)
    check.equal(f"{integrator}: full Newton factors a tangent per iteration", factored_full, iterations_full)
    check.less(f"{integrator}: modified Newton's factorisations per iteration", factored_modified / iterations_modified, 0.5)
    summary = re.search(r"tangents\s+(\d+) assembled and factored, (\d+) Newton iterations reused", stdout_modified)
    check.true(f"{integrator}: the summary counts the tangents", summary is not None)
    if summary:
        check.equal(f"{integrator}: tangents assembled (summary)", int(summary.group(1)), factored_modified)
        check.equal(f"{integrator}: tangents assembled + reused = Newton iterations", int(summary.group(1)) + int(summary.group(2)), iterations_modified)
    if integrator == "em":
        energy = np.abs(history_full["total_energy"]).max()
        for label, history in (("full", history_full), ("modified", history_modified)):
            balance = history["energy_balance"]
            check.less(f"em {label}: energy balance range / energy", np.ptp(balance[1:]) / energy, 1e-9)

# Restart with modified Newton: bitwise the uninterrupted run.
path = f"{args.work_dir}/cantilever_em.yaml"
continued, reference = f"{args.work_dir}/restart_em.h5", f"{args.work_dir}/restart_em_reference.h5"
checkpoint = f"{args.work_dir}/restart_em.ckpt.h5"
mt.run_msflex(args, path, continued, extra=["-quiet", "-analysis_jacobian_reuse", "0.1", "-checkpoint_every", "7", "-checkpoint_file", checkpoint])
shutil.copyfile(continued, reference)
with h5py.File(checkpoint, "r") as f:
    checkpoint_step = int(f["run/numbers"][0])
restart = mt.mpi_launcher(args.mpiexec, args.np) + [args.msflex, "--restart", checkpoint, "-quiet"]
result = mt.run_with_timeout(restart, args.work_dir, 300)
check.true("restart: completes", result is not None and result[2] == 0)
with h5py.File(continued, "r") as a, h5py.File(reference, "r") as b:
    differences = [float(np.abs(a["frames"][name][()] - b["frames"][name][()]).max()) for name in b["frames"] if a["frames"][name].shape == b["frames"][name].shape]
    same_shapes = all(a["frames"][name].shape == b["frames"][name].shape for name in b["frames"])
    history_difference = float(np.abs(a["history/values"][()] - b["history/values"][()]).max())
print(f"restart from step {checkpoint_step}: largest frame difference {max(differences):.3e}, history {history_difference:.3e}")
check.true(f"restart: checkpoint inside the run (step {checkpoint_step})", 0 < checkpoint_step < 20)
check.true("restart: the same frames", same_shapes)
check.less("restart: largest frame difference", max(differences), 1e-300)
check.less("restart: largest history difference", history_difference, 1e-300)

# A factor outside [0, 1): one line, exit status 1.
path = f"{args.work_dir}/cantilever_em.yaml"
status, stdout, stderr = mt.run_msflex(args, path, f"{args.work_dir}/bad.h5", extra=["-analysis_jacobian_reuse", "1.5"], expect_success=False)
check.equal("option 1.5: exit status", status, 1)
lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]  # not mpiexec's own report
check.equal("option 1.5: message lines", len(lines), 1)
check.true("option 1.5: the line names it", bool(lines) and "-analysis_jacobian_reuse must lie in [0, 1), got 1.5" in lines[0])
check.equal("option 1.5: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)
bad = f"{args.work_dir}/bad_reuse.yaml"
mt.write_dynamic_cantilever(bad, "em", extra="  jacobian_reuse: -0.2\n")
status, stdout, stderr = mt.run_msflex(args, bad, f"{args.work_dir}/bad.h5", expect_success=False)
check.equal("input -0.2: exit status", status, 1)
lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
check.equal("input -0.2: message lines", len(lines), 1)
check.true("input -0.2: the line names file, line and key", bool(lines) and "bad_reuse.yaml:21:" in lines[0] and "jacobian_reuse" in lines[0])
check.equal("input -0.2: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)
check.finish()
