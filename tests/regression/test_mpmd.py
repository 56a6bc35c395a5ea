"""Ranks started with different command lines (mpirun's MPMD form, `-n 1 msflex A : -n 1 msflex
B`): one line and a non-zero exit at once, before any file is written. Before, different output
files or options deadlocked in the first collective file open, and different inputs ran rank 0's
model without a word."""

import os
import subprocess

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("mpmd")
os.makedirs(args.work_dir, exist_ok=True)
inputs = f"{args.source_dir}/tests/regression/inputs"
pendulum, welded = f"{inputs}/beam_pendulum.yaml", f"{inputs}/welded_pendulum.yaml"
cases = {
    "different output files": ([pendulum, "-output_file", "o.h5"], [pendulum, "-output_file", "p.h5"]),
    "an option on one rank": ([pendulum, "-output_file", "o.h5"], [pendulum, "-output_file", "o.h5", "-analysis_end_time", "0.2"]),
    "different inputs": ([pendulum, "-output_file", "o.h5"], [welded, "-output_file", "o.h5"]),
}
for label, (first, second) in cases.items():
    for name in ("o.h5", "p.h5", "o.xmf", "p.xmf"):
        if os.path.exists(os.path.join(args.work_dir, name)):
            os.remove(os.path.join(args.work_dir, name))
    command = [args.mpiexec, "-n", "1", args.msflex] + first + [":", "-n", "1", args.msflex] + second
    try:
        result = subprocess.run(command, cwd=args.work_dir, capture_output=True, text=True, timeout=60)
        code, output = result.returncode, result.stdout + result.stderr
    except subprocess.TimeoutExpired:
        code, output = None, "no end within 60 s"
    lines = [line for line in output.splitlines() if line.startswith("msflex:")]
    print(f"{label}: exit {code}; {lines[:1]}")
    check.true(f"{label}: ends with a non-zero status", code not in (None, 0))
    check.true(f"{label}: one line says the ranks were started differently", len(lines) == 1 and "different arguments or options" in lines[0])
    check.true(f"{label}: no result file written", not any(os.path.exists(os.path.join(args.work_dir, n)) for n in ("o.h5", "p.h5")))
check.finish()
