"""Time series of an msflex result file (layout: docs/output.md), for the post-processing scripts.

A series is one column of the history table /history/values, named in /history/names (with its
unit and description in /history/units and /history/descriptions): the history series (time,
energies, joint coordinates and forces, ...) and per probe <probe>.position.x|y|z,
<probe>.displacement.x|y|z, <probe>.rotation.w|x|y|z and <probe>.rotation_angle. All series of a
file have one value per history row. Files of older msflex versions (`msflex result 2` and
before) held a dataset per series, /history/<name> and /probes/<probe>/<quantity>, with `unit`
and `description` attributes (or none); they are read as well.
"""

import difflib
import os
import re
import sys

# A running msflex holds its result file open for writing, and HDF5's file locking (on by default)
# then refuses every other opening of it ("unable to lock file", errno 11): without the lock the
# tools read the file's last flush (docs/output.md). HDF5 reads HDF5_USE_FILE_LOCKING when it
# starts, that is when h5py is imported; open_hdf5 also says locking=False (h5py 3.5 and later).
_LOCKING = os.environ.get("HDF5_USE_FILE_LOCKING")
os.environ["HDF5_USE_FILE_LOCKING"] = "FALSE"

import h5py  # noqa: E402  (after the environment above)
import numpy as np  # noqa: E402

# Where h5py takes locking=False, the environment is given back as it was: the programs started by
# a script that imports this module (msflex, run by the regression tests) keep HDF5's locking, which
# tells msflex that another process has its output file open. (render-paraview sets the variable
# itself, for the pvpython it starts.)
if tuple(int(v) for v in re.findall(r"\d+", h5py.version.version)[:2]) >= (3, 5):
    if _LOCKING is None:
        del os.environ["HDF5_USE_FILE_LOCKING"]
    else:
        os.environ["HDF5_USE_FILE_LOCKING"] = _LOCKING

# Older files: probe datasets and the names of their columns (None: a 1-D dataset, one value per row).
PROBE_COMPONENTS = {
    "position": "xyz",
    "displacement": "xyz",
    "rotation": "wxyz",
    "rotation_angle": None,
}

SERIES_HELP = """\
series names:
  <name>                        every history series, e.g. time (in statics the load factor,
                                or the path parameter under arc length or displacement control;
                                the mode number in modes and buckling analyses),
                                newton_iterations, residual_norm, step_size, <joint>.rz
  <probe>.position.x|y|z        probed point's current position (node, offset point, centre of mass)
  <probe>.displacement.x|y|z    probed point's displacement
  <probe>.rotation.w|x|y|z      probed node's rotation quaternion
  <probe>.rotation_angle        probed node's rotation angle (rad), in [0, 2 pi], not unwrapped
"""


def _text(value):
    return value.decode() if isinstance(value, bytes) else value


class UsageError(Exception):
    """A mistake on the command line; the scripts exit with status 2 for it."""


class FileError(OSError):
    """A file that is not an msflex result file, or one without history rows; the scripts exit
    with status 1 for it (as for any file that cannot be read)."""


def _dataset_text(dataset):
    """The text of a string dataset, or of one of characters (msflex checkpoints: int8 arrays)."""
    value = dataset[()]
    if hasattr(value, "dtype") and value.dtype.kind in "iu":
        return bytes(value.astype("uint8").tolist()).decode(errors="replace").rstrip("\0")
    if hasattr(value, "shape") and value.shape:
        value = value.ravel()[0] if value.size else b""
    return _text(value.item() if hasattr(value, "item") else value)


def _text_attribute(group, name):
    value = group.attrs.get(name)
    return None if value is None else _text(value.item() if hasattr(value, "item") else value)


def _is_lock_error(error):
    return "unable to lock file" in str(error).lower()


def _lock_message(path):
    """The one line for a file HDF5 refuses to open because another process holds it locked (these
    tools open files without locking, so this is an HDF5 library that locks all the same)."""
    return (f"cannot read {path}: HDF5 could not lock the file, which another program (a running msflex?) holds open"
            " for writing; this HDF5 library locks files even with HDF5_USE_FILE_LOCKING=FALSE, so wait for the run to end"
            " or read a copy of the file")


def _read_error(path, error):
    """The one line for an OSError of h5py opening `path`."""
    return _lock_message(path) if _is_lock_error(error) else f"cannot read {path}: {error}"


def open_hdf5(path):
    """h5py.File(path, "r") without HDF5 file locking (where h5py can say so; the environment
    variable set above does it for the others), so that a running msflex's file opens too."""
    try:
        return h5py.File(path, "r", locking=False)
    except TypeError:  # h5py before 3.5: no locking argument
        return h5py.File(path, "r")
    except OSError as error:
        # The file is open already in this process with HDF5's locking (a script that holds it
        # with h5py.File and asks this module too): HDF5 wants the same flag for both.
        if "locking flag values don't match" not in str(error):
            raise
        return h5py.File(path, "r")


