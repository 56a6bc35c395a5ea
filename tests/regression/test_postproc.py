#!/usr/bin/env python3
"""Runs postproc/msflex-history, postproc/plot-history and postproc/msflex-modes on synthetic result
files that follow docs/output.md (a history table with one probe's columns, with the units and
descriptions msflex writes, of a static and of a dynamic analysis, and one of an older msflex: a
dataset per series, without units; modes; critical points): the listing, CSV, the axis labels with units ("load factor" for a static
analysis's time) and the errors. Run: python3 tests/regression/test_postproc.py"""

import csv
import importlib.machinery
import importlib.util
import io
import os
import subprocess
import sys
import tempfile
import unittest

import h5py
import numpy as np

POSTPROC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "postproc")

TIME = np.array([0.0, 0.5, 1.0])
LOAD_FACTOR = np.array([0.0, 0.25, 1.0])
NEWTON_ITERATIONS = np.array([0.0, 4.0, 6.0])
TIP_POSITION = np.array([[1.0, 0.0, 0.0], [0.9, 0.1, 0.2], [0.5, 0.3, 0.7]])
TIP_ROTATION = np.array([[1.0, 0.0, 0.0, 0.0], [0.9, 0.1, 0.2, 0.3], [0.5, 0.4, 0.3, 0.2]])
TIP_ROTATION_ANGLE = np.array([0.0, 0.9, 2.1])


# Units and descriptions as msflex writes them (docs/output.md); time's depend on the analysis.
UNITS = {"load_factor": ("1", "a load factor"), "newton_iterations": ("1", "Newton iterations of the step"),
         "strain_energy": ("J", "strain energy of the beams")}
PROBE_UNITS = {"position": ("m", "current position of the probed node"), "displacement": ("m", "displacement of the probed node"),
               "rotation": ("1", "rotation of the probed node, unit quaternion (w, x, y, z)"),
               "rotation_angle": ("rad", "tracked rotation angle of the probed node")}


def write_table(f, columns, quantities=None):
    """The history table of the current layout: /history/values (rows x columns) and the columns'
    names, units and descriptions (`quantities`: name -> (unit, description); default none known)."""
    names = list(columns)
    f["history/values"] = np.column_stack([np.asarray(columns[name], dtype=float) for name in names])
    quantities = quantities or {}
    f["history/names"] = np.array([name.encode() for name in names])
    f["history/units"] = np.array([quantities.get(name, ("", ""))[0].encode() for name in names])
    f["history/descriptions"] = np.array([quantities.get(name, ("", "a series of unknown meaning"))[1].encode() for name in names])


def write_result_file(path, analysis="static"):
    """analysis: "static", "dynamic", or None for a file of an older msflex (a dataset per series,
    no units)."""
    with h5py.File(path, "w") as f:
        if analysis is None:
            f["history/time"] = TIME
            f["history/load_factor"] = LOAD_FACTOR
            f["history/newton_iterations"] = NEWTON_ITERATIONS
            f["history/strain_energy"] = 2 * LOAD_FACTOR
            f["probes/tip/position"] = TIP_POSITION
            f["probes/tip/displacement"] = TIP_POSITION - TIP_POSITION[0]
            f["probes/tip/rotation"] = TIP_ROTATION
            f["probes/tip/rotation_angle"] = TIP_ROTATION_ANGLE
            return
        f.attrs["analysis_type"] = analysis
        columns = {"time": TIME, "load_factor": LOAD_FACTOR, "newton_iterations": NEWTON_ITERATIONS, "strain_energy": 2 * LOAD_FACTOR}
        quantities = dict(UNITS, time=("s", "time") if analysis == "dynamic" else ("1", "load factor: the pseudo-time"))
        probe = {"position": TIP_POSITION, "displacement": TIP_POSITION - TIP_POSITION[0], "rotation": TIP_ROTATION}
        for quantity, values in probe.items():
            unit, description = PROBE_UNITS[quantity]
            for k, component in enumerate("wxyz" if quantity == "rotation" else "xyz"):
                columns[f"tip.{quantity}.{component}"] = values[:, k]
                quantities[f"tip.{quantity}.{component}"] = (unit, f"probe tip: {description}, {component}")
        columns["tip.rotation_angle"] = TIP_ROTATION_ANGLE
        quantities["tip.rotation_angle"] = (PROBE_UNITS["rotation_angle"][0], "probe tip: " + PROBE_UNITS["rotation_angle"][1])
        write_table(f, columns, quantities)


