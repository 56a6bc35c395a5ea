"""Checkpoint and restart through the real executable (docs/options.md, "Checkpoints and restart").

1. Restart equality, serial: a run that writes a checkpoint every 120 steps is continued from its
   last checkpoint with `msflex --restart`; the continued result file must equal the one of a run
   that never stopped, every frame and every history and probe row, to the last bit. Cases: the
   floating chain (em; revolute, spherical and screw joints; fixed steps of 0.005 s) and the
   torque-free top with Newmark
   (a rigid body with its own centre-of-mass motion, accelerations carried over).
2. Restart on another number of ranks (1 -> 2, into a new result file): the frames and history rows
   after the checkpoint equal the uninterrupted serial run to 1e-8 relative: on other ranks the
   Newton iterates differ at the level of the Newton tolerance (1e-10), not of round-off (a history series
   relative to the largest value of its joint's or probe's series, so that a ball joint's moment,
   zero up to round-off, is measured against the joint's force; the solver's own diagnostics —
   residual norm, Newton iterations, em's beta — are not results and are left out). And (torque-free
   top) a serial result file continued on 2 ranks beyond its end, so that its datasets grow new
   chunks in collective writes: equal to an uninterrupted serial run to the new end to 1e-8.
3. SIGTERM and SIGINT (serial; SIGINT printed a PETSc trace and left no checkpoint) and SIGUSR1
   sent to mpirun (2 ranks) during a run: exit status 75, a
   checkpoint at the step reached, a readable result file holding exactly the steps done, the last
   as a frame too (output.every 100 did not write it before); the restart then completes the run
   exactly as the uninterrupted run on as many ranks (it drops that extra frame).
4. SIGKILL during a run: the result file stays readable and holds whole frames and rows up to the
   last completed step.
5. Checkpoints by wall time (-checkpoint_wall_time 0.2): a run of more than a second leaves a
   checkpoint of an intermediate step, from which the restart again ends bitwise equal.
6. A serial run continued on 2 ranks into the same file, for two pendulums whose joints are listed
   against the order of their slave nodes (so that 2 ranks own them in the other order): the
   history's columns are those of the serial run, and the continued file equals an uninterrupted
   serial run to round-off.
7. A run whose Newton handed the banded LU (PETSc's, here) over to MUMPS (forced with a zero-pivot threshold
   that no pivot passes, on an AIJ tangent, whose LU applies it): its checkpoint records it, and the restart factors by MUMPS from its
   first step (no second handover) and ends bitwise equal to the uninterrupted run."""

import os
import re
import shutil
import signal
import subprocess
import time

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("checkpoint and restart")
env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
work = args.work_dir
# A fresh directory: files of an earlier run of this test (results, sidecars, checkpoints) would be
# existing files that msflex rightly refuses to replace.
shutil.rmtree(work)
os.makedirs(work)


def command(ranks, *arguments):
    launcher = [args.mpiexec, "-n", str(ranks), "--oversubscribe"] if ranks > 1 else []
    return launcher + [args.msflex] + [str(a) for a in arguments]


def run(ranks, *arguments, expect=0):
    result = subprocess.run(command(ranks, *arguments), capture_output=True, text=True, timeout=600, env=env)
    if result.returncode != expect:
        print(result.stdout[-3000:], result.stderr[-3000:])
        raise SystemExit(f"exit status {result.returncode}, expected {expect}: {' '.join(command(ranks, *arguments))}")
    return result


def read_all(path):
    """Every frame dataset ("frames/<name>") and every column of the history table, probes'
    included ("history/<series>")."""
    data = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                data["frames/" + name] = obj[()]
        f["frames"].visititems(visit)
    data.update({"history/" + name: values for name, values in mt.history(path).items()})
    return data


SOLVER_DIAGNOSTICS = ("history/residual_norm", "history/newton_iterations", "history/energy_correction")


# Series of energy measured on the scale of the total energy: the energy balance's terms
# (algorithmic_dissipation is zero to the Newton tolerance in em, so its own scale is round-off).
ENERGY_SERIES = ("history/total_energy", "history/kinetic_energy", "history/strain_energy", "history/external_work", "history/energy_balance",
                 "history/algorithmic_dissipation")


