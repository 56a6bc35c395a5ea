"""What a restart must refuse, and the runs no checkpoint can continue (docs/options.md,
"Checkpoints and restarts"; docs/stability.md).

1. --restart without a checkpoint file after it (last on the line, an empty word, an option
   next): one line, exit 1; a job script's empty $CHECKPOINT used to start a fresh run.
2. A restart that changes the analysis: a dynamic checkpoint continued as buckling (the run
   stopped with a trace, "frame of step 0 after the frame of step 4") and a load-controlled
   checkpoint continued under arc length, or without the stability account whose series the file
   holds: one line, exit 1, the result file and its sidecar untouched. A completed run continued
   from a checkpoint before its end is allowed, with a warning naming the rows it drops.
3. A static analysis under arc length writes no checkpoint (a restart cannot continue it: its
   predictor needs the previous step): -checkpoint_every is ignored with a warning, and SIGTERM
   stops it with its results written, no checkpoint, and exit status 128 + 15 (the shell's
   convention for a signalled stop), not 75, which tells a job script to resubmit.
4. A mesh file (`mesh:`) changed after the checkpoint: one line, exit 1 (the restart combined
   the new geometry with the old state).
   Also refused: a change of integrator that the new one cannot continue (to newmark or genalpha
   from another integrator or spectral radius; mc and em continue any), and two checkpoints;
   allowed: a restart with a max_step below the input's initial_step, whose steps then keep it.
   A stop signal during the last step ends the run as completed (exit 0), not 75. After a restart
   the summary's energy figures cover the whole result file. A stop signal during an eigenanalysis
   writes the modes converged by then and exits with 143.
5. The temporaries a killed run left beside its result file, sidecar and checkpoint
   (`<file>.tmp.XXXXXX`) are removed by the next run that owns those files, and nothing else."""

import os
import re
import signal
import subprocess
import time

import h5py

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("restart refusals")
work = args.work_dir
os.makedirs(work, exist_ok=True)


def run(command, cwd=work):
    result = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=cwd)
    return result.returncode, result.stdout, result.stderr