def plot_history_module():
    """postproc/plot-history as a module, for its plot() (the axes of the figure it draws)."""
    loader = importlib.machinery.SourceFileLoader("plot_history", os.path.join(POSTPROC, "plot-history"))
    spec = importlib.util.spec_from_loader("plot_history", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def run(script, *arguments):
    # The interpreter running this test has h5py; the scripts' shebang python3 may not.
    return subprocess.run([sys.executable, os.path.join(POSTPROC, script), *arguments],
                          capture_output=True, text=True, check=False)


class PostprocTest(unittest.TestCase):
    def setUp(self):
        self.directory = tempfile.TemporaryDirectory()
        self.h5 = os.path.join(self.directory.name, "out.h5")
        write_result_file(self.h5)

    def tearDown(self):
        self.directory.cleanup()

    def test_lists_every_series(self):
        result = run("msflex-history", self.h5, "--names")
        self.assertEqual(result.returncode, 0, result.stderr)
        names = result.stdout.split()
        self.assertEqual(names[:4], ["time", "load_factor", "newton_iterations", "strain_energy"])
        for name in ["tip.position.x", "tip.position.z", "tip.displacement.y", "tip.rotation.w",
                     "tip.rotation.z", "tip.rotation_angle"]:
            self.assertIn(name, names)
        self.assertEqual(len(names), 4 + 3 + 3 + 4 + 1)

    def test_lists_units_and_descriptions(self):
        result = run("msflex-history", self.h5)
        self.assertEqual(result.returncode, 0, result.stderr)
        rows = {line.split()[0]: line.split(None, 2)[1:] for line in result.stdout.splitlines()}
        self.assertEqual(len(rows), 4 + 3 + 3 + 4 + 1)
        self.assertEqual(rows["time"], ["[1]", "load factor: the pseudo-time"])
        self.assertEqual(rows["strain_energy"], ["[J]", "strain energy of the beams"])
        self.assertEqual(rows["tip.position.y"], ["[m]", "probe tip: current position of the probed node, y"])
        self.assertEqual(rows["tip.rotation_angle"], ["[rad]", "probe tip: tracked rotation angle of the probed node"])
        self.assertEqual(rows["tip.rotation.w"], ["[1]", "probe tip: rotation of the probed node, unit quaternion (w, x, y, z), w"])
        # A file of an older msflex (a dataset per series, no units) lists the same series, their
        # units as unknown.
        write_result_file(self.h5, analysis=None)
        result = run("msflex-history", self.h5)
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertEqual(result.stdout.splitlines()[0].split(), ["time", "[?]"])
        self.assertEqual(len(result.stdout.splitlines()), 4 + 3 + 3 + 4 + 1)

    def test_reads_the_same_values_from_either_layout(self):
        new = run("msflex-history", self.h5, "load_factor", "tip.position.z", "tip.rotation.w", "tip.rotation_angle")
        write_result_file(self.h5, analysis=None)
        old = run("msflex-history", self.h5, "load_factor", "tip.position.z", "tip.rotation.w", "tip.rotation_angle")
        self.assertEqual(new.returncode, 0, new.stderr)
        self.assertEqual(old.returncode, 0, old.stderr)
        rows = list(csv.reader(io.StringIO(new.stdout)))
        self.assertEqual(rows[1:], list(csv.reader(io.StringIO(old.stdout)))[1:])
        self.assertEqual([float(x) for x in rows[3]], [1.0, 1.0, 0.7, 0.5, 2.1])

    def test_plot_axes_carry_names_and_units(self):
        plot_history = plot_history_module()
        sys.path.insert(0, POSTPROC)
        import msflex_h5
        # Statics: time is the load factor.
        with msflex_h5.HistoryFile(self.h5) as history:
            axes = plot_history.plot(history, "time", ["tip.position.z"], "t").axes[0]
        self.assertEqual(axes.get_xlabel(), "load factor")
        self.assertEqual(axes.get_ylabel(), "tip.position.z [m]")
        # Two series of one unit: the unit on the axis, the series with theirs in the legend.
        with msflex_h5.HistoryFile(self.h5) as history:
            axes = plot_history.plot(history, "strain_energy", ["tip.position.x", "tip.displacement.y"], "t").axes[0]
        self.assertEqual(axes.get_xlabel(), "strain_energy [J]")
        self.assertEqual(axes.get_ylabel(), "value [m]")
        self.assertEqual([text.get_text() for text in axes.get_legend().get_texts()], ["tip.position.x [m]", "tip.displacement.y [m]"])
        # Different units: no unit on the axis; a dimensionless series has none.
        with msflex_h5.HistoryFile(self.h5) as history:
            axes = plot_history.plot(history, "time", ["tip.rotation_angle", "newton_iterations"], "t").axes[0]
        self.assertEqual(axes.get_ylabel(), "value")
        self.assertEqual([text.get_text() for text in axes.get_legend().get_texts()], ["tip.rotation_angle [rad]", "newton_iterations"])
        # Dynamics: time in s.
        write_result_file(self.h5, analysis="dynamic")
        with msflex_h5.HistoryFile(self.h5) as history:
            axes = plot_history.plot(history, "time", ["tip.rotation_angle"], "t").axes[0]
        self.assertEqual(axes.get_xlabel(), "time [s]")
        self.assertEqual(axes.get_ylabel(), "tip.rotation_angle [rad]")

    def test_prints_csv_with_time_first(self):
        result = run("msflex-history", self.h5, "load_factor", "tip.position.z",
                     "tip.displacement.y", "tip.rotation.x", "tip.rotation_angle")
        self.assertEqual(result.returncode, 0, result.stderr)
        rows = list(csv.reader(io.StringIO(result.stdout)))
        self.assertEqual(rows[0], ["time", "load_factor", "tip.position.z", "tip.displacement.y",
                                   "tip.rotation.x", "tip.rotation_angle"])
        expected = np.column_stack([TIME, LOAD_FACTOR, TIP_POSITION[:, 2],
                                    TIP_POSITION[:, 1] - TIP_POSITION[0, 1], TIP_ROTATION[:, 1],
                                    TIP_ROTATION_ANGLE])
        np.testing.assert_array_equal(np.array(rows[1:], dtype=float), expected)

    def test_unknown_series_suggests_close_names(self):
        result = run("msflex-history", self.h5, "tip.displacment.z")
        self.assertEqual(result.returncode, 2)
        self.assertIn("tip.displacment.z", result.stderr)
        self.assertIn("tip.displacement.z", result.stderr)
        self.assertEqual(result.stdout, "")

    def test_help(self):
        for script in ["msflex-history", "plot-history"]:
            result = run(script, "--help")
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn("<probe>.rotation_angle", result.stdout)

    def test_plots_png(self):
        png = os.path.join(self.directory.name, "plot.png")
        result = run("plot-history", self.h5, "tip.position.x", "tip.position.z", "-o", png,
                     "--x", "load_factor", "--title", "tip")
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(png, "rb") as image:
            self.assertEqual(image.read(8), b"\x89PNG\r\n\x1a\n")
        self.assertGreater(os.path.getsize(png), 1000)

    def test_plot_of_unknown_series_fails(self):
        png = os.path.join(self.directory.name, "plot.png")
        result = run("plot-history", self.h5, "no_such_series", "-o", png)
        self.assertEqual(result.returncode, 2)
        self.assertFalse(os.path.exists(png))


    def test_lists_modes(self):
        path = os.path.join(self.directory.name, "modes.h5")
        with h5py.File(path, "w") as f:
            write_table(f, {"time": [1, 2], "step": [1, 2], "mode": [1, 2], "eigenvalue": [-1e-9, 400.0], "angular_frequency": [0.0, 20.0],
                            "frequency": [0.0, 20.0 / (2 * np.pi)], "rigid_mode": [1, 0], "backward_error": [1e-16, 2e-16]})
        result = run("msflex-modes", path)
        self.assertEqual(result.returncode, 0, result.stderr)
        lines = result.stdout.splitlines()
        self.assertEqual(len(lines), 3)
        self.assertIn("rigid mode", lines[1])
        self.assertAlmostEqual(float(lines[2].split()[2]), 20.0 / (2 * np.pi), places=6)
        self.assertAlmostEqual(float(lines[2].split()[3]), 2 * np.pi / 20.0, places=5)

    def test_lists_critical_points(self):
        path = os.path.join(self.directory.name, "path.h5")
        with h5py.File(path, "w") as f:
            write_table(f, {"time": [0, 1, 2, 3], "step": [0, 1, 2, 3], "critical_point": [0, 1, 0, 2],
                            "critical_load_factor": [np.nan, 0.38, np.nan, 0.5], "negative_pivots": [0, 1, 1, 2]})
        result = run("msflex-modes", path)
        self.assertEqual(result.returncode, 0, result.stderr)
        lines = result.stdout.splitlines()
        self.assertEqual(len(lines), 3)
        self.assertIn("limit point", lines[1])
        self.assertIn("0 -> 1", lines[1])
        self.assertIn("bifurcation point", lines[2])
        self.assertIn("1 -> 2", lines[2])

    def test_modes_of_a_file_without_them_fail(self):
        result = run("msflex-modes", self.h5)
        self.assertEqual(result.returncode, 2)
        self.assertIn("no modes", result.stderr)


if __name__ == "__main__":
    unittest.main()
