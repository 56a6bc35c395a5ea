"""Bad input through the executable: every corpus file (tests/bad_input) on 1 rank and on --np
ranks. Each run must end within the time limit (no rank hangs) with exit status 1 on every rank,
print exactly one error line 'msflex: file:line:column: error: ...' naming the line of the file's
'# line:' header and holding its '# expect:' text, print no PETSc trace-back, and leave an output
file that already exists untouched (same bytes, same modification time) and create no other file.

On 1 rank the run writes to the default output (<input name>.h5 in the working directory, which is
there already); on --np ranks to an existing -output_file. Both pass -output_overwrite, so a run
that got as far as opening the output would replace it.

Under --np ranks each rank runs through a small wrapper that records the rank's own exit status and
exits 0, so mpiexec lets every rank finish by itself (by default it kills the others, after a
second's grace, as soon as one rank exits non-zero, which would hide a rank that never returns and
cost a second per run). A few files also run without the wrapper, for mpiexec's own exit status.
The runs go two at a time (they mostly wait on MPI start-up); --jobs changes that."""

import argparse
import concurrent.futures
import os
import re
import shutil
import sys
import time

import msflex_testing as mt

parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--msflex", required=True, help="path of the msflex executable")
parser.add_argument("--source-dir", required=True, help="repository root")
parser.add_argument("--work-dir", required=True, help="directory for this test's runs")
parser.add_argument("--mpiexec", default="mpiexec", help="MPI launcher")
parser.add_argument("--np", type=int, default=2, help="ranks of the parallel runs")
parser.add_argument("--jobs", type=int, default=2, help="runs at the same time")
parser.add_argument("--timeout", type=float, default=60.0, help="seconds before a run counts as hung")
parser.add_argument("--only", nargs="*", help="corpus file names to run (default: all)")
args = parser.parse_args()
args.msflex = os.path.abspath(args.msflex)

corpus = os.path.join(args.source_dir, "tests", "bad_input")
names = sorted(name for name in os.listdir(corpus) if name.endswith(".yaml"))
if args.only:
    names = [name for name in names if name in args.only]
# mpiexec's own exit status is checked (without the wrapper) on these.
PLAIN_MPIEXEC = {"section_EA_negative.yaml", "beam_unknown_section.yaml", "mechanism_no_supports.yaml", "yaml_syntax_error.yaml",
                 "mesh_file_missing.yaml"}
SENTINEL_TIME = 946684800  # 2000-01-01: a time no run can give a file it writes
STATUS_PREFIX = "rank-status."


def expectation(path):
    """The '# expect:' text and '# line:' number of a corpus file."""
    with open(path, encoding="utf-8", errors="surrogateescape") as f:  # a corpus file may hold invalid UTF-8 past its header
        first, second = f.readline(), f.readline()
    expect = re.match(r"#\s*expect:\s*(.*?)\s*$", first)
    line = re.match(r"#\s*line:\s*(\d+)\s*$", second)
    if not expect or not line:
        raise SystemExit(f"{path}: the first two lines must be '# expect: ...' and '# line: N'")
    return expect.group(1), int(line.group(1))


def make_sentinel(path):
    with open(path, "w") as f:
        f.write(f"sentinel {os.path.basename(path)}\n")
    os.utime(path, (SENTINEL_TIME, SENTINEL_TIME))


