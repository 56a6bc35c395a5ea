"""File faults through the executable (issue 16, docs/options.md "Files msflex writes"): each case
sets up files in a scratch directory, records every file's bytes (and every symbolic link's
target), runs msflex on 1 rank and on --np ranks, and checks

  - the exit status (1 for a fault, on every rank; 0 for the cases that must simply not write
    through a link),
  - exactly one line 'msflex: ...' holding 'error' and the case's expected fragments (the path
    and the reason), and no trace-back: no 'PETSC ERROR', 'HDF5-DIAG', 'MPI_ABORT', '#0' or
    'Traceback',
  - every file that existed before is unchanged byte for byte, and a failed run leaves no new
    file (no temporary either).

The cases cover every rule of issue 16: aliases of the run's files (also through links and
`..`), foreign files that must not be replaced, symbolic links at temporary names, missing,
unwritable and directory paths, names that are not HDF5 path components, counts beyond what a
file holds, and corrupted checkpoints of many kinds made from a real one; a control restart from
an intact checkpoint must continue the run. "Unwritable" is /sys (the tests run as root, which
permission bits do not stop; sysfs refuses every new file).

Each rank runs through a small wrapper that records its own exit status and exits 0, so that
mpiexec lets every rank finish (see test_bad_input_cli.py)."""

import argparse
import concurrent.futures
import hashlib
import os
import re
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import msflex_testing  # noqa: E402

import h5py  # noqa: E402
import numpy as np  # noqa: E402

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--msflex", required=True, help="path of the msflex executable")
parser.add_argument("--source-dir", required=True, help="repository root")
parser.add_argument("--work-dir", required=True, help="directory for this test's runs")
parser.add_argument("--mpiexec", default="mpiexec", help="MPI launcher")
parser.add_argument("--np", type=int, default=2, help="ranks of the parallel runs (1: serial runs only)")
parser.add_argument("--jobs", type=int, default=2, help="cases run at the same time")
parser.add_argument("--only", nargs="*", help="case names to run")
parser.add_argument("--timeout", type=float, default=120.0)
args = parser.parse_args()
args.msflex = os.path.abspath(args.msflex)

TRACE_MARKERS = ["PETSC ERROR", "HDF5-DIAG", "MPI_ABORT", "#0", "Traceback"]
STATUS_PREFIX = "rank-status."

MODEL = """sections:
  - {name: steel, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5, rhoA: 1.0, rhoJ: [0.1, 0.05, 0.05]}
nodes:
  root: [0, 0, 0]
  tip: [1, 0, 0]
beams:
  - {name: arm, section: steel, from: root, to: tip, elements: 4}
supports:
  - {nodes: root, fix: all}
loads:
  - {nodes: tip, force: [0, 0, -1]}
probes:
  - {name: PROBE, node: tip}
analysis: {type: dynamic, integrator: newmark, end_time: 0.04, initial_step: 0.01, max_step: 0.01}
"""
# Line and column of the probe's name in MODEL (for located errors).
PROBE_LINE = 13


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def model(directory, name="model.yaml", probe="tip", extra=""):
    write(os.path.join(directory, name), MODEL.replace("{name: PROBE", "{name: " + probe) + extra)
    return name


def run_plain(directory, command):
    """A set-up run (serial), which must succeed."""
    result = subprocess.run([args.msflex] + command, cwd=directory, capture_output=True, text=True, timeout=args.timeout)
    if result.returncode != 0:
        raise RuntimeError(f"set-up run failed ({result.returncode}): {result.stdout}{result.stderr}")


def checkpointed_run(directory):
    """model.yaml run to the end with a checkpoint every step: out.h5, out.xmf, out.ckpt.h5."""
    model(directory)
    run_plain(directory, ["model.yaml", "-output_file", "out.h5", "-checkpoint_every", "1", "-quiet"])


FOOTER_MAGIC = b"MSFLXSUM"


