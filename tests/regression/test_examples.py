"""Every example in input/ is a test: each carries its expected results under `expected:`
(docs/input.md, "expected"), and this runs every example and checks them (msflex_testing.
check_expected). Every input/*.yaml must have at least one expected result.

By default the long dynamic examples are shortened with -analysis_end_time (SHORTENED below) and
only the expected results at times the shortened run reaches are checked; --full runs every
example to its own end_time and checks all of them. -output_every is set high: it changes which
frames are written, not the steps or the history, which every row holds."""

import glob
import os
import sys
import time

import msflex_testing as mt

# Quick runs: an end time the steps land on in the full run as well (an output time or a
# multiple of a constant step), so the rows up to it are the full run's.
SHORTENED = {"flying_spaghetti": 2.5, "spin_up": 5.0, "torque_free_top": 1.0, "cam_follower": 0.25, "rack_pinion": 0.5, "driven_screw": 0.3,
             "turning_arm_screw": 0.3, "rotating_shaft": 0.5}

full = "--full" in sys.argv
if full:
    sys.argv.remove("--full")
only = None
if "--only" in sys.argv:
    index = sys.argv.index("--only")
    only = sys.argv[index + 1].split(",")
    del sys.argv[index:index + 2]
args = mt.parse_arguments(__doc__)
check = mt.Checker("examples" + (" (full)" if full else ""))
examples = sorted(glob.glob(f"{args.source_dir}/input/*.yaml"))
check.true(f"at least 12 examples found ({len(examples)})", len(examples) >= 12)
for source in examples:
    name = os.path.basename(source)[:-5]
    if only and name not in only:
        continue
    entries = mt.expected_results(source)
    check.true(f"{name}: at least 1 expected result ({len(entries)})", len(entries) >= 1)
    end_time = None if full else SHORTENED.get(name)
    options = ["-output_every", "1000000", "-quiet"] + (["-analysis_end_time", str(end_time)] if end_time else [])
    output = f"{args.work_dir}/{name}.h5"
    started = time.monotonic()
    mt.run_msflex(args, source, output, extra=options)
    print(f"{name}: ran in {time.monotonic() - started:.1f} s ({' '.join(options)})")
    checked, skipped = mt.check_expected(check, source, output, name, end_time)
    check.true(f"{name}: at least 1 expected result checked ({checked})", checked >= 1)
check.finish()
