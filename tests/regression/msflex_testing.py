"""Shared helpers for the regression tests: run the real msflex executable (serial or under
mpiexec) and read its HDF5 output. Every check compares numbers with explicit tolerances (Checker.less), counts
exactly (Checker.equal) or asserts a yes/no condition (Checker.true)."""

import argparse
import os
import signal
import subprocess
import sys

import h5py
import numpy as np

# The post-processing scripts' reader of the history (postproc/msflex_h5.py), for every layout.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "postproc"))
import msflex_h5  # noqa: E402


# scripts/bench-dynamics' cantilever at 40 two-node elements: L = 10, root clamped, a tip force
# switched on within 1 ms and held, 20 steps of 10 ms (one period of the first bending mode), so
# that every step needs 3-4 Newton iterations. `extra`: further lines of the analysis section.
DYNAMIC_CANTILEVER = """
functions:
  - {{name: step, type: table, points: [[0, 0], [0.001, 1]]}}
sections:
  - {{name: s, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5, rhoA: 1.0, rhoJ: [2.0e-2, 1.0e-2, 1.0e-2]}}
nodes:
  root: [0, 0, 0]
  tip: [10, 0, 0]
beams:
  - {{name: beam, section: s, from: root, to: tip, elements: 40}}
supports:
  - {{nodes: root, fix: all}}
loads:
  - {{nodes: tip, force: [0, 1000, 2000], function: step}}
analysis:
  type: dynamic
  integrator: {integrator}
  end_time: 0.2
  initial_step: 0.01
  max_step: 0.01
{extra}"""


def write_dynamic_cantilever(path, integrator, extra=""):
    """Writes DYNAMIC_CANTILEVER with the given integrator to path; returns path."""
    with open(path, "w") as f:
        f.write(DYNAMIC_CANTILEVER.format(integrator=integrator, extra=extra))
    return path


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


def run_with_timeout(command, cwd, timeout):
    """Runs command in its own session; returns (stdout, stderr, exit status), or None when it did
    not end within `timeout` s. A hung run gets SIGTERM first (mpiexec then takes its ranks down
    with it, which SIGKILL would not let it do), SIGKILL after 10 s more."""
    process = subprocess.Popen(command, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace",
                               start_new_session=True)
    try:
        stdout, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
        return None
    return stdout, stderr, process.returncode


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


def run_input(args, name, extra=("-quiet",)):
    """Runs tests/regression/inputs/<name>.yaml into <work_dir>/<name>.h5 and returns that path
    and its history (history())."""
    output = f"{args.work_dir}/{name}.h5"
    run_msflex(args, f"{args.source_dir}/tests/regression/inputs/{name}.yaml", output, extra=list(extra))
    return output, history(output)


def probe_history(path, probe):
    """time column and the probe's quantities as numpy arrays: position, displacement (rows x 3),
    rotation (rows x 4, w x y z), rotation_angle (rows)."""
    with msflex_h5.HistoryFile(path) as h:
        data = {"time": h.read("time")}
        for quantity, components in (("position", "xyz"), ("displacement", "xyz"), ("rotation", "wxyz")):
            data[quantity] = np.column_stack([h.read(f"{probe}.{quantity}.{c}") for c in components])
        data["rotation_angle"] = h.read(f"{probe}.rotation_angle")
    return data


def history(path):
    """Every series of the history table (docs/output.md), {name: array}; probes' columns included."""
    with msflex_h5.HistoryFile(path) as h:
        return h.read_all()


# The result file's frames (since "msflex result 2"): /frames/step, /frames/time and /frames/contents
# list the frames in the order written (steps rising); every other dataset of /frames is
# frames x rows x columns, frame k being its entry [k]. A dataset exists when any frame has it; a
# frame without it (its bit of /frames/contents not set) holds zeros there. FRAME_CONTENT_BIT: the
# bit each per-frame dataset needs (0: every frame has it).
FRAME_LISTS = ("step", "time", "contents")
FRAME_CONTENT_BIT = {
    "position": 0, "displacement": 0, "rotation": 0, "element_resultants": 0, "element_strains": 0, "segment_force": 0, "segment_moment": 0,
    "velocity": 1, "angular_velocity": 1,
    "segment_e1": 2, "segment_e2": 2, "segment_e3": 2,
    "body_center": 4, "body_axis_1": 4, "body_axis_2": 4, "body_axis_3": 4, "body_rotation": 4,
    "joint_position": 8, "joint_a1": 8, "joint_a2": 8, "joint_a3": 8,
}


def frame_count(h5file):
    """Number of frames in an open result file (the length of /frames/step)."""
    return len(h5file["frames/step"])


def _frame_datasets(h5file):
    """The per-frame datasets of /frames by name; raises on a dataset this table does not know
    (so that a new output field is added to FRAME_CONTENT_BIT rather than read blindly)."""
    datasets = {name: dataset for name, dataset in h5file["frames"].items() if name not in FRAME_LISTS}
    unknown = sorted(set(datasets) - set(FRAME_CONTENT_BIT))
    if unknown:
        raise SystemExit(f"{h5file.filename}: unknown frame datasets {unknown}; add them to FRAME_CONTENT_BIT")
    return datasets


def _frame_dict(step, time, contents, values):
    """One frame's dict: step, time, and the values (name -> array of that frame) whose bit is set."""
    data = {"step": int(step), "time": float(time)}
    for name, value in values.items():
        bit = FRAME_CONTENT_BIT[name]
        if bit == 0 or (contents & bit):
            data[name] = value
    return data