def refooter(path):
    """The checkpoint's whole-file checksum made to match its bytes again (AppendCheckpointFooter in
    src/core/hdf5_files.cpp: "MSFLXSUM" and FNV-1a 64 of every byte before it), so that an edit made
    through h5py reaches the checks behind it; a stale footer left at the end is replaced."""
    data = bytearray(open(path, "rb").read())
    if len(data) >= 16 and data[-16:-8] == FOOTER_MAGIC:
        del data[-16:]
    value = 14695981039346656037
    for byte in data:
        value = ((value ^ byte) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    open(path, "wb").write(bytes(data) + FOOTER_MAGIC + value.to_bytes(8, "little"))


def corrupt(path, edit):
    with h5py.File(path, "r+") as f:
        edit(f)
    if path.endswith(".ckpt.h5"):
        refooter(path)


def flip_file_byte(offset, bit):
    """A raw bit flip in the checkpoint, its checksum left as it was (restart_case's raw_edit)."""
    def edit(path):
        data = bytearray(open(path, "rb").read())
        data[offset] ^= 1 << bit
        open(path, "wb").write(bytes(data))
    return edit


def flip_number_bit(index, bit):
    def edit(f):
        numbers = f["run/numbers"][()]
        raw = numbers.view(np.uint64)
        raw[index] ^= np.uint64(1 << bit)
        f["run/numbers"][...] = raw.view(np.float64)
    return edit


def set_number(index, value):
    def edit(f):
        numbers = f["run/numbers"][()]
        numbers[index] = value
        f["run/numbers"][...] = numbers
    return edit


def replace_dataset(name, make):
    def edit(f):
        del f[name]
        make(f, name)
    return edit


def hollow(shape, dtype="f8"):
    """A chunked dataset of `shape` whose chunks are never written: big header, tiny file."""
    def make(f, name):
        f.create_dataset(name, shape=shape, dtype=dtype, chunks=tuple(min(s, 1024) for s in shape))
    return make


class Case:
    def __init__(self, name, setup, fragments, status=1, may_change=(), verify=None, serial_only=False):
        self.name, self.setup, self.fragments, self.status = name, setup, fragments, status
        self.may_change, self.verify, self.serial_only = may_change, verify, serial_only


def located(file, line):
    return rf"{re.escape(file)}:{line}:\d+: error: "


# ---- the cases -------------------------------------------------------------------------------
# setup(directory) writes the files and returns the command-line arguments; fragments are regular
# expressions that the one error line must match (path and reason).

def mesh_hollow(directory):
    write(os.path.join(directory, "model.yaml"), """mesh: mesh.h5
sections:
  - {name: steel, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5}
supports:
  - {nodes: n0, fix: all}
""")
    with h5py.File(os.path.join(directory, "mesh.h5"), "w") as f:
        f.create_dataset("nodes/coordinates", shape=(400000000, 3), dtype="f8", chunks=(4096, 3))
        f.create_dataset("beams/nodes", data=np.array([[0, 1]], dtype=np.int64))
    return ["model.yaml"]


def mesh_named_like_the_result(directory):
    """A valid mesh named model.h5, the default result file of model.yaml, run with -output_overwrite."""
    write(os.path.join(directory, "model.yaml"), """mesh: model.h5
sections:
  - {name: steel, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5}
supports:
  - {nodes: n0, fix: all}
loads:
  - {nodes: n1, force: [0, 1, 0]}
""")
    with h5py.File(os.path.join(directory, "model.h5"), "w") as f:
        f.create_dataset("nodes/coordinates", data=np.array([[0.0, 0, 0], [1.0, 0, 0]]))
        f.create_dataset("beams/nodes", data=np.array([[0, 1]], dtype=np.int64))
        f.create_dataset("beams/section", data=np.array([0], dtype=np.int64))
        f.create_dataset("beams/elements", data=np.array([2], dtype=np.int64))
        f.create_dataset("beams/order", data=np.array([1], dtype=np.int64))
    return ["model.yaml", "-output_overwrite"]


def link_victim(directory, link):
    write(os.path.join(directory, "victim.txt"), "precious\n")
    os.symlink("victim.txt", os.path.join(directory, link))


def fingerprint(input_text, options):
    """ModelFingerprint (src/core/file_safety.cpp): SHA-256 of a tag and each field with its length."""
    digest = hashlib.sha256(b"msflex model 1\n")
    for field in (input_text, options):
        digest.update(len(field).to_bytes(8, "little"))
        digest.update(field)
    return "sha256:" + digest.hexdigest()


def set_text(name, text, refingerprint=False):
    """Replaces the stored text `name` (bytes); with refingerprint the marker is made to match."""
    def edit(f):
        del f[name]
        f.create_dataset(name, data=np.frombuffer(text, dtype=np.int8))
        if refingerprint:
            f.attrs["msflex_model"] = fingerprint(f["run/input_text"][()].tobytes(), f["run/options"][()].tobytes())
    return edit


def append_text(name, extra):
    def edit(f):
        set_text(name, f[name][()].tobytes() + extra)(f)
    return edit


def set_attribute(name, value):
    def edit(f):
        f.attrs[name] = value
    return edit


def delete(name):
    def edit(f):
        del f[name]
    return edit


def rechecksum(edit):
    """`edit`, then the run record's checksum made to match (RunRecordChecksum in
    src/state/checkpoint.cpp: FNV-1a 64 of the numbers, the LU flag and each text with its length,
    its top 53 bits), so that the edit reaches the checks behind it."""
    def edited(f):
        edit(f)
        hash_value = 14695981039346656037
        def feed(data):
            nonlocal hash_value
            for byte in data:
                hash_value = ((hash_value ^ byte) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
        feed(np.asarray(f["run/numbers"][()], dtype="<f8").tobytes())
        feed(np.asarray(f["run/pivoting_lu"][()], dtype="<f8").tobytes())
        for name in ("input_file", "input_text", "options", "output_file", "mesh_fingerprint"):
            text = f[f"run/{name}"][()].tobytes() if f"run/{name}" in f else b""
            feed(len(text).to_bytes(8, "little"))
            feed(text)
        f["run/checksum"][...] = np.array([float(hash_value >> 11)])
    return edited


def restart_case(name, edit, fragments, arguments=("-analysis_end_time", "0.08"), result_edit=None, raw_edit=None):
    """A run checkpointed at every step; `edit` corrupts its checkpoint (or `result_edit` its
    result file); then the restart, which must refuse it and change nothing."""
    def setup(d):
        checkpointed_run(d)
        if edit:
            corrupt(os.path.join(d, "out.ckpt.h5"), edit)
        if raw_edit:
            raw_edit(os.path.join(d, "out.ckpt.h5"))
        if result_edit:
            corrupt(os.path.join(d, "out.h5"), result_edit)
        return ["--restart", "out.ckpt.h5"] + list(arguments)
    return Case(name, setup, [r"out\.ckpt\.h5"] + fragments if not result_edit else fragments)


def drop_frame(step):
    """Removes the frame of `step` from a result file: its row of every /frames dataset (the others
    move up, and the datasets shrink by one frame)."""
    def edit(f):
        keep = f["frames/step"][()] != step
        if keep.all():
            raise RuntimeError(f"the result file has no frame for step {step} to remove")
        for dataset in f["frames"].values():
            rows = dataset[()][keep]
            dataset.resize(len(rows), axis=0)
            dataset[...] = rows
    return edit


def foreign_checkpoint(d):
    with h5py.File(os.path.join(d, "c.h5"), "w") as f:
        f.create_dataset("run/numbers", data=np.zeros(11))
    return ["--restart", "c.h5"]


def damaged_heap_output(d):
    """An existing output file whose marker is a variable-length string (as files of earlier
    msflex versions and h5py's have it) with a damaged global heap: its first object's size made
    larger by 256 bytes, on which HDF5's read loops for ever (as on the bit flips of a user
    trial)."""
    path = os.path.join(d, "out.h5")
    with h5py.File(path, "w") as f:
        f.attrs["msflex_format"] = "msflex result 3"
    data = bytearray(open(path, "rb").read())
    heap = data.find(b"GCOL")
    if heap < 0:
        raise RuntimeError("h5py wrote no global heap for a string attribute")
    data[heap + 25] ^= 0x01  # object 1's size (a 64-bit field at offset 24), second byte
    open(path, "wb").write(bytes(data))
    return [model(d), "-output_file", "out.h5", "-file_read_timeout", "1"]


def foreign_output_restart(d):
    checkpointed_run(d)
    os.remove(os.path.join(d, "out.h5"))
    with h5py.File(os.path.join(d, "out.h5"), "w") as f:
        f.create_dataset("data", data=np.arange(10.0))
    return ["--restart", "out.ckpt.h5", "-analysis_end_time", "0.08"]


def restart_continues_check(d):
    """The control: a valid checkpoint restarts and the result file grows to the new end."""
    time = msflex_testing.history(os.path.join(d, "out.h5"))["time"]
    rows, end = time.shape[0], time[-1]
    with h5py.File(os.path.join(d, "out.h5"), "r") as f:
        frames = msflex_testing.frame_count(f)
    failures = []
    if rows != 9 or abs(end - 0.08) > 1e-12 or frames != 9:
        failures.append(f"after the restart: {rows} history rows to t = {end}, {frames} frames; expected 9 rows to 0.08 and 9 frames")
    return failures


CASES = [
    # (4) names that are not HDF5 path components: located errors of the reader
    Case("probe_name_slash", lambda d: [model(d, probe="a/b")],
         [located("model.yaml", PROBE_LINE), r"probe name 'a/b' cannot begin the names of its history columns", r"contains '/'"]),
    Case("probe_name_dot", lambda d: [model(d, probe=".")],
         [located("model.yaml", PROBE_LINE), r"probe name '\.'", r"'\.' means the current group"]),
    Case("probe_name_root", lambda d: [model(d, probe="/")], [located("model.yaml", PROBE_LINE), r"probe name '/'"]),
    Case("joint_name_slash",
         lambda d: [model(d, extra="joints:\n  - {name: arm/hinge, type: rigid, master: ground, slave: tip}\n")],
         [located("model.yaml", 16), r"joint name 'arm/hinge' cannot begin the names of its history series", r"contains '/'"]),
    # (5) counts the file cannot hold
    Case("mesh_counts_beyond_file", mesh_hollow,
         [located("model.yaml", 1), r"mesh\.h5: /nodes/coordinates: claims 1200000000 entries \(9600000000 bytes\) but the file holds only 0 bytes"]),
    # (1) never write over what the run did not create
    Case("checkpoint_is_input", lambda d: [model(d), "-checkpoint_file", "model.yaml"],
         [r"checkpoint file 'model\.yaml' is the same file as the input file 'model\.yaml'"]),
    Case("checkpoint_is_unrelated_file", lambda d: (write(os.path.join(d, "notes.txt"), "keep\n"), [model(d), "-checkpoint_file", "notes.txt"])[1],
         [r"refusing to replace the checkpoint file 'notes\.txt': it is a file that msflex did not write"]),
    Case("output_is_input", lambda d: [model(d), "-output_file", "model.yaml", "-output_overwrite"],
         [r"output file 'model\.yaml' is the same file as the input file 'model\.yaml'"]),
    Case("output_is_input_by_link", lambda d: (model(d), os.symlink("model.yaml", os.path.join(d, "link.h5")),
                                               ["model.yaml", "-output_file", "link.h5", "-output_overwrite"])[-1],
         [r"output file 'link\.h5' is the same file as the input file 'model\.yaml'"]),
    Case("checkpoint_is_output", lambda d: [model(d), "-output_file", "out.h5", "-checkpoint_file", "./out.h5"],
         [r"checkpoint file '\./out\.h5' is the same file as the output file 'out\.h5'"]),
    Case("checkpoint_is_output_by_dotdot", lambda d: (os.mkdir(os.path.join(d, "sub")), [model(d), "-output_file", "out.h5", "-checkpoint_file", "sub/../out.h5"])[1],
         [r"checkpoint file 'sub/\.\./out\.h5' is the same file as the output file 'out\.h5'"]),
    Case("output_is_mesh", mesh_named_like_the_result, [r"output file 'model\.h5' is the same file as the mesh file"]),
    Case("sidecar_exists", lambda d: (write(os.path.join(d, "out.xmf"), "<my notes/>\n"), [model(d), "-output_file", "out.h5"])[1],
         [r"refusing to replace the XDMF sidecar 'out\.xmf': it is a file that msflex did not write"]),
    Case("sidecar_exists_overwrite", lambda d: (write(os.path.join(d, "out.xmf"), "<my notes/>\n"), [model(d), "-output_file", "out.h5", "-output_overwrite"])[1],
         [r"refusing to replace the XDMF sidecar 'out\.xmf'"]),
    Case("overwrite_foreign_hdf5", lambda d: (h5py.File(os.path.join(d, "out.h5"), "w").close(), [model(d), "-output_file", "out.h5", "-output_overwrite"])[1],
         [r"refusing to replace the output file 'out\.h5': it is a file that msflex did not write"]),
    Case("output_exists_without_overwrite", lambda d: (checkpointed_run(d), ["model.yaml", "-output_file", "out.h5"])[-1],
         [r"output file 'out\.h5' exists; pass -output_overwrite to replace it"]),
    # (2) temporaries are new files: a link at the old fixed names is never written through
    Case("sidecar_temporary_is_link", lambda d: (link_victim(d, "out.xmf.tmp"), [model(d), "-output_file", "out.h5", "-quiet"])[1], [], status=0),
    Case("checkpoint_temporary_is_link",
         lambda d: (link_victim(d, "out.ckpt.h5.tmp"), [model(d), "-output_file", "out.h5", "-checkpoint_every", "1", "-quiet"])[1], [], status=0),
    Case("result_temporary_is_link", lambda d: (link_victim(d, "out.h5.tmp"), [model(d), "-output_file", "out.h5", "-quiet"])[1], [], status=0),
    # (4) file-system errors are one line with the path and the reason
    Case("output_missing_directory", lambda d: [model(d), "-output_file", "nowhere/out.h5"],
         [r"cannot create output file 'nowhere/out\.h5': No such file or directory"]),
    Case("output_is_directory", lambda d: (os.mkdir(os.path.join(d, "adir")), [model(d), "-output_file", "adir"])[1],
         [r"cannot create output file 'adir': Is a directory"]),
    Case("output_under_a_file", lambda d: [model(d), "-output_file", "model.yaml/out.h5"], [r"cannot create output file 'model\.yaml/out\.h5': Not a directory"]),
    # Unwritable: the tests run as root, which access(2) and chmod do not stop; sysfs refuses
    # every new file (EACCES) whoever asks.
    Case("output_unwritable", lambda d: [model(d), "-output_file", "/sys/msflex-out.h5"], [r"cannot create '/sys/msflex-out\.h5\.tmp\.\w+': Permission denied"]),
    # (an empty value is no value to PETSc: the command line's check says so before any file)
    Case("output_empty_name", lambda d: [model(d), "-output_file", ""], [r"bad option: -output_file needs a value \(FILE\.h5\)"]),
    Case("checkpoint_missing_directory", lambda d: [model(d), "-checkpoint_file", "nowhere/c.h5"],
         [r"cannot create checkpoint file 'nowhere/c\.h5': No such file or directory"]),
    Case("checkpoint_under_a_file", lambda d: [model(d), "-checkpoint_file", "model.yaml/c.h5"],
         [r"cannot create checkpoint file 'model\.yaml/c\.h5': Not a directory"]),
    Case("output_is_device", lambda d: [model(d), "-output_file", "/dev/null"], [r"'/dev/null': it exists and is not a regular file"]),
    Case("input_is_hdf5", lambda d: (h5py.File(os.path.join(d, "result.h5"), "w").close(), ["result.h5", "-output_file", "out.h5"])[1],
         [r"'result\.h5' is an HDF5 file, not a YAML input"]),
    Case("restart_missing", lambda d: ["--restart", "none.ckpt.h5"], [r"cannot open 'none\.ckpt\.h5': No such file or directory"]),
    Case("restart_is_directory", lambda d: (os.mkdir(os.path.join(d, "adir")), ["--restart", "adir"])[1], [r"cannot open 'adir': Is a directory"]),
    Case("restart_not_hdf5", lambda d: (write(os.path.join(d, "c.h5"), "text\n"), ["--restart", "c.h5"])[1], [r"cannot open 'c\.h5': not an HDF5 file"]),
    Case("restart_foreign_hdf5", foreign_checkpoint, [r"'c\.h5' is not an msflex checkpoint: it is a file that msflex did not write"]),
    Case("restart_from_result_file", lambda d: (checkpointed_run(d), ["--restart", "out.h5"])[-1], [r"'out\.h5' is an msflex result file, not a checkpoint"]),
    # (3) corrupted checkpoints, each made from a real one: refused, nothing changes
    restart_case("restart_format_other", set_attribute("msflex_format", "msflex checkpoint 99"),
                 [r"has format 'msflex checkpoint 99'; this msflex reads 'msflex checkpoint 7'"]),
    restart_case("restart_marker_removed", lambda f: [f.attrs.__delitem__(k) for k in list(f.attrs)],
                 [r"has format 'msflex checkpoint 7' without file markers \(written by an earlier msflex\)"]),
    restart_case("restart_format_1", lambda f: ([f.attrs.__delitem__(k) for k in list(f.attrs)], set_text("run/format", b"msflex checkpoint 1")(f)),
                 [r"has format 'msflex checkpoint 1' without file markers"]),
    restart_case("restart_numbers_missing", delete("run/numbers"), [r"/run/numbers"]),
    restart_case("restart_nan_time", set_number(1, float("nan")), [r"/run/numbers entry 1 is not a finite number"]),
    restart_case("restart_numbers_wrong_length", replace_dataset("run/numbers", lambda f, n: f.create_dataset(n, data=np.ones(100000))),
                 [r"/run/numbers has 100000 entries, expected 13"]),
    restart_case("restart_pivoting_lu_half", replace_dataset("run/pivoting_lu", lambda f, n: f.create_dataset(n, data=np.array([0.5]))),
                 [r"/run/pivoting_lu is 0\.5, not 0 or 1"]),
    restart_case("restart_pivoting_lu_wrong_length", replace_dataset("run/pivoting_lu", lambda f, n: f.create_dataset(n, data=np.zeros(3))),
                 [r"/run/pivoting_lu has 3 entries, expected 1"]),
    # A damaged heap of variable-length strings: one line after -file_read_timeout, not a hang.
    # One rank only: the read cannot be interrupted, so rank 0 (which reads it) writes the line
    # and exits, and the MPI launcher ends the others (docs/options.md).
    Case("output_damaged_string_heap", damaged_heap_output,
         [r"reading '.*out\.h5' did not end within 1 s: HDF5 loops on a damaged part of it"], serial_only=True),
    restart_case("restart_step_huge", set_number(0, 1e30), [r"the step 1e\+30 is not an integer"]),
    restart_case("restart_step_nearly_integer", set_number(0, 4 + 2**-40), [r"the step \d+\.\d{6,} is not an integer"]),
    # A plausible number changed (a flipped bit in the time, the step size, the work): the run
    # record's checksum (it restarted at the wrong time).
    # A bit flipped in the HDF5 metadata (a user trial's sweep: a flip at byte 7228 made HDF5 read out
    # of range and crash in H5Dopen): the whole file's checksum refuses it before HDF5 reads it.
    restart_case("restart_metadata_bit_flipped", None, [r"is damaged: its bytes do not match the checksum at its end"], raw_edit=flip_file_byte(2100, 1)),
    restart_case("restart_footer_cut", None, [r"has no checksum at its end"], raw_edit=lambda path: open(path, "r+b").truncate(os.path.getsize(path) - 16)),
    restart_case("restart_time_changed", set_number(1, 0.001), [r"is damaged: its run record \(/run: time, step, work, texts\) does not match its checksum"]),
    restart_case("restart_work_bit_flipped", flip_number_bit(2, 0), [r"is damaged: its run record .* does not match its checksum"]),
    restart_case("restart_output_name_changed", set_text("run/output_file", b"other.h5"), [r"does not match its checksum"]),
    restart_case("restart_step_negative", set_number(0, -1), [r"the step -1 is not an integer"]),
    restart_case("restart_step_fraction", set_number(0, 2.5), [r"the step 2\.5 is not an integer"]),
    restart_case("restart_history_rows_inconsistent", set_number(4, 999), [r"history rows 999 do not match step 4 \(expected 5\)"]),
    restart_case("restart_last_written_beyond_step", set_number(3, 7), [r"the last written step 7 is beyond the step 4"]),
    restart_case("restart_controller_step_zero", set_number(5, 0.0), [r"step controller's step 0 is not positive"]),
    restart_case("restart_node_count_changed", rechecksum(set_number(7, 9)), [r"holds 9 nodes, 0 joints and 0 rigid bodies, but the model has 5"]),
    restart_case("restart_input_text_huge", replace_dataset("run/input_text", hollow((1 << 40,), "i1")), [r"/run/input_text claims 1099511627776 entries"]),
    restart_case("restart_input_altered", append_text("run/input_text", b"# edited\n"), [r"is damaged: its stored input and options do not match its fingerprint"]),
    restart_case("restart_options_altered", append_text("run/options", b" -analysis_end_time 9"),
                 [r"is damaged: its stored input and options do not match its fingerprint"]),
    restart_case("restart_input_unreadable", rechecksum(set_text("run/input_text", b"nodes: [1, 2\n", refingerprint=True)),
                 [r"model\.yaml:\d+:\d+: error: ", r"\(the input stored in out\.ckpt\.h5\)"]),
    restart_case("restart_nodes_wrong_shape", replace_dataset("nodes", lambda f, n: f.create_dataset(n, data=np.zeros((3, 32)))),
                 [r"/nodes has shape \(3, 32\), expected \(5, 32\)"]),
    restart_case("restart_nodes_hollow", replace_dataset("nodes", hollow((5, 32))), [r"/nodes claims 160 entries \(1280 bytes\) but the file holds only 0 bytes"]),
    restart_case("restart_node_state_nan", lambda f: f["nodes"].__setitem__((0, 0), float("nan")), [r"/nodes row 0 holds a value that is not a finite number"]),
    restart_case("restart_rotation_not_unit", lambda f: f["nodes"].__setitem__((2, 3), 2.0), [r"/nodes row 2: the rotation is not a unit quaternion"]),
    # one bit of a position's mantissa: finite, plausible, and caught only by the row's checksum
    restart_case("restart_node_bit_flip", lambda f: f["nodes"].__setitem__((1, 0), np.nextafter(f["nodes"][1, 0], np.inf)),
                 [r"/nodes row 1 does not match its checksum: the file is damaged"]),
    Case("restart_other_run",
         lambda d: (checkpointed_run(d), shutil.copy(os.path.join(d, "out.ckpt.h5"), os.path.join(d, "old.ckpt.h5")),
                    run_plain(d, ["model.yaml", "-output_file", "out.h5", "-output_overwrite", "-quiet"]),
                    ["--restart", "old.ckpt.h5", "-analysis_end_time", "0.08"])[-1], [r"out\.h5' belongs to another run than the checkpoint 'old\.ckpt\.h5'"]),
    Case("restart_into_foreign_output", foreign_output_restart, [r"refusing to replace the output file 'out\.h5': it is a file that msflex did not write"]),
    restart_case("restart_result_history_short", None, [r"'out\.h5': /history/values has 3 rows, the checkpoint expects 5"],
                 result_edit=lambda f: f["history/values"].resize(3, axis=0)),
    restart_case("restart_result_frame_missing", None, [r"'out\.h5' has no frame for step 4"],
                 result_edit=drop_frame(4)),
    restart_case("restart_result_frames_short", None, [r"'out\.h5': /frames/position has 3 frames, /frames/step 5"],
                 result_edit=lambda f: f["frames/position"].resize(3, axis=0)),
    restart_case("restart_end_before_checkpoint", None, [r"is at t = 0\.04, at or beyond the end time 0\.01"], arguments=("-analysis_end_time", "0.01")),
    # A restart from another directory: the run's result file (a relative path) is not there, and
    # the restart must not start a new one holding only the rest of the run.
    Case("restart_elsewhere", lambda d: (os.mkdir(os.path.join(d, "run")), checkpointed_run(os.path.join(d, "run")),
                                         ["--restart", "run/out.ckpt.h5", "-analysis_end_time", "0.08"])[-1],
         [r"the result file 'out\.h5' that the checkpoint 'run/out\.ckpt\.h5' continues is not there", r"pass -output_file FILE\.h5"]),
    # The control: the same restart from an intact checkpoint continues the run.
    Case("restart_continues", lambda d: (checkpointed_run(d), ["--restart", "out.ckpt.h5", "-analysis_end_time", "0.08", "-quiet"])[-1], [], status=0,
         may_change=("out.h5", "out.xmf", "out.ckpt.h5"), verify=restart_continues_check),
]


def snapshot(directory):
    """Every entry below `directory`: file bytes, link targets (links are not followed), directories."""
    entries = {}
    for root, dirs, files in os.walk(directory):
        for name in dirs + files:
            path = os.path.join(root, name)
            relative = os.path.relpath(path, directory)
            if relative.startswith(STATUS_PREFIX):
                continue
            if os.path.islink(path):
                entries[relative] = ("link", os.readlink(path))
            elif os.path.isdir(path):
                entries[relative] = ("dir", None)
            else:
                with open(path, "rb") as f:
                    entries[relative] = ("file", f.read())
    return entries


def run_case(case, ranks):
    directory = os.path.join(args.work_dir, f"{case.name}-np{ranks}")
    shutil.rmtree(directory, ignore_errors=True)
    os.makedirs(directory)
    try:
        arguments = case.setup(directory)
    except Exception as exception:  # a broken set-up must fail the case, not hide the others
        return [f"set-up failed: {exception!r}"], ""
    before = snapshot(directory)
    command = [args.msflex] + arguments
    if ranks > 1:
        wrapper = f'"$@"; echo $? > {STATUS_PREFIX}${{OMPI_COMM_WORLD_RANK:-$PMI_RANK}}; exit 0'
        command = msflex_testing.mpi_launcher(args.mpiexec, ranks) + ["sh", "-c", wrapper, "sh"] + command
    result = msflex_testing.run_with_timeout(command, directory, args.timeout)
    if result is None:
        return [f"no result within {args.timeout:.0f} s"], ""
    stdout, stderr, returncode = result
    failures = []
    if ranks > 1:
        if returncode != 0:
            failures.append(f"mpiexec exit status {returncode}")
        for rank in range(ranks):
            status_file = os.path.join(directory, f"{STATUS_PREFIX}{rank}")
            status = open(status_file).read().strip() if os.path.exists(status_file) else "none"
            if status != str(case.status):
                failures.append(f"rank {rank} exit status {status}, expected {case.status}")
    elif returncode != case.status:
        failures.append(f"exit status {returncode}, expected {case.status}")
    output = stdout + stderr
    for marker in TRACE_MARKERS:
        if marker in output:
            failures.append(f"trace-back marker {marker!r} printed")
    error_lines = [line for line in output.splitlines() if line.startswith("msflex:") and ("error" in line or "bad option" in line)]
    summary = error_lines[0] if error_lines else ""
    if case.status == 0:
        if error_lines:
            failures.append(f"error lines: {error_lines}")
    else:
        other = [line for line in output.splitlines() if "error" in line.lower() and line not in error_lines]
        if len(error_lines) != 1 or other:
            failures.append(f"{len(error_lines)} 'msflex: ... error ...' lines and {len(other)} other error lines")
        for fragment in case.fragments:
            if not error_lines or not re.search(fragment, error_lines[0]):
                failures.append(f"the error line does not match {fragment!r}")
    after = snapshot(directory)
    for name, entry in before.items():
        if name in case.may_change:
            continue
        if after.get(name) != entry:
            failures.append(f"pre-existing {name} changed" if name in after else f"pre-existing {name} removed")
    created = sorted(set(after) - set(before))
    if case.status != 0 and created:
        failures.append(f"a failed run created {', '.join(created)}")
    if case.verify and not failures:
        failures += case.verify(directory)
    leftovers = [name for name in created if ".tmp" in name]
    if leftovers:
        failures.append(f"temporaries left: {', '.join(leftovers)}")
    if failures:
        failures.append("output: " + output.strip()[:500])
    else:
        shutil.rmtree(directory)
    return failures, summary


os.makedirs(args.work_dir, exist_ok=True)
selected = CASES if not args.only else [case for case in CASES if case.name in args.only]
ranks_list = [1] + ([args.np] if args.np > 1 else [])
runs = [(case, ranks) for case in selected for ranks in ranks_list if ranks == 1 or not case.serial_only]
started = time.monotonic()
# Cases run side by side (each in its own directory); the results print in the cases' order.
with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
    results = list(pool.map(lambda run: run_case(*run), runs))
failed = 0
for (case, ranks), (failures, summary) in zip(runs, results):
    if failures:
        failed += 1
        print(f"FAIL np {ranks} {case.name}: " + "; ".join(failures))
    else:
        print(f"ok   np {ranks} {case.name}: {summary}")
print(f"{len(selected)} cases on {ranks_list} ranks in {time.monotonic() - started:.1f} s: {len(runs) - failed} runs passed, {failed} failed")
sys.exit(1 if failed else 0)
