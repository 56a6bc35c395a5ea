"""Time series of an msflex result file (layout: docs/output.md), for the post-processing scripts.

A series is one column of the history: every /history/<name> dataset, and per probe
<probe>.position.x|y|z, <probe>.displacement.x|y|z, <probe>.rotation.w|x|y|z and
<probe>.rotation_angle. All series of a file have one value per history row. Each carries the
`unit` and `description` attributes of its dataset (files of older msflex versions have none).
"""

import difflib
import sys

import h5py

# Probe datasets and the names of their columns (None: a 1-D dataset, one value per row).
PROBE_COMPONENTS = {
    "position": "xyz",
    "displacement": "xyz",
    "rotation": "wxyz",
    "rotation_angle": None,
}

SERIES_HELP = """\
series names:
  <name>                        every /history/<name>, e.g. time (the load factor in statics),
                                newton_iterations, residual_norm, step_size
  <probe>.position.x|y|z        probed node's current position
  <probe>.displacement.x|y|z    probed node's displacement
  <probe>.rotation.w|x|y|z      probed node's rotation quaternion
  <probe>.rotation_angle        probed node's tracked rotation angle (rad)
"""


class UsageError(Exception):
    """A mistake on the command line; the scripts exit with status 2 for it."""


class HistoryFile:
    """An open result file; use as a context manager."""

    def __init__(self, path):
        self._file = h5py.File(path, "r")
        # Series name -> (dataset path, column or None for 1-D datasets).
        self._series = {}
        history = self._file.get("history", {})
        # time first, as in the writer; HDF5 itself lists names alphabetically.
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
        """All series of the file: history series (time first), then probe series."""
        return list(self._series)

    def is_static(self):
        """Whether the file holds a static analysis (its time is the load factor)."""
        kind = self._file.attrs.get("analysis_type")
        if kind is None:  # older files: dynamics writes kinetic_energy
            return "kinetic_energy" not in self._file.get("history", {})
        return (kind.decode() if isinstance(kind, bytes) else str(kind)) == "static"

    def quantity(self, name):
        """(unit, description) of series `name`; unit None when the file does not say."""
        self._check(name)
        path, column = self._series[name]
        attributes = self._file[path].attrs
        unit, description = attributes.get("unit"), attributes.get("description")
        unit = unit.decode() if isinstance(unit, bytes) else unit
        description = (description.decode() if isinstance(description, bytes) else description) or ""
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

    def read_columns(self, names):
        """The named series as equally long arrays. A run killed while writing a row may leave
        some series one row longer than others, so all are cut to the shortest."""
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
