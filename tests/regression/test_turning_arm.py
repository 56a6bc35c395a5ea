"""The turning arm with a screw joint (input/turning_arm_screw.yaml; the paper's §5.1, Fig. 6):
with dt = 0.02 Newmark's energy grows until the run stops (non-zero exit, the stop message)
before t = 4 s, having written its results so far; em runs to the end with its total energy
constant to 1e-8 relative; mc runs to the end too; with the exact tangent no step of em or mc
is rejected because the linear solver failed. The screw translation equals pitch x angle."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("turning arm")
source = f"{args.source_dir}/input/turning_arm_screw.yaml"

output = f"{args.work_dir}/newmark.h5"
code, _, stderr = mt.run_msflex(args, source, output, extra=["-analysis_integrator", "newmark", "-quiet"], expect_success=False)
h = mt.history(output)
energy = h["total_energy"]
print(f"newmark: exit {code}, last converged t = {h['time'][-1]:.4f}, energy {energy[0]:.3f} -> max {energy.max():.4g}")
check.true("newmark: exit status 1", code == 1)
check.less("newmark: stops before t = 4 (last time / 4)", h["time"][-1] / 4.0, 1.0)
check.less("newmark: energy grows (initial / max energy)", energy[0] / energy.max(), 0.5)
check.true("newmark: stop message printed", "stopped at t =" in stderr)

for integrator in ("em", "mc"):
    output = f"{args.work_dir}/{integrator}.h5"
    _, stdout, _ = mt.run_msflex(args, source, output, extra=["-analysis_integrator", integrator, "-progress_every", "1000000"])
    rejections = [line for line in stdout.splitlines() if "rejected:" in line]
    linear_failures = [line for line in rejections if "linear solver" in line]
    h = mt.history(output)
    energy = h["total_energy"]
    drift = np.abs(energy - energy[0]).max() / energy[0]
    print(f"{integrator}: reached t = {h['time'][-1]:.4f} in {len(energy) - 1} steps, energy drift {drift:.3e}")
    check.less(f"{integrator}: runs to the end (4.5 - t_end)", 4.5 - h["time"][-1], 1e-9)
    # The exact tangent leaves Newton's own divergence as the only reason to halve a step.
    print(f"{integrator}: {len(rejections)} rejected steps, {len(linear_failures)} of them by the linear solver")
    check.true(f"{integrator}: no step rejected because the linear solver failed", not linear_failures)
    if integrator == "em":
        check.less("em: total energy max deviation / energy", drift, 1e-8)
    check.less(f"{integrator}: max |screw translation - pitch x angle|", np.abs(h["screw.tx"] + 0.05 * h["screw.rx"]).max(), 1e-12)
check.finish()
