"""Joint coordinates that go far (tests/regression/inputs/far_joints.yaml): a slider pushed to
8000 m and a hinge turned to 8000 rad by constant loads, newmark at 1 ms for 40,000 steps. The
slave's step is formed from the increments alone (docs/joints.md): before, q_n + dq rounded to
eps |q| and the inertia turned that staircase into a residual floor, and Newton stalled (the
slider at 2048 m, the hinge near 10^3 rad). Checks: the run completes every step without a
rejection, with at most 2 Newton iterations per step, and both coordinates follow the closed form
q = 5 t^2 (newmark integrates a constant acceleration exactly) to 1e-10 relative.

A flexible spoke on a slider started at 1000 m/s (inputs/far_flexible_slider.yaml), 3000 steps to
1.5 km with each integrator: the residual floors grow with the reach of the configuration
(Assembler::BeginStep), so no step is rejected (em stalled from 1.1 km on, 346 rejected steps), and
the slide follows 1000 t to 1e-12 relative."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("far joints")
_, h = mt.run_input(args, "far_joints")
t = h["time"]
check.true(f"the run reaches t = 40 ({t[-1]:.6g})", abs(t[-1] - 40.0) < 1e-9)
check.true(f"every step taken at 1 ms: {len(t) - 1} steps", len(t) - 1 == 40000)
check.less("Newton iterations per step, largest", float(np.max(h["newton_iterations"][1:])), 2.5)
for series in ("slide.tx", "hinge.rx"):
    exact = 5.0 * t * t
    check.less(f"{series}: largest relative difference to 5 t^2", float(np.max(np.abs(h[series][1:] - exact[1:]) / exact[1:])), 1e-10)
slider = f"{args.source_dir}/tests/regression/inputs/far_flexible_slider.yaml"
for integrator in ("em", "mc", "genalpha", "newmark"):
    output = f"{args.work_dir}/far_flexible_slider_{integrator}.h5"
    mt.run_msflex(args, slider, output, extra=["-quiet", "-analysis_integrator", integrator])
    s = mt.history(output)
    check.true(f"flexible slider, {integrator}: 3000 steps of 0.5 ms to t = 1.5, none rejected ({len(s['time']) - 1} rows to {s['time'][-1]:.6g})",
               abs(s["time"][-1] - 1.5) < 1e-9 and len(s["time"]) == 3001 and float(np.min(s["step_size"][1:])) > 5e-4 * (1 - 1e-9))
    check.less(f"flexible slider, {integrator}: largest |g.tx / (1000 t) - 1|", float(np.max(np.abs(s["g.tx"][1:] / (1000.0 * s["time"][1:]) - 1.0))), 1e-12)
check.finish()
