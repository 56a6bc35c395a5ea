"""Relative output names of one character (input/bend45.yaml into `b`, checkpoints into `c`, run
from the work directory): under mpirun Open MPI's MPI_File_open failed on every one-character
name (MPI_ERR_OTHER), after -output_overwrite had replaced the old result with an empty file.
The run must complete, the result hold all its rows, and an -output_overwrite run replace it
with a complete one."""

import os

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("short output names")
command = mt.mpi_launcher(args.mpiexec, args.np) + [args.msflex, f"{args.source_dir}/input/bend45.yaml", "-output_file", "b", "-checkpoint_every", "2",
                                                     "-checkpoint_file", "c", "-quiet"]
for label, extra in (("first run", []), ("-output_overwrite", ["-output_overwrite"])):
    if label == "first run":
        for name in ("b", "b.xmf", "c"):
            try:
                os.remove(f"{args.work_dir}/{name}")
            except FileNotFoundError:
                pass
    result = mt.run_with_timeout(command + extra, args.work_dir, 300)
    check.true(f"{label}: completed on {args.np} rank(s) ({'hung' if result is None else result[1].strip()[:300]})", result is not None and result[2] == 0)
    h = mt.history(f"{args.work_dir}/b") if result is not None and result[2] == 0 else {}
    last = h["time"][-1] if "time" in h else float("nan")
    check.true(f"{label}: the result's last row is at t = 1 ({last})", abs(last - 1.0) < 1e-12)
check.finish()
