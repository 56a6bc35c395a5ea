"""Error-controlled steps in dynamics (analysis.step_tolerance, docs/dynamics.md "Step size and
accuracy") on the spring slider (tests/regression/inputs/spring_slider.yaml, x = 0.1 cos(2 pi t)):
- newmark at tolerances 1e-2, 1e-3, 1e-4: more steps and a smaller error at every tenfold
  tightening; the error ratio (omega dt)^2 / 12 / tol aimed at 0.81 gives dt = 0.0157 at 1e-3,
  about 127 steps to t = 2 (checked within 100..160), and the step grows from initial_step 0.01
  (max_step defaults to end_time with a tolerance);
- a first step of 0.5 s is rejected by its error estimate (reason step_tolerance, "shortening")
  and the run completes within the same error as from 0.01;
- em follows the tolerance too (error below newmark's bound at 1e-3);
- a restart from a checkpoint continues the steps bitwise;
- a tolerance no step meets runs at min_step with one warning, also where a step is stretched to
  land on an output time;
- from rest under a load ramped from zero newmark, genalpha and em complete (the estimate's floor
  of motion) within 1e-3 m of the closed form;
- a tolerance outside [0, 1) is one line and exit 1, from the input and from the option."""

import math
import re
import subprocess

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("step tolerance")
source = f"{args.source_dir}/tests/regression/inputs/spring_slider.yaml"


def run(name, extra):
    output = f"{args.work_dir}/{name}.h5"
    _, stdout, _ = mt.run_msflex(args, source, output, extra=extra)
    h = mt.history(output)
    steps = int(re.search(r"steps\s+(\d+) accepted", stdout).group(1))
    error = np.abs(h["slide.tx"] - 0.1 * np.cos(2.0 * math.pi * h["time"])).max()
    return steps, error, stdout


results = {}
for tolerance in ("1e-2", "1e-3", "1e-4"):
    steps, error, _ = run(f"newmark_{tolerance}", ["-analysis_step_tolerance", tolerance])
    results[tolerance] = (steps, error)
    print(f"newmark step_tolerance {tolerance}: {steps} steps, largest |x - x_exact| {error:.3e} m")
for loose, tight in (("1e-2", "1e-3"), ("1e-3", "1e-4")):
    check.true(f"tolerance {loose} -> {tight}: more steps ({results[loose][0]} -> {results[tight][0]})", results[tight][0] > results[loose][0])
    check.true(f"tolerance {loose} -> {tight}: smaller error ({results[loose][1]:.3e} -> {results[tight][1]:.3e})", results[tight][1] < results[loose][1])
steps_1e3, error_1e3 = results["1e-3"]
check.true(f"tolerance 1e-3: 100..160 steps to t = 2 (dt about 0.0157 from (omega dt)^2/12 = 0.81e-3; {steps_1e3})", 100 <= steps_1e3 <= 160)
check.less("tolerance 1e-3: largest |x - x_exact| [m]", error_1e3, 5e-3)

steps, error, stdout = run("from_half_second", ["-analysis_step_tolerance", "1e-3", "-analysis_initial_step", "0.5"])
shortened = re.findall(r"rejected: the local error estimate is [0-9.e+-]+ times step_tolerance = 0.001; shortening", stdout)
print(f"from 0.5 s: {steps} steps, {len(shortened)} rejections by the estimate, error {error:.3e}")
check.true(f"a first step of 0.5 s is rejected by the error estimate ({len(shortened)} rejections)", len(shortened) >= 1)
check.less("from 0.5 s: largest |x - x_exact| [m]", error, 5e-3)
summary = re.search(r"^\s*steps\s+\d+ accepted, (\d+) rejected \((\d+) step_tolerance\)", stdout, re.M)
check.true(f"the summary counts the rejections by step_tolerance ({summary.group(0).strip() if summary else 'no summary line'})",
           summary is not None and int(summary.group(2)) == len(shortened))

steps, error, _ = run("em", ["-analysis_step_tolerance", "1e-3", "-analysis_integrator", "em"])
print(f"em step_tolerance 1e-3: {steps} steps, error {error:.3e}")
check.true(f"em at 1e-3: 100..160 steps ({steps})", 100 <= steps <= 160)
check.less("em at 1e-3: largest |x - x_exact| [m]", error, 5e-3)

# A restart continues the controlled steps bitwise: em at 1e-3 with checkpoints every 37 steps,
# restarted from the last (step 111 of 118), ends on the uninterrupted run's last row exactly (the
# controller's step, the rejection flag and the last step's length are in the checkpoint).
full = f"{args.work_dir}/em_checkpointed.h5"
checkpoint = f"{args.work_dir}/em_checkpointed.ckpt.h5"
mt.run_msflex(args, source, full, extra=["-quiet", "-analysis_step_tolerance", "1e-3", "-analysis_integrator", "em", "-checkpoint_every", "37",
                                         "-checkpoint_file", checkpoint])