def family_scales(data):
    """Per history series: the largest |value| among the series of its joint or probe ("ball.force_x"
    and "ball.moment_x" share "ball", "tip.position.x" and "tip.rotation.w" share "tip"), or among
    the energy series; other datasets: their own largest |value|."""
    scales, families = {}, {}
    for name, values in data.items():
        family = name.rsplit("/", 1)[0] + "/" + name.rsplit("/", 1)[1].split(".")[0] if name.startswith("history/") and "." in name else name
        if name in ENERGY_SERIES:
            family = "history/energies"
        families[name] = family
        scales[family] = max(scales.get(family, 0.0), float(np.abs(np.asarray(values, float)).max()) if np.size(values) else 0.0)
    return {name: scales[families[name]] for name in data}


def largest_difference(reference, other, names=None, relative=False, rows=slice(None), frame_rows=slice(None)):
    """Max |a - b| over the datasets of `names` (default: all of the reference), relative when
    asked: a history/probe series to its family scale, a frame dataset (frames x rows x columns)
    frame by frame to that frame's largest |value| in the reference. History/probe series are
    compared on `rows` of the reference, the /frames datasets on its frames `frame_rows`."""
    worst, compared = 0.0, 0
    scales = family_scales(reference)
    for name in names if names is not None else reference:
        a, b = np.asarray(reference[name], float), np.asarray(other[name], float)
        a = a[frame_rows] if name.startswith("frames/") else a[rows]
        if a.shape != b.shape:
            return float("inf"), compared
        if not a.size:
            difference = 0.0
        elif relative and name.startswith("frames/") and a.ndim > 1:
            per_frame = tuple(range(1, a.ndim))
            difference = float((np.abs(a - b).max(axis=per_frame) / np.maximum(np.abs(a).max(axis=per_frame), 1e-300)).max())
        else:
            difference = np.abs(a - b).max()
            if relative:
                difference /= max(scales[name], 1e-300)
        worst, compared = max(worst, difference), compared + 1
    return worst, compared


# Fixed steps (no step-size control at work), so that runs on different numbers of ranks take the
# same steps and can be compared step by step.
cases = [("floating chain, em", f"{args.source_dir}/tests/regression/inputs/floating_chain.yaml",
          ["-analysis_end_time", "2.5", "-analysis_initial_step", "0.005", "-analysis_max_step", "0.005"]),
         ("torque-free top, newmark", f"{args.source_dir}/input/torque_free_top.yaml", ["-analysis_integrator", "newmark", "-analysis_end_time", "4"])]
