"""A run's sidecar before its first flush (docs/output.md): the file and its sidecar are created
when the run starts, and the frames are listed at the first flush (by default after 10 s of wall
time). ParaView 5.11's Xdmf3 reader aborted (SIGABRT, "Invalid xpointer encountered") on the
sidecar of such a run, whose temporal collections took their grids by XInclude from a list that
was still empty: the sidecar of a run killed (SIGKILL) after a few steps, before its first flush,
must open in pvpython with no time step, and the run's next frames, once flushed, with theirs
(input/rotating_shaft.yaml, a frame every step). A run killed after some flushes holds no frame of
a step beyond its history's last row."""

import os
import shutil
import signal
import subprocess

import h5py

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("sidecar before the first flush")
work = args.work_dir
os.makedirs(work, exist_ok=True)
pvpython = shutil.which("pvpython")
if not pvpython:
    raise SystemExit("pvpython not found: scripts/setup installs it (Debian package paraview)")
OPEN = """
import sys
from paraview.simple import OpenDataFile
reader = OpenDataFile(sys.argv[1])
reader.UpdatePipelineInformation()
reader.UpdatePipeline()
print("time steps", len(reader.TimestepValues or []))
"""
with open(f"{work}/open.py", "w") as f:
    f.write(OPEN)


def open_in_paraview(xmf):
    command = [pvpython, f"{work}/open.py", xmf]
    if shutil.which("xvfb-run") and not os.environ.get("DISPLAY"):
        command = ["xvfb-run", "-a", *command]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    lines = [line for line in result.stdout.splitlines() if line.startswith("time steps")]
    return result.returncode, int(lines[-1].split()[-1]) if lines else -1, result.stderr.strip()[-300:]


shaft = f"{args.source_dir}/input/rotating_shaft.yaml"
output = f"{work}/killed.h5"
for path in (output, output[:-3] + ".xmf"):
    if os.path.exists(path):
        os.remove(path)
process = subprocess.Popen([args.msflex, shaft, "-output_file", output, "-output_overwrite", "-progress_every", "1", "-progress_interval", "0"],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
for line in process.stdout:
    if line.startswith("step") and int(line.split()[1]) >= 5:
        break
process.send_signal(signal.SIGKILL)
process.wait()
with open(output[:-3] + ".xmf") as f:
    sidecar = f.read()
check.true("killed before the first flush: the sidecar lists no frame", "<Time " not in sidecar)
code, steps, errors = open_in_paraview(output[:-3] + ".xmf")
print(f"killed run's sidecar in pvpython: exit {code}, {steps} time steps {errors}")
check.equal("killed before the first flush: pvpython opens the sidecar (exit status)", code, 0)
check.equal("killed before the first flush: time steps ParaView sees", steps, 0)

completed = f"{work}/completed.h5"
mt.run_msflex(args, shaft, completed, extra=["-quiet", "-analysis_end_time", "0.002", "-output_overwrite"])
code, steps, errors = open_in_paraview(completed[:-3] + ".xmf")
check.equal("completed run: pvpython opens the sidecar (exit status)", code, 0)
with h5py.File(completed, "r") as f:
    frames = mt.frame_count(f)
check.equal("completed run: time steps ParaView sees (one per frame)", steps, frames)

# Killed after some flushes (every 0.2 s, a frame every step): the file holds no frame of a step its
# history has not reached. A flush due when a step's frame was taken, before its history row, held
# that frame alone until the next flush (one frame more than the rows in 4 of 4 kills of a user
# trial, whatever the moment).
flushed = f"{work}/flushed.h5"
for path in (flushed, flushed[:-3] + ".xmf"):
    if os.path.exists(path):
        os.remove(path)
process = subprocess.Popen([args.msflex, shaft, "-output_file", flushed, "-output_every", "1", "-output_flush_interval", "0.2", "-progress_every", "1",
                            "-progress_interval", "0"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
for line in process.stdout:
    if line.startswith("step") and int(line.split()[1]) >= 3000:
        break
process.send_signal(signal.SIGKILL)
process.wait()
with h5py.File(flushed, "r", locking=False) as f:
    frame_steps = f["frames/step"][()]
    history_steps = f["history/values"][:, list(name.decode() for name in f["history/names"][()]).index("step")]
print(f"killed after flushes: last frame of step {frame_steps[-1] if len(frame_steps) else None}, last history row of step "
      f"{history_steps[-1] if len(history_steps) else None}")
check.true("killed after flushes: frames and history rows were flushed", len(frame_steps) > 0 and len(history_steps) > 0)
check.true("killed after flushes: no frame of a step beyond the history's last row", len(frame_steps) > 0 and frame_steps[-1] <= history_steps[-1])
check.finish()