def one_line(label, code, stderr, text):
    lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
    print(f"{label}: exit {code}: {lines[0] if lines else stderr.strip()[:300]}")
    check.equal(f"{label}: exit status", code, 1)
    check.true(f"{label}: one line saying '{text}'", len(lines) == 1 and text in lines[0])
    check.equal(f"{label}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)


# 1. --restart without a file
bend = f"{args.source_dir}/input/bend45.yaml"
for words in (["--restart"], [bend, "--restart"], ["--restart", ""], ["--restart", "-analysis_end_time", "2"]):
    code, _, stderr = run([args.msflex, *words, "-output_file", "never.h5"])
    one_line(f"msflex {' '.join(repr(w) if not w else w for w in words)}", code, stderr, "--restart needs the checkpoint file after it")
check.true("no result file from the runs without a checkpoint file", not os.path.exists(f"{work}/never.h5"))

# 2. a restart that changes the analysis
shaft = f"{args.source_dir}/input/rotating_shaft.yaml"
code, _, stderr = run([args.msflex, shaft, "-analysis_end_time", "0.004", "-checkpoint_every", "20", "-output_file", "shaft.h5", "-output_overwrite", "-quiet"])
check.equal("rotating shaft with checkpoints: exit status", code, 0)
with open(f"{work}/shaft.h5", "rb") as f:
    before = f.read()
code, _, stderr = run([args.msflex, "--restart", "shaft.ckpt.h5", "-analysis_end_time", "0.01", "-analysis_type", "buckling"])
one_line("dynamic checkpoint restarted as buckling", code, stderr, "a restart continues the checkpoint's analysis: 'shaft.ckpt.h5' holds a dynamic analysis, not buckling")
with open(f"{work}/shaft.h5", "rb") as f:
    check.true("dynamic checkpoint restarted as buckling: the result file is untouched", f.read() == before)
# ... or its integrator where the new one would continue accelerations it does not hold (em ->
# newmark jumped the energy balance by a tenth of the energy in one step); the mid-point schemes
# need velocities alone and continue any checkpoint
for words, text in ((["-analysis_integrator", "newmark"], "'shaft.ckpt.h5' was written by genalpha (spectral radius 0); newmark continues only its own accelerations"),
                    (["-analysis_spectral_radius", "0.5"], "genalpha (spectral radius 0.5) continues only its own accelerations"),
                    (["--restart", "shaft.ckpt.h5"], "--restart given 2 times")):
    code, _, stderr = run([args.msflex, "--restart", "shaft.ckpt.h5", "-analysis_end_time", "0.01", *words])
    one_line(f"dynamic checkpoint restarted with {' '.join(words)}", code, stderr, text)
with open(f"{work}/shaft.h5", "rb") as f:
    check.true("refused restarts: the result file is untouched", f.read() == before)
with open(f"{work}/shaft.ckpt.h5", "rb") as f:
    checkpoint_bytes = f.read()
for name in ("shaft_em.h5", "shaft_em.xmf", "shaft_em.ckpt.h5", "shaft_narrow.h5", "shaft_narrow.xmf", "shaft_narrow.ckpt.h5"):  # (a rerun's: another run's files)
    if os.path.exists(f"{work}/{name}"):
        os.remove(f"{work}/{name}")
code, _, stderr = run([args.msflex, "--restart", "shaft.ckpt.h5", "-analysis_end_time", "0.0045", "-analysis_integrator", "em", "-output_file", "shaft_em.h5"])
check.equal(f"genalpha checkpoint continued by em: exit status ({stderr.strip()[-200:]})", code, 0)
# A restart narrowing the steps: the checkpoint's step is kept within the new max_step (it went
# on at 20 times the new max_step for two steps), and the input's initial_step above it is no error.
with open(f"{work}/shaft.ckpt.h5", "wb") as f:
    f.write(checkpoint_bytes)
code, _, stderr = run([args.msflex, "--restart", "shaft.ckpt.h5", "-analysis_end_time", "0.0045", "-analysis_max_step", "2.5e-5", "-output_file", "shaft_narrow.h5"])
check.equal(f"restart with max_step 2.5e-5 below the input's initial_step 1e-4: exit status ({stderr.strip()[-200:]})", code, 0)
if code == 0:
    narrowed = mt.history(f"{work}/shaft_narrow.h5")
    after = narrowed["time"] > 0.004 * (1 - 1e-12)
    check.less("restart with max_step 2.5e-5: largest step after the checkpoint (s)", float(narrowed["step_size"][after].max()), 2.5e-5 * (1 + 1e-12))

arch = f"{args.source_dir}/input/deep_arch.yaml"
code, _, stderr = run([args.msflex, arch, "-analysis_control", "load", "-analysis_end_time", "0.1", "-checkpoint_every", "1", "-output_file", "arch_load.h5",
                       "-output_overwrite", "-quiet"])
check.equal("deep arch under load control with checkpoints: exit status", code, 0)
code, _, stderr = run([args.msflex, "--restart", "arch_load.ckpt.h5", "-analysis_control", "arc_length"])
one_line("load-controlled checkpoint restarted under arc length", code, stderr, "was written under control: load, not arc_length")
# ... or without the stability account whose series the file holds: refused before the file or its
# sidecar changes (it cut the history and frames to the checkpoint's, marked the run as running and
# rewrote the sidecar, and only the first row found the columns different).
files = {name: open(f"{work}/{name}", "rb").read() for name in ("arch_load.h5", "arch_load.xmf")}
code, _, stderr = run([args.msflex, "--restart", "arch_load.ckpt.h5", "-analysis_stability", "false", "-analysis_end_time", "0.2"])
one_line("restart without the stability account", code, stderr, "the run it continues wrote the series 'negative_pivots', and this restart would not")
for name, before in files.items():
    with open(f"{work}/{name}", "rb") as f:
        check.true(f"restart without the stability account: {name} is untouched", f.read() == before)
# A completed run continued from a checkpoint before its end (here to an earlier end time) loses
# the rows after that checkpoint: allowed, and said on stderr (nothing else told).
code, _, stderr = run([args.msflex, bend, "-checkpoint_every", "3", "-output_file", "bend_cut.h5", "-output_overwrite", "-quiet"])
check.equal("bend45 with checkpoints every 3 steps: exit status", code, 0)
code, _, stderr = run([args.msflex, "--restart", "bend_cut.ckpt.h5", "-analysis_end_time", "0.8", "-quiet"])
check.equal("completed run cut back to its checkpoint: exit status", code, 0)
check.true(f"completed run cut back to its checkpoint: the warning names the run's end and the rows replaced ({stderr.strip()!r})",
           "msflex: warning: 'bend_cut.h5' holds a run that completed at t = 1 after step 8; this restart continues it from its checkpoint at step 6 "
           "and drops the 2 rows after that step" in stderr)

# A stop signal during the last step: the run has completed and ends so (exit 0); it stopped with
# exit 75, and the job script's restart was then refused (nothing left to do). One step of a long
# cantilever, the signal once the run has begun.
with open(f"{work}/one_step.yaml", "w") as f:
    f.write("""sections: [{name: s, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 1.0e4, EI2: 1.0e4, EI3: 1.0e4, rhoA: 1.0, rhoJ: [1.0e-3, 5.0e-4, 5.0e-4]}]
nodes: {root: [0, 0, 0], tip: [1, 0, 0]}
beams: [{name: arm, section: s, from: root, to: tip, elements: 40000}]
supports: [{nodes: root, fix: all}]
functions: [{name: one, type: constant, value: 1.0}]
loads: [{nodes: tip, force: [0, 1000, 0], function: one}]
analysis: {type: dynamic, integrator: em, end_time: 0.01, initial_step: 0.01, max_step: 0.01}
""")
def terminate_once_begun(words, banner, label):
    """Runs msflex with `words` in work, sends SIGTERM once the line starting with `banner` is out
    (the analysis has begun), and returns the exit status and standard error."""
    process = subprocess.Popen([args.msflex, *words], cwd=work, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for line in process.stdout:
        if line.startswith(banner):
            break
    process.send_signal(signal.SIGTERM)
    _, errors = process.communicate(timeout=300)
    print(f"{label}: exit {process.returncode}: {errors.strip()[-300:]}")
    return process.returncode, errors


code, errors = terminate_once_begun(["one_step.yaml", "-output_file", "one_step.h5", "-output_overwrite"], "msflex: dynamic analysis", "SIGTERM during the only step")
check.equal("SIGTERM during the last step: exit status (completed)", code, 0)
check.true("SIGTERM during the last step: said on standard error", "SIGTERM arrived during the last step; the run has completed" in errors)
with h5py.File(f"{work}/one_step.h5", "r") as f:
    check.true("SIGTERM during the last step: run_end says completed", f.attrs["run_end"].decode().startswith("completed at t = 0.01"))
check.less("SIGTERM during the last step: |last history time - end time|", abs(float(mt.history(f"{work}/one_step.h5")["time"][-1]) - 0.01), 1e-15)

# A stop signal once the run has completed (its summary out, the process finalising): exit 0, and at
# most a line saying it changed nothing. PETSc's finalisation reset the signal to its default, and
# such a signal killed the completed run with exit 143 and no word (3 of 3 tries before; a small
# model, whose process ends quickly after its summary). Standard output is read a byte at a time,
# so that the signal follows the summary's last line at once (Python's line reading waited for
# more and sent it too late to find the window).
for attempt in range(3):
    process = subprocess.Popen([args.msflex, f"{args.source_dir}/input/turning_arm_screw.yaml", "-output_file", "late.h5", "-output_overwrite"], cwd=work,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    line = b""
    while byte := os.read(process.stdout.fileno(), 1):
        line = b"" if line.endswith(b"\n") else line
        line += byte
        if line.endswith(b"\n") and b"peak memory" in line:
            process.send_signal(signal.SIGTERM)
            break
    _, errors = process.communicate(timeout=300)
    errors = errors.decode()
    print(f"SIGTERM after the summary, try {attempt + 1}: exit {process.returncode}: {errors.strip()}")
    check.equal(f"SIGTERM after the summary, try {attempt + 1}: exit status", process.returncode, 0)
    check.true(f"SIGTERM after the summary, try {attempt + 1}: nothing on standard error but the line saying it changed nothing",
               errors.strip() in ("", "msflex: a stop signal (15) arrived after the run had completed; it changes nothing"))

# After a restart into its result file, the summary's energy figures and the energy warning cover
# the whole file (they covered the restarted part: drift 69.52 instead of 25.47, "initial total
# energy" the restart's 373.1 J instead of 417.2 J).
spinning = f"{args.source_dir}/tests/regression/inputs/spinning_beam.yaml"
code, stdout, stderr = run([args.msflex, spinning, "-output_file", "spin_full.h5", "-output_overwrite"])
full_lines = [line.strip() for line in (stdout + stderr).splitlines() if "energy drift" in line or "energy balance grew" in line]
# A frame every 7 steps: the checkpoint's step 400 has none (the last before it is step 399, which
# restart_1 named).
run([args.msflex, spinning, "-output_file", "spin.h5", "-output_overwrite", "-checkpoint_every", "200", "-output_every", "7", "-quiet"])
code, stdout, stderr = run([args.msflex, "--restart", "spin.ckpt.h5", "-quiet", "0"])
restart_lines = [line.strip() for line in (stdout + stderr).splitlines() if "energy drift" in line or "energy balance grew" in line]
print("energy lines, whole run:", full_lines, "\nafter the restart:", restart_lines)
check.true("restart: the energy drift and warning lines equal the uninterrupted run's", len(full_lines) == 2 and restart_lines == full_lines)
# ... and the file records the restart and how the run ended (its attributes were the first run's
# alone, and a finished run could not be told from one stopped by a failure)
with h5py.File(f"{work}/spin.h5", "r") as f:
    attributes = {name: (value.decode() if isinstance(value, bytes) else str(value)) for name, value in f.attrs.items()}
print("restarted file:", {name: attributes.get(name, "")[:120] for name in ("run_end", "restart_1", "restart_2")})
check.true("restart: restart_1 records the restart (ranks, step, command line)",
           re.search(r"on 1 rank\(s\) at step 400: .*--restart spin.ckpt.h5", attributes.get("restart_1", "")) is not None)
check.true("restart: no restart_2", "restart_2" not in attributes)
check.true("restart: run_end says completed", attributes.get("run_end", "").startswith("completed at t = "))

# A stop signal during an eigenanalysis: the solver ends with the modes it has, which are written,
# and the run stops with 128 + 15 (no checkpoint continues it); it ran on to the end, exit 0.
with open(f"{args.source_dir}/input/hinged_beam_modes.yaml") as f:
    modes_input = f.read().split("expected:")[0].replace("elements: 48", "elements: 2000").replace("eigenvalues: 8", "eigenvalues: 200")
with open(f"{work}/many_modes.yaml", "w") as f:
    f.write(modes_input)
# (-eps_mpd 16: many outer iterations of the solver, between which it looks for a signal.)
code, errors = terminate_once_begun(["many_modes.yaml", "-output_file", "many_modes.h5", "-output_overwrite", "-eps_mpd", "16"], "msflex: modes analysis",
                                    "SIGTERM during the eigensolve")
check.equal("SIGTERM during the eigensolve: exit status 128 + 15", code, 143)
check.true("SIGTERM during the eigensolve: said in one line", "stopped by SIGTERM with the modes converged by then" in errors)
with h5py.File(f"{work}/many_modes.h5", "r") as f:
    check.true("SIGTERM during the eigensolve: run_end says so", f.attrs["run_end"].decode().startswith("stopped by SIGTERM"))
    check.true(f"SIGTERM during the eigensolve: fewer than 200 modes written ({mt.frame_count(f) - 1})", mt.frame_count(f) - 1 < 200)

# 3. arc length: no checkpoint, SIGTERM stops with 143
for name in ("arch_arc.h5", "arch_arc.ckpt.h5"):
    if os.path.exists(f"{work}/{name}"):
        os.remove(f"{work}/{name}")
process = subprocess.Popen([args.msflex, arch, "-analysis_initial_step", "0.0005", "-analysis_max_step", "0.0005", "-analysis_max_steps", "1000000",
                            "-checkpoint_every", "5", "-output_file", "arch_arc.h5", "-output_overwrite", "-output_flush_interval", "0"], cwd=work, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
deadline = time.time() + 60
while time.time() < deadline and process.poll() is None:  # until some steps are written
    time.sleep(0.2)
    if os.path.exists(f"{work}/arch_arc.h5"):
        time.sleep(1.0)
        break
process.send_signal(signal.SIGTERM)
stdout, stderr = process.communicate(timeout=120)
print(f"arc length, SIGTERM: exit {process.returncode}; {stdout.strip().splitlines()[-1] if stdout.strip() else ''}")
check.equal("arc length with -checkpoint_every: warning lines", sum(1 for line in stderr.splitlines() if "writes no checkpoints" in line), 1)
check.equal("arc length, SIGTERM: exit status 128 + SIGTERM", process.returncode, 128 + signal.SIGTERM)
check.true("arc length, SIGTERM: the stop says why there is no checkpoint", "no checkpoint: a static analysis under control: arc_length" in stdout)
check.true("arc length, SIGTERM: no checkpoint file", not os.path.exists(f"{work}/arch_arc.ckpt.h5"))
with h5py.File(f"{work}/arch_arc.h5", "r") as f:
    rows = f["history/values"].shape[0]
check.less("arc length, SIGTERM: 1 / the history rows written", 1.0 / rows, 0.5)

# 4. a mesh file changed since the checkpoint
lattice = f"{work}/lattice.yaml"
subprocess.run(["python3", f"{args.source_dir}/scripts/make-network", "lattice", "--n", "2", "2", "2", "--elements", "1", "-o", lattice, "--hdf5",
                f"{work}/lattice_mesh.h5"], check=True, capture_output=True)
code, _, stderr = run([args.msflex, lattice, "-analysis_end_time", "0.02", "-checkpoint_every", "5", "-output_file", "lattice.h5", "-output_overwrite", "-quiet"])
check.equal("lattice with a mesh file and checkpoints: exit status", code, 0)
with h5py.File(f"{work}/lattice_mesh.h5", "r+") as f:
    coordinates = f["nodes/coordinates"]
    coordinates[...] = 2.0 * coordinates[()]
code, _, stderr = run([args.msflex, "--restart", "lattice.ckpt.h5", "-analysis_end_time", "0.03", "-output_file", "lattice_more.h5"])
one_line("restart after the mesh file changed", code, stderr, "has changed since the run wrote the checkpoint 'lattice.ckpt.h5'")
with h5py.File(f"{work}/lattice_mesh.h5", "r+") as f:
    coordinates = f["nodes/coordinates"]
    coordinates[...] = 0.5 * coordinates[()]
for name in ("lattice_more.h5", "lattice_more.xmf", "lattice_more.ckpt.h5"):  # from an earlier run of this test
    if os.path.exists(f"{work}/{name}"):
        os.remove(f"{work}/{name}")
code, _, stderr = run([args.msflex, "--restart", "lattice.ckpt.h5", "-analysis_end_time", "0.03", "-output_file", "lattice_more.h5", "-quiet"])
check.equal("restart with the mesh file as it was: exit status", code, 0)

# 5. What a killed run left beside its files (a checkpoint killed while written leaves
#    <checkpoint>.tmp.XXXXXX): the next run that owns those files removes it, and nothing else.
stale = ["shaft2.h5.tmp.AbC123", "shaft2.xmf.tmp.q1w2e3", "shaft2.ckpt.h5.tmp.ZZZZZZ"]
kept = ["shaft2.ckpt.h5.tmp.short", "other.h5.tmp.AAAAAA"]
for name in stale + kept:
    with open(f"{work}/{name}", "w") as f:
        f.write("partial")
code, _, stderr = run([args.msflex, shaft, "-analysis_end_time", "0.001", "-output_file", "shaft2.h5", "-output_overwrite", "-quiet"])
check.equal("run beside stale temporaries: exit status", code, 0)
check.equal("stale temporaries of the run's files left", sum(os.path.exists(f"{work}/{name}") for name in stale), 0)
check.equal("other files kept", sum(os.path.exists(f"{work}/{name}") for name in kept), len(kept))

# A checkpoint or options file that is a FIFO without a writer: the open blocked for good, deaf to
# SIGTERM; both are now refused in one line.
fifo = f"{work}/not_a_checkpoint.ckpt.h5"
if os.path.exists(fifo):
    os.remove(fifo)
os.mkfifo(fifo)
for label, command in (("--restart FIFO", [args.msflex, "--restart", fifo]),
                       ("-options_file FIFO", [args.msflex, shaft, "-options_file", fifo, "-analysis_end_time", "0.001", "-quiet", "-output_overwrite"])):
    result = mt.run_with_timeout(command, work, 60)
    lines = [] if result is None else [line for line in (result[0] + result[1]).splitlines() if line.strip()]
    print(f"{label}: {'hung' if result is None else f'exit {result[2]}'}: {lines}")
    check.true(f"{label}: ends with exit 1", result is not None and result[2] == 1)
    check.true(f"{label}: one line saying it is not a regular file", len(lines) == 1 and "not a regular file" in lines[0])
os.remove(fifo)
check.finish()