for label, source, settings in cases:
    tag = label.split(",")[0].replace(" ", "_")
    reference = f"{work}/{tag}_reference.h5"
    run(1, source, "-output_file", reference, "-output_overwrite", "-quiet", *settings)
    expected = read_all(reference)

    # 1. Serial restart from the last checkpoint of a complete run.
    continued = f"{work}/{tag}_continued.h5"
    checkpoint = f"{work}/{tag}_continued.ckpt.h5"
    run(1, source, "-output_file", continued, "-output_overwrite", "-quiet", "-checkpoint_every", 120, *settings)
    with h5py.File(checkpoint, "r") as f:
        checkpoint_step = int(f["run/numbers"][0])
    run(1, "--restart", checkpoint)
    got = read_all(continued)
    difference, compared = largest_difference(expected, got)
    print(f"{label}: restart at step {checkpoint_step}, serial: {compared} datasets, largest difference {difference:.3e}")
    check.true(f"{label}: checkpoint step > 0 ({checkpoint_step})", checkpoint_step > 0)
    check.equal(f"{label}: datasets in only one of this and the uninterrupted run", len(set(expected) ^ set(got)), 0)
    check.less(f"{label}: serial restart, largest difference", difference, 1e-300)

    # 2. The same checkpoint continued on 2 ranks into a new file: the root attribute `continues`
    # names the checkpoint; the rows and frames are those of the steps after it (the state it starts
    # from is the last row of the file it came from: its joints' rates and reactions are those of
    # the step that reached it).
    other = f"{work}/{tag}_np2.h5"
    if os.path.exists(other):
        os.remove(other)
    run(2, "--restart", checkpoint, "-output_file", other, "-checkpoint_file", f"{work}/{tag}_np2.ckpt.h5")
    got = read_all(other)
    with h5py.File(other, "r") as f:
        continues = f.attrs.get("continues", b"")
        continues = continues.decode() if isinstance(continues, bytes) else str(continues)
    check.true(f"{label}: the new file's attribute 'continues' names the checkpoint and its step ({continues!r})",
               continues.startswith(f"checkpoint {checkpoint} at step {checkpoint_step},"))
    frames = [name for name in got if name.startswith("frames/")]
    first_step = int(mt.history(other)["step"][0])
    rows = slice(first_step, None)
    # The new file holds the frames after the checkpoint: the reference's frames of the same steps
    # (a step the reference lacks makes the shapes differ).
    frame_rows = np.isin(expected["frames/step"], got["frames/step"])
    new_steps = got["frames/step"]
    check.true(f"{label}: 2-rank restart writes frames, only after the checkpoint ({len(new_steps)} frames, from step {min(new_steps, default=None)})",
               len(new_steps) >= 1 and bool(np.all(new_steps > checkpoint_step)))
    history_names = [name for name in got if not name.startswith("frames/") and name not in SOLVER_DIAGNOSTICS]
    frame_difference, frame_count = largest_difference(expected, got, frames, relative=True, frame_rows=frame_rows)
    history_difference, _ = largest_difference(expected, got, history_names, relative=True, rows=rows)
    print(f"{label}: restart on 2 ranks from step {first_step - 1}: {frame_count} frame datasets, largest relative difference {frame_difference:.3e}; "
          f"history {history_difference:.3e}")
    check.equal(f"{label}: 2-rank restart writes the steps after the checkpoint (first step = checkpoint step + 1)", first_step, checkpoint_step + 1)
    check.less(f"{label}: 2-rank restart, frames, largest relative difference", frame_difference, 1e-8)
    check.less(f"{label}: 2-rank restart, history, largest relative difference", history_difference, 1e-8)

    # 2b. The serial result file continued on 2 ranks past its end: the datasets a serial process
    # created get new chunks in collective writes (a restart that crossed a chunk boundary hung in
    # MPI-IO, "writev: Invalid argument", until chunks were allocated when datasets are extended).
    if tag == "torque-free_top":
        longer = settings[:-1] + ["6"]
        longer_reference = f"{work}/{tag}_longer_reference.h5"
        run(1, source, "-output_file", longer_reference, "-output_overwrite", "-quiet", *longer)
        grown = f"{work}/{tag}_grown.h5"
        run(1, source, "-output_file", grown, "-output_overwrite", "-quiet", "-checkpoint_every", 120, *settings)
        run(2, "--restart", f"{work}/{tag}_grown.ckpt.h5", "-analysis_end_time", "6", "-quiet")
        expected_longer, got = read_all(longer_reference), read_all(grown)
        with h5py.File(grown, "r") as f:
            chunk_frames = f["frames/position"].chunks[0]
        grown_frames = len(got["frames/step"])
        check.true(f"{label}: continued on 2 ranks to t = 6 past the end of its chunks ({grown_frames} frames, chunks of {chunk_frames})",
                   grown_frames == len(expected_longer["frames/step"]) and grown_frames > chunk_frames)
        names = [name for name in got if name not in SOLVER_DIAGNOSTICS]
        difference, _ = largest_difference(expected_longer, got, names, relative=True)
        check.less(f"{label}: serial file continued on 2 ranks, largest relative difference", difference, 1e-8)


def interrupt(ranks, send, label, source, settings, expected):
    """Starts a run, sends `send` once it has done 50 steps, checks the stop and the restart
    against `expected`, the uninterrupted run on as many ranks."""
    output = f"{work}/signal_{ranks}.h5"
    checkpoint = f"{work}/signal_{ranks}.ckpt.h5"
    for path in (output, checkpoint, output[:-3] + ".xmf"):
        if os.path.exists(path):
            os.remove(path)
    process = subprocess.Popen(command(ranks, source, "-output_file", output, "-progress_every", 1, "-progress_interval", 0, *settings), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=env)
    for line in process.stdout:
        if line.startswith("step") and int(line.split()[1]) >= 50:
            break
    send(process)
    remaining, errors = process.communicate(timeout=300)
    print(f"{label}: exit {process.returncode}; {remaining.strip().splitlines()[-1] if remaining.strip() else errors.strip()[-300:]}")
    check.equal(f"{label}: exit status", process.returncode, 75)
    with h5py.File(checkpoint, "r") as f:
        stopped_at = int(f["run/numbers"][0])
    history_steps = mt.history(output)["step"]
    check.equal(f"{label}: the result file's history ends at the checkpoint (last step = checkpoint step)", history_steps[-1], stopped_at)
    # The last step is always written, as a frame too (output.every is 100 here); the restart drops
    # that frame again, so the completed run has the frames of the uninterrupted one.
    with h5py.File(output, "r") as f:
        last_frame = int(f["frames/step"][-1])
    check.equal(f"{label}: the stopped run's last frame is its last step", last_frame, stopped_at)
    run(ranks, "--restart", checkpoint, "-quiet")
    got = read_all(output)
    difference, compared = largest_difference(expected, got)
    print(f"{label}: stopped at step {stopped_at}, restarted on {ranks} rank(s): {compared} datasets, largest difference {difference:.3e}")
    check.less(f"{label}: completed run equals the uninterrupted one", difference, 1e-300)


