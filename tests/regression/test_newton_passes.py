"""One pass over the model per Newton iteration (docs/solvers.md): outside em, msflex's line
search assembles the residual of the new iterate together with the tangent there, and the last
iteration of a converged step, predicted from quadratic convergence, the residual alone.

1. The 40-element dynamic cantilever of scripts/bench-dynamics (tip force switched on in 1 ms,
   20 steps of 10 ms, 3 Newton iterations per step) with newmark, genalpha and mc: the element
   passes of the whole run (-log_view's AssembleResidual and AssembleJacobian events) are at most
   1.5 per Newton iteration (a residual pass and a tangent pass each, as before, would be more
   than 2), and the tangents assembled are at least the Newton iterations (each iteration solves
   with the tangent of its iterate). With em, whose tangent needs beta of the whole residual first,
   the one call visits the elements twice (-log_view's AssembleEmBeta, the forces and beta's sums,
   then AssembleJacobian), so there are two visits per iteration, and the residual is assembled
   alone (AssembleResidual) only for about the last iteration of each step, as in the other schemes.
2. PETSc's finite-difference checks of the tangent evaluate residuals between the tangent and its
   solve (-snes_compare_coloring, -snes_test_jacobian_display_threshold): they must leave the
   matrix alone. The cantilever (genalpha) and a floating chain of joints (genalpha, relays
   excluded: -jacobian_dense_below 0 for coloring) give the same history with the check as
   without, to 1e-12 of each series' size, in the same Newton iterations."""

import re

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("Newton passes")


def event_count(stdout, event):
    """Calls of a -log_view event, summed over the stages."""
    return sum(int(count) for count in re.findall(rf"^{event}\s+(\d+)\s", stdout, re.MULTILINE))


# 1. Passes per Newton iteration.
for integrator in ("newmark", "genalpha", "mc", "em"):
    path = mt.write_dynamic_cantilever(f"{args.work_dir}/cantilever_{integrator}.yaml", integrator)
    output = f"{args.work_dir}/cantilever_{integrator}.h5"
    _, stdout, _ = mt.run_msflex(args, path, output, extra=["-log_view", "-quiet"])
    iterations = int(mt.history(output)["newton_iterations"].sum())
    residual_passes, tangent_passes = event_count(stdout, "AssembleResidual"), event_count(stdout, "AssembleJacobian")
    passes = (residual_passes + tangent_passes) / iterations
    print(f"{integrator}: {iterations} Newton iterations, {residual_passes} residual passes, {tangent_passes} tangent passes: {passes:.2f} per iteration")
    check.true(f"{integrator}: Newton iterations counted", iterations >= 40)
    check.true(f"{integrator}: a tangent for every Newton iteration", tangent_passes >= iterations)
    if integrator == "em":
        beta_passes = event_count(stdout, "AssembleEmBeta")
        steps = len(mt.history(output)["newton_iterations"]) - 1
        print(f"em: {beta_passes} visits for beta's sums, {steps} steps")
        check.true("em: beta's sums once for every tangent with its residual", beta_passes >= iterations - steps)
        check.less("em: element visits per Newton iteration", (residual_passes + tangent_passes + beta_passes) / iterations, 2.5)
        check.less("em: residuals assembled alone per step", residual_passes / steps, 1.5)
    else:
        check.less(f"{integrator}: element passes per Newton iteration", passes, 1.5)

# 2. Finite-difference checks of the tangent change nothing.
cases = [
    ("cantilever", f"{args.work_dir}/cantilever_genalpha.yaml", []),
    ("floating chain", f"{args.source_dir}/tests/regression/inputs/floating_chain.yaml", ["-analysis_integrator", "genalpha", "-analysis_end_time", "0.02"]),
]
for name, path, extra in cases:
    runs = {}
    for label, check_options in (("plain", []), ("coloring", ["-snes_compare_coloring"]), ("display threshold", ["-snes_test_jacobian_display_threshold", "1e-3"])):
        output = f"{args.work_dir}/fd_check_{name.replace(' ', '_')}_{label.replace(' ', '_')}.h5"
        mt.run_msflex(args, path, output, extra=["-quiet", "-jacobian_dense_below", "0"] + extra + check_options)
        runs[label] = mt.history(output)
    plain = runs["plain"]
    for label in ("coloring", "display threshold"):
        other = runs[label]
        check.equal(f"{name}, {label}: Newton iterations", int(other["newton_iterations"].sum()), int(plain["newton_iterations"].sum()))
        worst = 0.0
        for series, values in plain.items():
            if series in ("residual_norm",) or values.dtype.kind not in "fi":
                continue
            scale = max(np.abs(values).max(), 1e-300)
            worst = max(worst, float(np.abs(other[series] - values).max() / scale))
        check.less(f"{name}, {label}: largest difference of a series / its size", worst, 1e-12)
check.finish()