uninterrupted = mt.history(full)
restarted = subprocess.run(mt.mpi_launcher(args.mpiexec, args.np) + [args.msflex, "--restart", checkpoint, "-quiet"], capture_output=True, text=True)
check.true(f"restart with step_tolerance: exit 0 ({restarted.stderr.strip()[:200]})", restarted.returncode == 0)
again = mt.history(full)
check.true(f"restart with step_tolerance: the same rows ({len(again['time'])} and {len(uninterrupted['time'])})", len(again["time"]) == len(uninterrupted["time"]))
if len(again["time"]) == len(uninterrupted["time"]):
    check.true("restart with step_tolerance: times and positions bitwise equal",
               bool(np.array_equal(again["time"], uninterrupted["time"]) and np.array_equal(again["slide.tx"], uninterrupted["slide.tx"])))

# From rest under a load ramped from zero (f(t) = t): the motion and the estimate both start as
# dt^3, so a measure relative to the motion alone never fell with the step and newmark stopped at
# t = 0; with the floor of motion every scheme completes, within 1e-3 m of
# x = (F/k) (t - sin(omega t)/omega) (amplitude 0.25 m).
with open(source) as f:
    ramp = f.read().replace("value: 0.1, rate: 0.0", "value: 0.0, rate: 0.0") + "loads:\n  - {nodes: mass, force: [10, 0, 0]}\n"
ramp_input = f"{args.work_dir}/ramp_from_rest.yaml"
with open(ramp_input, "w") as f:
    f.write(ramp)
k = 78.95683520871486
for integrator in ("newmark", "genalpha", "em"):
    output = f"{args.work_dir}/ramp_{integrator}.h5"
    code, stdout, _ = mt.run_msflex(args, ramp_input, output, expect_success=False,
                                    extra=["-analysis_step_tolerance", "1e-3", "-analysis_integrator", integrator])
    steps = re.search(r"steps\s+(\d+) accepted", stdout)
    print(f"ramp from rest, {integrator}: exit {code}, {steps.group(0) if steps else 'no summary'}")
    check.true(f"ramp from rest, {integrator}: completes", code == 0)
    if code == 0:
        h = mt.history(output)
        t = h["time"]
        exact = 10.0 / k * (t - np.sin(2.0 * math.pi * t) / (2.0 * math.pi))
        check.less(f"ramp from rest, {integrator}: largest |x - x_exact| [m]", np.abs(h["slide.tx"] - exact).max(), 1e-3)
        check.true(f"ramp from rest, {integrator}: fewer than 400 steps ({steps.group(1)})", int(steps.group(1)) < 400)

# A tolerance no step can meet: every step runs at min_step = initial_step = 0.01, accepted with one
# warning. Next to the output time 0.50005 the controller stretches the step to 0.01005 to land on
# it; that step counts as min_step (it looped for ever, rejected and retried at the same length).
command = [args.msflex, source, "-output_file", f"{args.work_dir}/at_min_step.h5", "-output_overwrite", "-quiet", "-analysis_step_tolerance", "1e-9",
           "-analysis_min_step", "0.01", "-analysis_end_time", "0.6", "-analysis_output_times", "0.50005"]
result = mt.run_with_timeout(command, args.work_dir, 60)
print(f"at min_step: {'hung' if result is None else f'exit {result[2]}: {result[1].strip()}'}")
check.true("a tolerance no step meets: the run ends (exit 0) at min_step", result is not None and result[2] == 0)
check.true("... with one warning of steps accepted at min_step", result is not None and result[1].count("are accepted whatever their estimate") == 1)
if result is not None and result[2] == 0:
    check.true("... and lands on the output time 0.50005", bool(np.any(np.abs(mt.history(f"{args.work_dir}/at_min_step.h5")["time"] - 0.50005) < 1e-12)))

for where, extra, text in (("option", ["-analysis_step_tolerance", "2"], None), ("input", [], "step_tolerance: -1")):
    path = source
    if text:
        path = f"{args.work_dir}/bad_tolerance.yaml"
        with open(source) as f:
            model = f.read().replace("initial_step: 0.01}", "initial_step: 0.01, " + text + "}")
        with open(path, "w") as f:
            f.write(model)
    result = subprocess.run([args.msflex, path, "-output_file", f"{args.work_dir}/bad.h5", "-output_overwrite"] + extra, capture_output=True, text=True)
    lines = [line for line in (result.stdout + result.stderr).splitlines() if line.strip()]
    print(f"bad tolerance from the {where}: exit {result.returncode}: {lines}")
    check.true(f"bad tolerance from the {where}: exit 1", result.returncode == 1)
    check.true(f"bad tolerance from the {where}: one line naming step_tolerance", len(lines) == 1 and "step_tolerance" in lines[0])
check.finish()