def run(name, ranks, plain):
    """Runs one corpus file; returns a list of failed checks (empty: all passed) and a summary."""
    path = os.path.join(corpus, name)
    expected_message, expected_line = expectation(path)
    stem = os.path.splitext(name)[0]
    run_dir = os.path.join(args.work_dir, f"np{ranks}{'-plain' if plain else ''}-{stem}")
    shutil.rmtree(run_dir, ignore_errors=True)
    os.makedirs(run_dir)
    if ranks == 1:
        sentinel = os.path.join(run_dir, stem + ".h5")  # the default output of the input
        output_options = ["-output_overwrite"]
    else:
        sentinel = os.path.join(run_dir, "existing.h5")
        output_options = ["-output_file", sentinel, "-output_overwrite"]
    make_sentinel(sentinel)
    command = [args.msflex, path] + output_options
    if ranks > 1:
        launcher = [args.mpiexec, "-n", str(ranks)]
        if ranks > (os.cpu_count() or 1):
            launcher.append("--oversubscribe")
        if not plain:
            # The rank's status to a file, then exit 0 so mpiexec waits for every rank.
            wrapper = f'"$@"; echo $? > {STATUS_PREFIX}${{OMPI_COMM_WORLD_RANK:-$PMI_RANK}}; exit 0'
            command = ["sh", "-c", wrapper, "sh"] + command
        command = launcher + command
    started = time.monotonic()
    result = mt.run_with_timeout(command, run_dir, args.timeout)
    if result is None:
        return [f"no result within {args.timeout:.0f} s (hang)"], "hung"
    stdout, stderr, returncode = result
    seconds = time.monotonic() - started
    failures = []
    if ranks > 1 and not plain:
        if returncode != 0:
            failures.append(f"mpiexec exit status {returncode} (the wrapper exits 0)")
        for rank in range(ranks):
            status_file = os.path.join(run_dir, f"{STATUS_PREFIX}{rank}")
            status = open(status_file).read().strip() if os.path.exists(status_file) else "none"
            if status != "1":
                failures.append(f"rank {rank} exit status {status}")
    elif returncode != 1:
        failures.append(f"exit status {returncode}")
    output = stdout + stderr
    error_lines = [line for line in output.splitlines() if line.startswith("msflex:") or "error" in line.lower()]
    if len(error_lines) != 1:
        failures.append(f"{len(error_lines)} error lines")
    located = re.compile(rf"^msflex: {re.escape(path)}:(\d+):(\d+): error: (.*)$")
    match = located.match(error_lines[0]) if error_lines else None
    if not match:
        failures.append("no line 'msflex: <file>:<line>:<column>: error: ...'")
    else:
        if int(match.group(1)) != expected_line:
            failures.append(f"line {match.group(1)}, expected {expected_line}")
        if expected_message not in match.group(3):
            failures.append(f"message lacks {expected_message!r}")
    if "PETSC ERROR" in output or "Traceback" in output:
        failures.append("trace-back printed")
    with open(sentinel, "rb") as f:
        untouched = f.read() == f"sentinel {os.path.basename(sentinel)}\n".encode() and int(os.stat(sentinel).st_mtime) == SENTINEL_TIME
    if not untouched:
        failures.append(f"existing output {os.path.basename(sentinel)} was touched")
    others = sorted(set(os.listdir(run_dir)) - {os.path.basename(sentinel)} - {f"{STATUS_PREFIX}{r}" for r in range(ranks)})
    if others:
        failures.append(f"created {', '.join(others)}")
    if failures:
        failures.append("output: " + output.strip()[:600])
    else:
        shutil.rmtree(run_dir)
    return failures, f"{seconds:.2f} s: {error_lines[0] if error_lines else ''}"


os.makedirs(args.work_dir, exist_ok=True)
runs = [(name, 1, False) for name in names] + [(name, args.np, False) for name in names]
if args.np > 1:
    runs += [(name, args.np, True) for name in names if name in PLAIN_MPIEXEC]
started = time.monotonic()
failed = 0
with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
    def checked_run(run_args):
        try:
            return run_args, run(*run_args)
        except Exception as exception:  # a broken check must fail the test, not hide the other runs
            return run_args, ([f"test error: {exception!r}"], "")

    results = pool.map(checked_run, runs)
    for (name, ranks, plain), (failures, summary) in results:
        label = f"np {ranks}{' plain mpiexec' if plain else ''} {name}"
        if failures:
            failed += 1
            print(f"FAIL {label}: " + "; ".join(failures))
        else:
            print(f"ok   {label} ({summary})")
elapsed = time.monotonic() - started
print(f"{len(runs)} runs of {len(names)} corpus files in {elapsed:.1f} s")
print(f"{len(runs) - failed} passed, {failed} failed")
sys.exit(1 if failed else 0)
