"""The turning arm with a screw joint (input/turning_arm_screw.yaml; the paper's §5.1, Fig. 6):
with dt = 0.02 Newmark's energy grows until the run stops (non-zero exit, the stop message)
before t = 4 s, having written its results so far; em runs to the end with its total energy
constant to 1e-8 relative; mc runs to the end too. The screw translation equals pitch x angle."""

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
check.less("newmark: |exit status - 1|", abs(code - 1), 0.5)
check.less("newmark: stops before t = 4 (last time / 4)", h["time"][-1] / 4.0, 1.0)
check.less("newmark: energy grows (initial / max energy)", energy[0] / energy.max(), 0.5)
check.less("newmark: stop message printed (0 = yes)", 0.0 if "stopped at t =" in stderr else 1.0, 0.5)

for integrator in ("em", "mc"):
    output = f"{args.work_dir}/{integrator}.h5"
    mt.run_msflex(args, source, output, extra=["-analysis_integrator", integrator, "-quiet"])
    h = mt.history(output)
    energy = h["total_energy"]
    drift = np.abs(energy - energy[0]).max() / energy[0]
    print(f"{integrator}: reached t = {h['time'][-1]:.4f} in {len(energy) - 1} steps, energy drift {drift:.3e}")
    check.less(f"{integrator}: runs to the end (4.5 - t_end)", 4.5 - h["time"][-1], 1e-9)
    if integrator == "em":
        check.less("em: total energy max deviation / energy", drift, 1e-8)
    check.less(f"{integrator}: max |screw translation - pitch x angle|", np.abs(h["screw.tx"] + 0.05 * h["screw.rx"]).max(), 1e-12)
check.finish()