label, source, settings = cases[0]
expected = read_all(f"{work}/floating_chain_reference.h5")
interrupt(1, lambda p: p.send_signal(signal.SIGTERM), "SIGTERM, serial", source, settings, expected)
interrupt(1, lambda p: p.send_signal(signal.SIGINT), "SIGINT (Ctrl-C), serial", source, settings, expected)
reference_np2 = f"{work}/floating_chain_reference_np2.h5"
run(2, source, "-output_file", reference_np2, "-output_overwrite", "-quiet", *settings)
interrupt(2, lambda p: p.send_signal(signal.SIGUSR1), "SIGUSR1 to mpirun, 2 ranks", source, settings, read_all(reference_np2))

# 4. SIGKILL: no chance to clean up, the file must still be readable up to the last whole step.
output = f"{work}/killed.h5"
# -output_flush_interval 0: the file is flushed after every step (by default every 10 s of wall time).
process = subprocess.Popen(command(1, source, "-output_file", output, "-output_overwrite", "-progress_every", 1, "-progress_interval", 0, "-output_flush_interval", 0, *settings),
                           stdout=subprocess.PIPE,
                           stderr=subprocess.DEVNULL, text=True, env=env)
for line in process.stdout:
    if line.startswith("step") and int(line.split()[1]) >= 80:
        break
process.kill()
process.wait()
history = mt.history(output)
steps, times = history["step"], history["time"]
with h5py.File(output, "r") as f:
    n_frames = mt.frame_count(f)
    last_frame = mt.frame(f, -1) if n_frames else {"step": -1, "position": np.array([np.nan])}
    positions = last_frame["position"]
print(f"SIGKILL: file readable, {len(steps)} history rows to step {int(steps[-1])}, {n_frames} frames, last frame (step {last_frame['step']}) "
      f"{positions.shape} finite {np.isfinite(positions).all()}")
check.true(f"SIGKILL: frames in the file, the last at or before the last history row ({n_frames}, step {last_frame['step']})",
           n_frames >= 1 and 0 <= last_frame["step"] <= steps[-1])
check.true(f"SIGKILL: history rows >= 80 ({len(steps)})", len(steps) >= 80)
check.less("SIGKILL: rows equal the reference (largest difference)", float(np.abs(times - expected["history/time"][: len(times)]).max()), 1e-300)
check.true("SIGKILL: last frame finite", bool(np.isfinite(positions).all()))

# 5. By wall time: the interval a fifth of the run's own wall time on this machine, as its summary
# reports it (a fixed one stops checkpointing once the run gets faster than it; the process's time
# would count MPI's start-up, which can exceed the time stepping of this small model).
output = f"{work}/by_wall_time.h5"
checkpoint = f"{work}/by_wall_time.ckpt.h5"
summary = run(1, source, "-output_file", output, "-output_overwrite", "-progress_every", 1000000, *settings).stdout
match = re.search(r"wall time\s+([0-9.eE+-]+) s", summary)
check.true("wall time: the summary reports the run's wall time", match is not None)
interval = float(match.group(1)) / 5 if match else 0.01
# A checkpoint falls due in the last step now and then (the wall clock decides; more often on a
# loaded machine), and a completed run's checkpoint has nothing left to continue: then again with
# a shorter interval, at most three times.
for attempt in range(3):
    started = time.time()
    run(1, source, "-output_file", output, "-output_overwrite", "-quiet", "-checkpoint_wall_time", interval, *settings)
    elapsed = time.time() - started
    checkpoint_step, last_step = -1, int(mt.history(output)["step"][-1])
    if not os.path.exists(checkpoint):
        break
    with h5py.File(checkpoint, "r") as f:
        checkpoint_step = int(f["run/numbers"][0])
    if checkpoint_step < last_step:
        break
    interval *= 0.7
