"""Newton converges quadratically (input/bend45.yaml, first load step): with the residual norms
r_k printed by -snes_monitor, the observed order p_k = log(r_{k+1}/r_k) / log(r_k/r_{k-1}) of the
last iteration above round-off (r_{k+1} > 1e-13 r_0) is at least 1.8, and the step converges
(r / r_0 < 1e-7; the solver's test is relative to the force level, see src/integrators/newton.hpp)
in at most 8 iterations."""

import math
import re

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
_, stdout, _ = mt.run_msflex(args, f"{args.source_dir}/input/bend45.yaml", f"{args.work_dir}/bend45_newton.h5", extra=["-snes_monitor"])
pattern = re.compile(r"^\s*(\d+) SNES Function norm ([0-9.eE+-]+)")
steps, current = [], []
for line in stdout.splitlines():
    match = pattern.match(line)
    if not match:
        continue
    iteration, norm = int(match.group(1)), float(match.group(2))
    if iteration == 0 and current:
        steps.append(current)
        current = []
    current.append(norm)
steps.append(current)
first = steps[0]
print("first load step, Newton residual norms:", " ".join(f"{r:.3e}" for r in first))
check = mt.Checker("Newton convergence")
check.less("iterations of the first step", len(first) - 1, 9)
check.less("final relative residual r / r_0", first[-1] / first[0], 1e-7)
above_roundoff = [k for k in range(1, len(first) - 1) if first[k + 1] > 1e-13 * first[0]]
last = above_roundoff[-1]
order = math.log(first[last + 1] / first[last]) / math.log(first[last] / first[last - 1])
print(f"observed order at iteration {last}: {order:.2f}")
check.less("1 / observed order (order >= 1.8)", 1.0 / order, 1.0 / 1.8)
check.finish()
