"""The README's shell command blocks (```sh) run top to bottom as written, in a scratch copy of the
repository (the files git tracks, plus new files not ignored), each with exit status 0.

With MSFLEX_README_BUILD_DIR set (ctest sets it to its own build directory), the copy's build/ is
a link to that directory, so that the README's commands (scripts/msflex builds when needed) find
an up-to-date build instead of building for minutes; without it they build in the copy.
`scripts/test` is not run: it runs the test suite, and with it this test. Commands run under
bash from the copy's root, with Open MPI allowed to run as root and to oversubscribe the cores
(the README's `mpirun -n 4` on a smaller machine)."""

import os
import re
import shutil
import subprocess
import sys
import time

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("README commands")
readme = open(os.path.join(args.source_dir, "README.md")).read()
blocks = re.findall(r"^```sh\n(.*?)^```", readme, flags=re.S | re.M)
commands = []
for block in blocks:
    pending = ""
    for line in block.splitlines():
        pending += line.rstrip()
        if pending.endswith("\\"):
            pending = pending[:-1] + " "
            continue
        if pending.strip() and not pending.strip().startswith("#"):
            commands.append(pending.strip())
        pending = ""
check.true(f"at least 1 README command block ({len(blocks)})", len(blocks) >= 1)
check.true(f"at least 1 README command ({len(commands)})", len(commands) >= 1)

scratch = os.path.join(args.work_dir, "scratch")
shutil.rmtree(scratch, ignore_errors=True)
os.makedirs(scratch)
listed = subprocess.run(["git", "-C", args.source_dir, "ls-files", "-z", "--cached", "--others", "--exclude-standard"], capture_output=True, check=True)
for path in sorted(set(filter(None, listed.stdout.decode().split("\0")))):
    source = os.path.join(args.source_dir, path)
    if not os.path.isfile(source) or path.startswith("build/"):
        continue
    os.makedirs(os.path.dirname(os.path.join(scratch, path)) or scratch, exist_ok=True)
    shutil.copy2(source, os.path.join(scratch, path))
build_dir = os.environ.get("MSFLEX_README_BUILD_DIR")
if build_dir:
    os.symlink(os.path.abspath(build_dir), os.path.join(scratch, "build"))
environment = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
for command in commands:
    if command.split()[0] == "scripts/test":
        print(f"skip {command}: runs the test suite, this test among it")
        continue
    started = time.monotonic()
    result = subprocess.run(["bash", "-c", command], cwd=scratch, env=environment, capture_output=True, text=True, timeout=1800)
    seconds = time.monotonic() - started
    print(f"exit {result.returncode} in {seconds:.1f} s: {command}")
    if result.returncode != 0:
        sys.stdout.write(result.stdout[-3000:] + result.stderr[-3000:])
    check.equal(f"exit status of: {command}", result.returncode, 0)
check.finish()