check.true(f"wall time: a checkpoint written with an interval of {interval:.3f} s in a run of {elapsed:.2f} s", os.path.exists(checkpoint))
print(f"wall-time checkpoints: run of {elapsed:.1f} s, last checkpoint at step {checkpoint_step} of {last_step}")
check.true(f"wall time: checkpoint of an intermediate step (0 < {checkpoint_step} < {last_step})", 0 < checkpoint_step < last_step)
run(1, "--restart", checkpoint)
difference, compared = largest_difference(expected, read_all(output))
check.less("wall time: restarted run equals the uninterrupted one", difference, 1e-300)

# 6. Into the same file on another number of ranks.
source = f"{args.source_dir}/tests/regression/inputs/crossed_pendulums.yaml"
serial, parallel = f"{work}/crossed_np1.h5", f"{work}/crossed_np2.h5"
run(1, source, "-output_file", serial, "-output_overwrite", "-quiet", "-analysis_end_time", 0.3)
run(2, source, "-output_file", parallel, "-output_overwrite", "-quiet", "-analysis_end_time", 0.3)
with h5py.File(parallel, "r") as f:
    mesh = f["mesh"]
    names = [name.decode() for name in mesh["joint_names"][()]]
    slave_rank = {name: int(mesh["node_rank"][slave]) for name, slave in zip(names, mesh["joint_slave"][()])}
    columns_np2 = f["history/names"][()]
with h5py.File(serial, "r") as f:
    columns_np1 = f["history/names"][()]
check.true(f"crossed pendulums: 2 ranks own the joints against the model's order (slave ranks {slave_rank})", slave_rank["jA"] > slave_rank["jB"])
check.true("crossed pendulums: the same history columns on 1 and 2 ranks", list(columns_np1) == list(columns_np2))
continued = f"{work}/crossed_continued.h5"
run(1, source, "-output_file", continued, "-output_overwrite", "-quiet", "-analysis_end_time", 0.1, "-checkpoint_every", 50)
run(2, "--restart", continued.replace(".h5", ".ckpt.h5"), "-quiet", "-analysis_end_time", 0.3)
reference, got = mt.history(serial), mt.history(continued)
check.true("crossed pendulums: the continued file has the serial run's series", list(reference) == list(got))
difference = max(float(np.abs(reference[name] - got[name]).max()) for name in reference if name not in ("residual_norm", "newton_iterations"))
print(f"crossed pendulums: continued on 2 ranks, {len(got['time'])} rows, largest difference from the serial run {difference:.3e}")
check.less("crossed pendulums: continued on 2 ranks equals the serial run (round-off)", difference, 1e-10)

# 7. The handover to MUMPS survives a restart.
# The zero-pivot tolerance makes PETSc's LU of an AIJ tangent fail at the first pivot; the LU of a
# BAIJ tangent (the default here) inverts 6x6 blocks with pivoting and stops at exact zeros only.
HANDOVER = "with the banded LU, which does not pivot between nodes"
source = f"{args.source_dir}/input/flying_spaghetti.yaml"
settings = ["-jacobian_dense_below", 0, "-jacobian_mat_type", "aij", "-pc_factor_zeropivot", "1e30", "-analysis_end_time", 0.5]
reference = f"{work}/handover_reference.h5"
handovers = run(1, source, "-output_file", reference, "-output_overwrite", *settings).stdout.count(HANDOVER)
check.equal("handover: lines saying the uninterrupted run handed the banded LU over to MUMPS", handovers, 1)
continued = f"{work}/handover_continued.h5"
run(1, source, "-output_file", continued, "-output_overwrite", "-quiet", "-checkpoint_every", 20, *settings)
with h5py.File(continued.replace(".h5", ".ckpt.h5"), "r") as f:
    check.equal("handover: the checkpoint records it (/run/pivoting_lu)", float(f["run/pivoting_lu"][0]), 1.0)
    checkpoint_step = int(f["run/numbers"][0])
restarted = run(1, "--restart", continued.replace(".h5", ".ckpt.h5"))
check.true(f"handover: checkpoint step > 0 ({checkpoint_step})", checkpoint_step > 0)
check.equal("handover: lines saying the restart handed the LU over again", restarted.stdout.count(HANDOVER), 0)
difference, compared = largest_difference(read_all(reference), read_all(continued))
print(f"handover: restart at step {checkpoint_step}: {compared} datasets, largest difference {difference:.3e}")
check.less("handover: restarted run equals the uninterrupted one", difference, 1e-300)
check.finish()