def frame(h5file, k):
    """Frame k (0-based, in the order written; negative counts from the end) of an open result
    file: a dict with "step" (int), "time" (float) and each per-frame dataset that the frame has
    (name -> numpy array of its rows x columns)."""
    count = frame_count(h5file)
    if not -count <= k < count:
        raise IndexError(f"{h5file.filename}: frame {k} of {count}")
    k = k % count
    lists = h5file["frames"]
    return _frame_dict(lists["step"][k], lists["time"][k], int(lists["contents"][k]),
                       {name: dataset[k] for name, dataset in _frame_datasets(h5file).items()})


def frames(h5file):
    """Every frame of an open result file, in the order written: a list of frame(h5file, k) dicts
    (each dataset is read once)."""
    lists = h5file["frames"]
    steps, times, contents = (lists[name][()] for name in FRAME_LISTS)
    data = {name: dataset[()] for name, dataset in _frame_datasets(h5file).items()}
    return [_frame_dict(steps[k], times[k], int(contents[k]), {name: values[k] for name, values in data.items()}) for k in range(len(steps))]


def final_frame(path):
    """The last frame of the result file `path`: frame(f, -1), its datasets with "step" and "time"."""
    with h5py.File(path, "r") as f:
        return frame(f, -1)


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

    def greater(self, label, value, limit):
        ok = bool(np.isfinite(value)) and value > limit
        print(f"{'ok  ' if ok else 'FAIL'} {label}: {value:.3e} (at least {limit:.1e})")
        self.failures += 0 if ok else 1

    def true(self, label, condition):
        """A yes/no check: passes when condition is True."""
        ok = condition is True or (isinstance(condition, (bool, np.bool_)) and bool(condition))
        print(f"{'ok  ' if ok else 'FAIL'} {label}")
        self.failures += 0 if ok else 1

    def equal(self, label, actual, expected):
        """An exact count (exit status, lines, modes, frames): passes when actual is the whole number expected."""
        ok = bool(np.isfinite(actual)) and float(actual).is_integer() and int(actual) == int(expected)
        print(f"{'ok  ' if ok else 'FAIL'} {label}: {actual} (expected {expected})")
        self.failures += 0 if ok else 1

    def finish(self):
        if self.failures:
            raise SystemExit(f"{self.name}: {self.failures} check(s) failed")
        print(f"{self.name}: all checks passed")


def expected_results(input_file):
    """The `expected` entries of an input (docs/input.md, "expected"), as dicts."""
    import yaml
    with open(input_file) as f:
        return yaml.safe_load(f).get("expected") or []


def series_values(f, series):
    """A series as postproc/msflex_h5.py names it (a column of the history table: time,
    <probe>.position.x, <probe>.rotation_angle, ...), or else any numeric dataset by its path,
    flattened."""
    with msflex_h5.HistoryFile(f.filename) as history:
        if series in history.names():
            return history.read(series)
    if series in f:
        return f[series][()].astype(float).ravel()
    raise KeyError(f"no series {series!r} (postproc/msflex-history lists them) nor a dataset of that path")


def check_expected(check, input_file, result_file, label, end_time=None):
    """Checks the input's expected results against its result file. An entry at a time after
    `end_time` (a run shortened by -analysis_end_time), or a statistic over the whole run when the
    run was shortened, is skipped and said so. Returns (checked, skipped)."""
    checked = skipped = 0
    with h5py.File(result_file, "r") as f:
        with msflex_h5.HistoryFile(result_file) as h:
            times = h.read("time") if "time" in h.names() else None
        for entry in expected_results(input_file):
            series = entry["series"]
            where = f"t = {entry['time']}" if "time" in entry else entry["statistic"]
            name = f"{label}: {series} ({where})"
            if end_time is not None and ("statistic" in entry or entry["time"] > end_time * (1 + 1e-12)):
                print(f"skip {name}: beyond the shortened run (end_time {end_time})")
                skipped += 1
                continue
            try:
                values = series_values(f, series)
            except KeyError as error:
                check.true(f"{name}: the series exists ({error})", False)
                continue
            if "time" in entry:
                rows = np.nonzero(np.abs(times - entry["time"]) <= 1e-9 * max(1.0, abs(entry["time"])))[0]
                if len(rows) != 1:
                    check.equal(f"{name}: history rows at that time (the steps must land on it: output_times)", len(rows), 1)
                    continue
                value = values[rows[0]]
            else:
                # NaN marks rows without a value (e.g. critical_load_factor away from critical points).
                value = {"final": lambda v: v[-1], "max": np.nanmax, "min": np.nanmin, "max_abs": lambda v: np.nanmax(np.abs(v)),
                         "range": lambda v: np.nanmax(v) - np.nanmin(v)}[entry["statistic"]](values)
            if "value" in entry:
                allowed = entry["tolerance"] if "tolerance" in entry else entry["relative_tolerance"] * abs(entry["value"])
                print(f"     {name} = {value:.10g}, expected {entry['value']:.10g}")
                check.less(f"{name}: |value - {entry['value']:.10g}| (tolerance)", abs(value - entry["value"]), allowed * (1 + 1e-12) + 1e-300)
            if "below" in entry:
                check.less(f"{name} = {value:.6g}: value - below", value - entry["below"], 0.0)
            if "above" in entry:
                check.less(f"{name} = {value:.6g}: above - value", entry["above"] - value, 0.0)
            checked += 1
    return checked, skipped
