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
import sys

import h5py

# Older files: probe datasets and the names of their columns (None: a 1-D dataset, one value per row).
PROBE_COMPONENTS = {
    "position": "xyz",
    "displacement": "xyz",
    "rotation": "wxyz",
    "rotation_angle": None,
}

SERIES_HELP = """\
series names:
  <name>                        every history series, e.g. time (the load factor in statics),
                                newton_iterations, residual_norm, step_size, <joint>.rz
  <probe>.position.x|y|z        probed node's current position
  <probe>.displacement.x|y|z    probed node's displacement
  <probe>.rotation.w|x|y|z      probed node's rotation quaternion
  <probe>.rotation_angle        probed node's tracked rotation angle (rad)
"""


def _text(value):
    return value.decode() if isinstance(value, bytes) else value


class UsageError(Exception):
    """A mistake on the command line; the scripts exit with status 2 for it."""


class HistoryFile:
    """An open result file; use as a context manager."""

    def __init__(self, path):
        self._file = h5py.File(path, "r")
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

    def is_static(self):
        """Whether the file holds a static analysis (its time is the load factor)."""
        kind = self._file.attrs.get("analysis_type")
        if kind is None:  # older files: dynamics writes kinetic_energy
            return "kinetic_energy" not in self._series
        return _text(kind) == "static"

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
        """Axis label of series `name`: its name, or 'load factor' for the time of a static
        analysis, with the unit in brackets (none for a dimensionless series)."""
        unit, _ = self.quantity(name)
        shown = "load factor" if name == "time" and self.is_static() else name
        return shown if unit in (None, "", "1") else f"{shown} [{unit}]"

    def _check(self, name):
        if name not in self._series:
            close = difflib.get_close_matches(name, self._series, n=5, cutoff=0.6)
            hint = f"; did you mean: {', '.join(close)}" if close else ""
            raise UsageError(f"no series '{name}' in {self._file.filename}{hint}"
                             f" (list them with: msflex-history {self._file.filename})")

    def read(self, name):
        """The values of series `name` as a 1-D float array; UsageError if there is none."""
        self._check(name)
        path, column = self._series[name]
        dataset = self._file[path]
        return (dataset[:] if column is None else dataset[:, column]).astype(float)

    def read_all(self):
        """Every series, {name: 1-D float array}, reading the table once."""
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


def run_cli(prog, main):
    """Runs main() and turns the expected failures into one-line messages and exit codes:
    2 for a usage mistake (as argparse does), 1 for a file that cannot be read."""
    try:
        main()
    except UsageError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 1
    return 0
