"""Dynamics without max_step steps at initial_step (tests/regression/inputs/spring_slider.yaml, a
linear oscillator of period 1 s given only initial_step 0.01): 200 steps to t = 2, also with
-analysis_initial_step and -analysis_type dynamic on a static input, and the position follows
0.1 cos(2 pi t) to the trapezoidal rule's phase error. With -analysis_max_step the controller
grows the step after easy Newton steps, as before: fewer steps. Output times beyond end_time given
on the command line are dropped with one warning. Before, max_step defaulted to 1 s
in dynamics too and this oscillator grew to a step of one period, with no warning."""

import math
import re

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("dynamic default step")
source = f"{args.source_dir}/tests/regression/inputs/spring_slider.yaml"


def steps_of(stdout):
    return int(re.search(r"steps\s+(\d+) accepted", stdout).group(1))


def run(name, extra, input_file=source):
    output = f"{args.work_dir}/{name}.h5"
    _, stdout, _ = mt.run_msflex(args, input_file, output, extra=extra)
    return steps_of(stdout), mt.history(output)


steps, h = run("default", [])
check.true(f"200 steps of initial_step 0.01 to t = 2 ({steps})", steps == 200)
slide = h["slide.tx"]
exact = 0.1 * np.cos(2.0 * math.pi * h["time"])
# Newmark's phase error (omega dt)^2 / 12 per radian: 3.3e-4 rad a radian, 4.1e-3 rad after two
# periods, at most 4.1e-4 m of the 0.1 m amplitude (3.6e-4 measured).
check.less("largest |x - 0.1 cos(2 pi t)| [m]", np.abs(slide - exact).max(), 5e-4)

steps, _ = run("override", ["-analysis_initial_step", "0.02"])
check.true(f"-analysis_initial_step 0.02: 100 steps ({steps})", steps == 100)

steps, _ = run("grows", ["-analysis_max_step", "0.5"])
check.true(f"-analysis_max_step 0.5 lets the step grow: fewer than 200 steps ({steps})", steps < 200)

# A static input switched to dynamics on the command line steps at its initial_step as well.
static_input = f"{args.work_dir}/static_slider.yaml"
with open(source) as f:
    text = f.read().replace("type: dynamic", "type: static")
with open(static_input, "w") as f:
    f.write(text)
steps, _ = run("switched", ["-analysis_type", "dynamic"], static_input)
check.true(f"-analysis_type dynamic on a static input: 200 steps ({steps})", steps == 200)

# Output times beyond end_time from the command line are dropped, as documented, and now said in
# one warning line (they went without a word, where the same list in the input is an error).
output = f"{args.work_dir}/times.h5"
_, _, stderr = mt.run_msflex(args, source, output, extra=["-quiet", "-analysis_output_times", "0.505,3,4"])
warnings = [line for line in stderr.splitlines() if "output time(s) beyond end_time" in line]
print(warnings)
check.true("output times beyond end_time: one warning naming two dropped, the first 3",
           len(warnings) == 1 and "2 output time(s) beyond end_time = 2 are dropped (the first: 3)" in warnings[0])
check.true("the output time kept is a row", bool(np.any(np.abs(mt.history(output)["time"] - 0.505) < 1e-12)))
check.finish()
