"""Shared helpers for the regression tests: run the real msflex executable (serial or under
mpiexec) and read its HDF5 output. Every check compares numbers with explicit tolerances."""

import argparse
import os
import subprocess
import sys

import h5py
import numpy as np


def parse_arguments(description):
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--msflex", required=True, help="path of the msflex executable")
    parser.add_argument("--source-dir", required=True, help="repository root")
    parser.add_argument("--work-dir", required=True, help="directory for this test's output files")
    parser.add_argument("--mpiexec", default="mpiexec", help="MPI launcher")
    parser.add_argument("--np", type=int, default=1, help="MPI ranks for the main run")
    parser.add_argument("--input", help="input file relative to the source directory, for tests that take one")
    parser.add_argument("--options", default="", help="extra msflex options for every run, space separated")
    args = parser.parse_args()
    os.makedirs(args.work_dir, exist_ok=True)
    return args


def mpi_launcher(mpiexec, np_ranks):
    """The command prefix that starts np_ranks ranks (nothing for one rank); oversubscribes when
    there are more ranks than cores."""
    if np_ranks <= 1:
        return []
    command = [mpiexec, "-n", str(np_ranks)]
    if np_ranks > (os.cpu_count() or 1):
        command.append("--oversubscribe")
    return command


def run_msflex(args, input_file, output_file, extra=(), np_ranks=None, expect_success=True):
    """Runs msflex and returns (returncode, stdout, stderr)."""
    np_ranks = args.np if np_ranks is None else np_ranks
    command = []
    if np_ranks > 1:
        command += [args.mpiexec, "-n", str(np_ranks)]
        if np_ranks > (os.cpu_count() or 1):
            command.append("--oversubscribe")
    command += [args.msflex, input_file, "-output_file", output_file, "-output_overwrite"] + args.options.split() + list(extra)
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    if expect_success and result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr)
        raise SystemExit(f"msflex failed ({result.returncode}): {' '.join(command)}")
    return result.returncode, result.stdout, result.stderr


def probe_history(path, probe):
    """time column and the probe's datasets as numpy arrays."""
    with h5py.File(path, "r") as f:
        data = {"time": f["history/time"][()]}
        for name, dataset in f["probes"][probe].items():
            data[name] = dataset[()]
    return data


def history(path):
    with h5py.File(path, "r") as f:
        return {name: dataset[()] for name, dataset in f["history"].items()}


def final_frame(path):
    """The last frame's datasets and attributes."""
    with h5py.File(path, "r") as f:
        frames = f["frames"]
        last = frames[sorted(frames.keys())[-1]]
        data = {name: dataset[()] for name, dataset in last.items()}
        data["time"] = float(last.attrs["time"])
        return data


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def expm(v):
    """exp of hat(v): the rotation by |v| about v."""
    angle = np.linalg.norm(v)
    if angle == 0.0:
        return np.eye(3)
    K = skew(v / angle)
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def quaternion_matrix(q):
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def row_at_time(data, t, tolerance=1e-12):
    rows = np.nonzero(np.abs(data["time"] - t) <= tolerance * max(1.0, abs(t)))[0]
    if len(rows) != 1:
        raise SystemExit(f"expected exactly one history row at t = {t}, found {len(rows)}")
    return rows[0]


class Checker:
    """Collects comparisons, prints each with its measured value, fails at the end if any failed."""

    def __init__(self, name):
        self.name = name
        self.failures = 0

    def less(self, label, value, limit):
        ok = bool(np.isfinite(value)) and value < limit
        print(f"{'ok  ' if ok else 'FAIL'} {label}: {value:.3e} (limit {limit:.1e})")
        self.failures += 0 if ok else 1

    def finish(self):
        if self.failures:
            raise SystemExit(f"{self.name}: {self.failures} check(s) failed")
        print(f"{self.name}: all checks passed")
