"""Progress lines through the executable: with -progress_every N one line every N converged steps
(and at the last), each giving step, time, dt, Newton iterations, residual, energy, wall time and,
before the end, an estimate of the time left; -progress_interval S keeps at most one line per S
seconds of wall time but always prints the first and the last; -quiet prints none."""

import re

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("progress lines")
source = f"{args.source_dir}/input/flying_spaghetti.yaml"
pattern = re.compile(r"^step +(\d+) +t = (\S+) +dt = (\S+) +newton +(\d+) +\|R\| = (\S+) +energy = (\S+) +wall ([0-9.]+ s|\d+ min \d+ s|\d+ h \d+ min)(, left ~(\S+ s|\d+ min \d+ s|\d+ h \d+ min))?$")

def printed_steps(stdout):
    return [int(line.split()[1]) for line in stdout.splitlines() if line.startswith("step")]


_, stdout, _ = mt.run_msflex(args, source, f"{args.work_dir}/progress.h5",
                             extra=["-analysis_end_time", "0.55", "-progress_every", "10", "-progress_interval", "0"])
lines = [line for line in stdout.splitlines() if line.startswith("step")]
parsed = [pattern.match(line) for line in lines]
for line in lines[:2] + lines[-1:]:
    print(line)
steps = [int(m.group(1)) for m in parsed if m]
check.equal("lines not in the progress format", sum(m is None for m in parsed), 0)
check.true(f"steps printed {steps} are [10, 20, 30, 40, 50, 55]", steps == [10, 20, 30, 40, 50, 55])
check.equal("lines but the last without a time-left estimate", sum(m.group(8) is None for m in parsed[:-1] if m), 0)
check.true("no time-left estimate on the last line", bool(parsed) and parsed[-1] is not None and parsed[-1].group(8) is None)
# A wall-time interval longer than the run: the first and the last line only, counted in steps
# of progress_every when it is given (the interval's default, 1 s, is what an input may set too).
for every, expected in ((1, [1, 55]), (10, [10, 55])):
    _, limited, _ = mt.run_msflex(args, source, f"{args.work_dir}/limited.h5",
                                  extra=["-analysis_end_time", "0.55", "-progress_every", str(every), "-progress_interval", "1e6"])
    check.true(f"-progress_every {every} -progress_interval 1e6: steps printed {printed_steps(limited)} are {expected}", printed_steps(limited) == expected)
_, quiet, _ = mt.run_msflex(args, source, f"{args.work_dir}/quiet.h5", extra=["-analysis_end_time", "0.55", "-quiet"])
check.equal("-quiet: output lines", len([line for line in quiet.splitlines() if line.strip()]), 0)
check.finish()
