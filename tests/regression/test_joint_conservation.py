"""Conservation with joints (tests/regression/inputs/floating_chain.yaml): four free flexible
beams joined by a revolute, a spherical and a screw joint, spinning with no supports and no loads,
over at least 1000 steps:
 - em: total energy constant to 1e-8 relative; linear and angular momentum to 1e-10;
 - mc: both momenta to 1e-10;
 - both: the screw's translation equals pitch x angle to 1e-12 at every step (an exact
   constraint), and the joints really move (the screw turns by more than one radian)."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("conservation with joints")
source = f"{args.source_dir}/tests/regression/inputs/floating_chain.yaml"
for integrator in ("em", "mc"):
    output = f"{args.work_dir}/{integrator}.h5"
    mt.run_msflex(args, source, output, extra=["-analysis_integrator", integrator, "-quiet"])
    h = mt.history(output)
    steps = len(h["time"]) - 1
    print(f"{integrator}: {steps} steps, Newton iterations per step {h['newton_iterations'][1:].mean():.2f}")
    check.less(f"{integrator}: steps >= 1000 (1000 / steps)", 1000.0 / steps, 1.0 + 1e-12)
    for kind in ("linear", "angular"):
        p = np.stack([h[f"{kind}_momentum_{c}"] for c in "xyz"], axis=1)
        check.less(f"{integrator}: {kind} momentum max deviation / magnitude", np.abs(p - p[0]).max() / np.linalg.norm(p[0]), 1e-10)
    energy = h["total_energy"]
    drift = np.abs(energy - energy[0]).max() / energy[0]
    if integrator == "em":
        check.less("em: total energy max deviation / energy", drift, 1e-8)
    else:
        print(f"mc: energy max deviation {drift:.3e} (not claimed)")
    check.less(f"{integrator}: max |screw translation - pitch x angle|", np.abs(h["lead.tx"] - 0.05 * h["lead.rx"]).max(), 1e-12)
    check.less(f"{integrator}: the screw turns (1 / max |angle|)", 1.0 / np.abs(h["lead.rx"]).max(), 1.0)
check.finish()