def _results_of_checkpoint(checkpoint, stored):
    """Where a checkpoint's results are, as seen from here: the run stored its output file as it
    was given, relative to the directory the run started in."""
    if os.path.isabs(stored):
        return stored
    # Beside the checkpoint first (its default place): a file of that name in the directory this
    # tool runs in may be another run's.
    beside = os.path.join(os.path.dirname(checkpoint), os.path.basename(stored))
    if os.path.exists(beside):
        return beside
    if os.path.exists(stored):  # this tool runs where the run did (a checkpoint kept elsewhere)
        return stored
    return f"{stored} (relative to the directory its run started in)"


def open_result_file(path):
    """The msflex result file `path`, open for reading (an h5py.File); FileError, with a one-line
    message, for a missing file, a file that is not HDF5 (an XDMF sidecar, ...), an msflex
    checkpoint, or another program's HDF5 file. Files of older msflex versions carry no marker
    (the root attribute msflex_format) and are recognised by their /history group."""
    if not os.path.exists(path):
        raise FileError(f"{path}: no such file")
    if os.path.isdir(path):
        raise FileError(f"{path} is a directory, not an msflex result file")
    try:
        is_hdf5 = h5py.is_hdf5(path)
    except OSError as error:
        raise FileError(_read_error(path, error)) from None
    if not is_hdf5:
        with open(path, "rb") as f:
            head = f.read(4096)
        if b"msflex results" in head and b"<Xdmf" in head:
            beside = os.path.splitext(path)[0] + ".h5"
            raise FileError(f"{path} is an msflex XDMF sidecar, not a result file; the results are in the HDF5 file beside it ({beside})")
        raise FileError(f"{path} is not an HDF5 file, so not an msflex result file")
    try:
        f = open_hdf5(path)
    except OSError as error:
        raise FileError(_read_error(path, error)) from None
    try:
        marker = _text_attribute(f, "msflex_format") or ""
        if not marker and isinstance(f.get("run/format"), h5py.Dataset):  # checkpoints written before the marker
            marker = _dataset_text(f["run/format"])
            marker = marker if marker.startswith("msflex checkpoint") else ""
        if marker.startswith("msflex checkpoint"):
            results = ""
            if isinstance(f.get("run/output_file"), h5py.Dataset):
                results = f"; its run's results are in {_results_of_checkpoint(path, _dataset_text(f['run/output_file']))}"
            raise FileError(f"{path} is an msflex checkpoint, not a result file{results}")
        if marker and not marker.startswith("msflex result"):
            raise FileError(f"{path} is not an msflex result file (its msflex_format is '{marker}')")
        if not marker and "history" not in f:
            raise FileError(f"{path} is not an msflex result file (an HDF5 file without /history)")
    except BaseException:
        f.close()
        raise
    return f


