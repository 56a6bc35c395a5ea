"""Newton converges quadratically.

- Statics, input/bend45.yaml, first load step: with the residual norms r_k of -snes_monitor, the
  observed order p = log(r_{k+1}/r_k) / log(r_k/r_{k-1}) at the last iteration above round-off
  (r_{k+1} > 1e-13 r_0) is >= 1.8, and the step converges (r / r_0 < 1e-7; the solver's test is
  relative to the force level, see src/integrators/newton.hpp) in at most 8 iterations.
- The energy-momentum scheme (em) with its exact tangent, on the flying spaghetti (dt = 0.1, first
  20 steps) and the tutorial's turning arm (dt = 0.04, twice its own, first 10 steps: at its own
  step the predictor, which moves the screw at its rate, leaves Newton 4 iterations, the last of
  them already at the unknowns' round-off floor of about 1e-8 of e_0, so no iterate shows the
  asymptotic order): the order is measured on the error of
  the unknowns, e_k = |x_k - x_K| with x_K the converged increments of the step (the iterates come
  from -snes_monitor_solution in full precision), p_k = log(e_{k+1}/e_k) / log(e_k/e_{k-1}) at the last k with
  e_{k+1} > 1e-9 e_0 (the converged iterate carries round-off); the error is free of the units
  that mix forces and moments in the residual norm, whose round-off floor (1e-13 of r_0 on the
  turning arm) hides the asymptotic order. The median order over the steps is >= 1.8, and no step
  needs more than 10 iterations."""

import math
import re
import statistics

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
norm_line = re.compile(r"^\s*(\d+) SNES Function norm ([0-9.eE+-]+)")


def newton_histories(stdout):
    """Per Newton solve, the list of (residual norm, iterate or None)."""
    solves, current, values, reading = [], [], [], False
    for line in stdout.splitlines():
        match = norm_line.match(line)
        if match:
            if reading and current:
                current[-1] = (current[-1][0], np.array(values))
            reading = False
            if int(match.group(1)) == 0 and current:
                solves.append(current)
                current = []
            current.append((float(match.group(2)), None))
            continue
        if line.startswith("%Vec Object"):
            reading, values = True, []
            continue
        if reading and not line.startswith("%") and "=" not in line and "]" not in line:
            try:
                values.append(float(line.split()[0]))
            except (ValueError, IndexError):
                pass
    if reading and current:
        current[-1] = (current[-1][0], np.array(values))
    solves.append(current)
    return solves


def residual_order(norms):
    above_roundoff = [k for k in range(1, len(norms) - 1) if norms[k + 1] > 1e-13 * norms[0]]
    if not above_roundoff:
        return None
    k = above_roundoff[-1]
    return math.log(norms[k + 1] / norms[k]) / math.log(norms[k] / norms[k - 1])


def error_order(iterates):
    errors = [np.linalg.norm(x - iterates[-1]) for x in iterates]
    counted = [k for k in range(1, len(errors) - 1) if errors[k + 1] > 1e-9 * errors[0]]
    if not counted:
        return None
    k = counted[-1]
    return math.log(errors[k + 1] / errors[k]) / math.log(errors[k] / errors[k - 1])


check = mt.Checker("Newton convergence")
_, stdout, _ = mt.run_msflex(args, f"{args.source_dir}/input/bend45.yaml", f"{args.work_dir}/bend45_newton.h5", extra=["-snes_monitor"])
first = [r for r, _ in newton_histories(stdout)[0]]
print("bend45, first load step, Newton residual norms:", " ".join(f"{r:.3e}" for r in first))
check.less("bend45: iterations of the first step", len(first) - 1, 9)
check.less("bend45: final relative residual r / r_0", first[-1] / first[0], 1e-7)
order = residual_order(first)
print(f"bend45: observed order {order:.2f}")
check.less("bend45: 1 / observed order (order >= 1.8)", 1.0 / order, 1.0 / 1.8)

cases = [("flying spaghetti, em, dt = 0.1", "flying_spaghetti.yaml", ["-analysis_initial_step", "0.1", "-analysis_max_step", "0.1", "-analysis_end_time", "2"]),
         ("turning arm, em, dt = 0.04", "turning_arm_screw.yaml",
          ["-analysis_integrator", "em", "-analysis_initial_step", "0.04", "-analysis_max_step", "0.04", "-analysis_end_time", "0.4"])]
for label, example, options in cases:
    _, stdout, _ = mt.run_msflex(args, f"{args.source_dir}/input/{example}", f"{args.work_dir}/{example}_newton.h5",
                                 extra=["-snes_monitor", "-snes_monitor_solution", "ascii::ascii_matlab", *options])
    solves = [s for s in newton_histories(stdout) if len(s) > 1]
    orders = [p for p in (error_order([x for _, x in s]) for s in solves) if p is not None]
    print(f"{label}: {len(solves)} solves, iterations {min(len(s) - 1 for s in solves)}..{max(len(s) - 1 for s in solves)}, "
          f"observed orders {' '.join(f'{p:.2f}' for p in orders)}")
    check.true(f"{label}: at least 1 solve with an observed order ({len(orders)})", len(orders) >= 1)
    check.less(f"{label}: 1 / median observed order (order >= 1.8)", 1.0 / statistics.median(orders), 1.0 / 1.8)
    check.less(f"{label}: most Newton iterations of a step", max(len(s) - 1 for s in solves), 11)
check.finish()