class HistoryFile:
    """An open result file; use as a context manager. FileError (open_result_file) for a file that
    is not a result file."""

    def __init__(self, path):
        self._file = open_result_file(path)
        history = self._file.get("history", {})
        # Series name -> (dataset path, column or None for 1-D datasets), and -> (unit, description)
        # where the file keeps them in tables.
        self._series, self._quantities = {}, {}
        if "values" in history and "names" in history:
            names = [_text(n) for n in history["names"][()]]
            units = [_text(u) for u in history["units"][()]] if "units" in history else [None] * len(names)
            descriptions = [_text(d) for d in history["descriptions"][()]] if "descriptions" in history else [""] * len(names)
            for column, name in enumerate(names):
                self._series[name] = ("history/values", column)
                self._quantities[name] = (units[column], descriptions[column])
            return
        # An older file: a dataset per series, time first as in the writer (HDF5 lists names
        # alphabetically).
        for name in sorted(history, key=lambda n: (n != "time", n)):
            self._series[name] = ("history/" + name, None)
        for probe in self._file.get("probes", {}):
            for quantity, components in PROBE_COMPONENTS.items():
                dataset = f"probes/{probe}/{quantity}"
                if components is None:
                    self._series[f"{probe}.{quantity}"] = (dataset, None)
                else:
                    for column, component in enumerate(components):
                        self._series[f"{probe}.{quantity}.{component}"] = (dataset, column)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._file.close()

    def names(self):
        """All series of the file, in the writer's order (time first)."""
        return list(self._series)

    def rows(self):
        """Number of history rows (0 when the file has no series)."""
        if not self._series:
            return 0
        path, _ = self._series[next(iter(self._series))]
        return len(self._file[path])

    def require_rows(self):
        """FileError unless the file holds at least one history row: a run that stopped before its
        first row (or has not flushed it yet) leaves a result file with the model only."""
        if self.rows() == 0:
            raise FileError(f"{self._file.filename} holds no history rows: its run stopped before writing its initial state"
                            " (or has not flushed it yet), so there is nothing to list, print or plot")

    def analysis_type(self):
        """What the file holds: "static", "dynamic", "modes" or "buckling" (one row per mode, the
        time being the mode number)."""
        kind = _text_attribute(self._file, "analysis_type")
        if kind in ("modes", "buckling", "dynamic"):
            return kind
        if "mode" in self._series and "eigenvalue" in self._series:  # files of msflex before it named eigenanalyses
            return "modes" if "frequency" in self._series else "buckling"
        if kind is None:  # older files: dynamics writes kinetic_energy
            return "static" if "kinetic_energy" not in self._series else "dynamic"
        return "static"

    def is_static(self):
        """Whether the file holds a static analysis (its time is the pseudo-time, the load factor)."""
        return self.analysis_type() == "static"

    def quantity(self, name):
        """(unit, description) of series `name`; unit None when the file does not say."""
        self._check(name)
        if name in self._quantities:
            return self._quantities[name]
        path, column = self._series[name]
        attributes = self._file[path].attrs
        unit, description = _text(attributes.get("unit")), _text(attributes.get("description")) or ""
        if column is not None:
            description += f", {name.rsplit('.', 1)[-1]}"
        return unit, description

    def label(self, name):
        """Axis label of series `name`: its name, or for the time of a static analysis 'load factor'
        (its pseudo-time under load control) or 'path parameter' (arc-length or displacement
        control, where the series load_factor differs from it), and 'mode' for that of an
        eigenanalysis, with the unit in brackets (none for a dimensionless series)."""
        unit, _ = self.quantity(name)
        shown = name
        if name == "time":
            shown = {"static": "load factor", "modes": "mode", "buckling": "mode"}.get(self.analysis_type(), name)
            if shown == "load factor" and "load_factor" in self._series:
                time, load_factor = self.read("time"), self.read("load_factor")
                if len(time) == len(load_factor) and not np.allclose(time, load_factor, rtol=1e-12, atol=1e-12):
                    shown = "path parameter"
        return shown if unit in (None, "", "1") else f"{shown} [{unit}]"

    def _check(self, name):
        if not self._series:
            self.require_rows()
        if name not in self._series:
            close = difflib.get_close_matches(name, self._series, n=5, cutoff=0.6)
            hint = f"; did you mean: {', '.join(close)}" if close else ""
            raise UsageError(f"no series '{name}' in {self._file.filename}{hint}"
                             f" (list them with: msflex-history {self._file.filename})")

    def read(self, name):
        """The values of series `name` as a 1-D float array; UsageError if there is none, FileError
        if the file has no history rows."""
        self._check(name)
        self.require_rows()
        path, column = self._series[name]
        dataset = self._file[path]
        return (dataset[:] if column is None else dataset[:, column]).astype(float)

    def read_all(self):
        """Every series, {name: 1-D float array}, reading the table once ({} for a file without rows)."""
        if not self._series:
            return {}
        if any(path != "history/values" for path, _ in self._series.values()):
            return {name: self.read(name) for name in self._series}
        table = self._file["history/values"][()].astype(float)
        return {name: table[:, column] for name, (_, column) in self._series.items()}

    def read_columns(self, names):
        """The named series as equally long arrays. A run killed while writing a row of an older
        file may leave some series one row longer than others, so all are cut to the shortest."""
        columns = [self.read(name) for name in names]
        rows = min(len(c) for c in columns)
        return [c[:rows] for c in columns]


def check_image_file(path):
    """UsageError (exit status 2) when matplotlib cannot write an image named `path`: its extension
    names a format it does not know (to a name without extension matplotlib adds .png)."""
    from matplotlib.backend_bases import FigureCanvasBase
    extension = os.path.splitext(path)[1][1:].lower()
    supported = FigureCanvasBase.get_supported_filetypes()
    if extension and extension not in supported:
        raise UsageError(f"cannot write '{path}': unsupported image format '.{extension}'"
                         f" (supported: {', '.join('.' + e for e in sorted(supported))})")


def run_cli(prog, main):
    """Runs main() and turns the expected failures into one-line messages and exit codes:
    2 for a usage mistake (as argparse does), 1 for a file that cannot be read, is not an msflex
    result file or holds no history rows (FileError)."""
    try:
        main()
    except UsageError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 1
    return 0
