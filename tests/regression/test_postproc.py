#!/usr/bin/env python3
"""Runs postproc/msflex-history, postproc/plot-history, postproc/msflex-modes and
postproc/plot-energy-momentum on synthetic result files that follow docs/output.md (a history table
with one probe's columns, with the units and descriptions msflex writes, of a static and of a
dynamic analysis, and one of an older msflex: a dataset per series, without units; modes; critical
points; the energies and momenta of a damped mechanism): the listing, CSV, the axis labels with
units ("load factor" for a static analysis's time, "mode" for an eigenanalysis'), the energy
balance and momentum panels, and the errors: one line on stderr and exit status 1 for a file
without history rows, a checkpoint and files that are no result files; exit status 2 and one
line for an image format matplotlib cannot write; msflex-history's arguments (SERIES optional,
each column once); a file another process holds open for writing with HDF5 file locking read all
the same; plot-rack-pinion's drive work by the trapezoid rule and its energy error against the
file's external_work. (tests/regression/
test_output_units.py does the same on the files msflex writes.) Run: python3 tests/regression/test_postproc.py"""

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
PROBE_UNITS = {"position": ("m", "current position of the probed point (node, its offset point or a rigid body's centre of mass)"), "displacement": ("m", "displacement of the probed point (node, its offset point or a rigid body's centre of mass)"),
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


def script_module(script):
    """postproc/<script> as a module, for its plot() (the axes of the figure it draws)."""
    name = script.replace("-", "_")
    loader = importlib.machinery.SourceFileLoader(name, os.path.join(POSTPROC, script))
    spec = importlib.util.spec_from_loader(name, loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def plot_history_module():
    return script_module("plot-history")


def write_model_only_file(path):
    """A result file as msflex leaves it when its run stops before the first history row (for
    example a static stage that finds no equilibrium): the marker, the input and the mesh, an empty
    /frames and /history."""
    with h5py.File(path, "w") as f:
        f.attrs["msflex_format"] = "msflex result 3"
        f.attrs["analysis_type"] = np.bytes_(b"dynamic")
        f["input"] = "nodes: {a: [0, 0, 0]}"
        f["mesh/node_coordinates"] = np.zeros((1, 3))
        f.create_group("frames")
        f.create_group("history")


def write_checkpoint(path, output_file="out.h5"):
    """An msflex checkpoint: its marker, and the format and result file as /run datasets of
    characters (int8), as msflex writes them."""
    with h5py.File(path, "w") as f:
        f.attrs["msflex_format"] = "msflex checkpoint 7"
        f["run/format"] = np.frombuffer(b"msflex checkpoint 7", dtype=np.int8)
        f["run/output_file"] = np.frombuffer(output_file.encode(), dtype=np.int8)
        f.create_group("nodes")


# A damped mechanism's energies (J) and momenta: a motor does work until the end, dampers
# dissipate part of it, the rest is the total energy, so that total - work falls while
# energy_balance = total - work + dissipated stays constant.
MECHANISM_TIME = np.linspace(0.0, 1.0, 11)
MECHANISM_WORK = 6.0 * MECHANISM_TIME ** 2
MECHANISM_DISSIPATED = 3.5 * MECHANISM_TIME ** 2
MECHANISM_SPRING = 0.01 * np.sin(10 * MECHANISM_TIME) ** 2
MECHANISM_STRAIN = 1e-4 * MECHANISM_TIME
MECHANISM_TOTAL = MECHANISM_WORK - MECHANISM_DISSIPATED + 3e-11 * np.cos(7 * MECHANISM_TIME)
MECHANISM_BALANCE = MECHANISM_TOTAL - MECHANISM_WORK + MECHANISM_DISSIPATED


def write_dynamic_file(path, damped=True, held=True, work=None):
    """The history of a dynamic analysis with energies and momenta (docs/output.md): `damped` adds
    spring_energy, dissipated_energy and energy_balance (without them: a file of an older msflex);
    `held`: a revolute joint to the ground; `work`: the external work (default MECHANISM_WORK)."""
    work = MECHANISM_WORK if work is None else work
    dissipated = MECHANISM_DISSIPATED if damped else 0 * work
    total = work - dissipated + 3e-11 * np.cos(7 * MECHANISM_TIME)
    spring = MECHANISM_SPRING if damped else 0 * work
    columns = {"time": MECHANISM_TIME, "strain_energy": MECHANISM_STRAIN}
    quantities = {"time": ("s", "time"), "strain_energy": ("J", "strain energy of the beams")}
    if damped:
        columns["spring_energy"] = spring
    columns.update(kinetic_energy=total - MECHANISM_STRAIN - spring, total_energy=total, external_work=work)
    if damped:
        columns["energy_balance"] = total - work + dissipated
    for k, axis in enumerate("xyz"):
        columns[f"linear_momentum_{axis}"] = (k + 1) * np.sin(3 * MECHANISM_TIME)
    for k, axis in enumerate("xyz"):
        columns[f"angular_momentum_{axis}"] = (k + 1) * np.cos(3 * MECHANISM_TIME)
    if damped:
        columns["dissipated_energy"] = dissipated
    for name in columns:
        quantities.setdefault(name, ("kg m/s" if name.startswith("linear") else "kg m^2/s" if name.startswith("angular") else "J", name))
    with h5py.File(path, "w") as f:
        f.attrs["msflex_format"] = "msflex result 3"
        f.attrs["analysis_type"] = np.bytes_(b"dynamic")
        f["input"] = "nodes: {rotor: [0, 0, 0]}\nrigid_bodies:\n  - {node: rotor, mass: 1}\n"
        if held:
            f["mesh/joint_names"] = np.array([b"rotor"])
            f["mesh/joint_types"] = np.array([b"revolute"])
            f["mesh/joint_master"] = np.array([-1], dtype=np.int32)
        write_table(f, columns, quantities)


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
        self.assertEqual(rows["tip.position.y"], ["[m]", "probe tip: current position of the probed point (node, its offset point or a rigid body's centre of mass), y"])
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
        # Statics: time is the path parameter where the load factor series differs from it (an
        # arc-length path, as this file's), else the load factor (test_output_units runs both).
        with msflex_h5.HistoryFile(self.h5) as history:
            axes = plot_history.plot(history, "time", ["tip.position.z"], "t").axes[0]
        self.assertEqual(axes.get_xlabel(), "path parameter")
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
        self.assertEqual(axes.get_lines()[0].get_linestyle(), "-")
        # Against an eigenanalysis's mode number: points without a line between them, whole-number
        # ticks (the axis showed 1.25, 1.5, ...).
        write_result_file(self.h5, analysis="static")  # (time in unit 1, as a mode number's)
        with h5py.File(self.h5, "a") as f:
            f.attrs["analysis_type"] = "modes"
        with msflex_h5.HistoryFile(self.h5) as history:
            figure = plot_history.plot(history, "time", ["tip.rotation_angle"], "t")
        axes = figure.axes[0]
        self.assertEqual(axes.get_xlabel(), "mode")
        self.assertEqual(axes.get_lines()[0].get_linestyle(), "None")
        figure.canvas.draw()
        ticks = [tick for tick in axes.get_xticks() if axes.get_xlim()[0] <= tick <= axes.get_xlim()[1]]
        self.assertTrue(len(ticks) > 0 and all(float(tick).is_integer() for tick in ticks), ticks)

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

    def test_time_of_an_eigenanalysis_is_labelled_mode(self):
        # msflex marks an eigenanalysis' file "static"; its rows are the modes.
        path = os.path.join(self.directory.name, "modes.h5")
        with h5py.File(path, "w") as f:
            f.attrs["analysis_type"] = np.bytes_(b"static")
            write_table(f, {"time": [1, 2], "step": [1, 2], "mode": [1, 2], "eigenvalue": [1.0, 400.0], "angular_frequency": [1.0, 20.0],
                            "frequency": [0.16, 3.2], "rigid_mode": [0, 0], "backward_error": [1e-16, 2e-16]},
                        {"time": ("1", "mode number"), "eigenvalue": ("(rad/s)^2", "eigenvalue omega^2 of the mode"), "frequency": ("Hz", "frequency")})
        sys.path.insert(0, POSTPROC)
        import msflex_h5
        with msflex_h5.HistoryFile(path) as history:
            axes = plot_history_module().plot(history, "time", ["eigenvalue"], "t").axes[0]
        self.assertEqual(axes.get_xlabel(), "mode")
        self.assertEqual(axes.get_ylabel(), "eigenvalue [(rad/s)^2]")

    def assert_one_line_error(self, result, script, message):
        """Exit status 1, nothing on stdout, and on stderr the one line '<script>: error: <message>'."""
        self.assertEqual(result.returncode, 1, result.stderr)
        self.assertEqual(result.stdout, "")
        self.assertEqual(result.stderr, f"{script}: error: {message}\n")

    def assert_every_tool_refuses(self, path, message, history_arguments):
        """msflex-history (with each of `history_arguments`), plot-history, plot-energy-momentum and
        msflex-modes on `path`: each one line `message`, exit 1, and no picture written."""
        for arguments in history_arguments:
            self.assert_one_line_error(run("msflex-history", path, *arguments), "msflex-history", message)
        png = os.path.join(self.directory.name, "plot.png")
        self.assert_one_line_error(run("plot-history", path, "time", "-o", png), "plot-history", message)
        self.assert_one_line_error(run("plot-energy-momentum", path, "-o", png), "plot-energy-momentum", message)
        self.assert_one_line_error(run("msflex-modes", path), "msflex-modes", message)
        self.assertFalse(os.path.exists(png))

    def test_a_file_without_history_rows_is_an_error_of_one_line(self):
        path = os.path.join(self.directory.name, "stopped.h5")
        write_model_only_file(path)
        message = (f"{path} holds no history rows: its run stopped before writing its initial state (or has not flushed it yet),"
                   " so there is nothing to list, print or plot")
        self.assert_every_tool_refuses(path, message, ([], ["--names"], ["time"], ["time", "kinetic_energy"]))

    def test_a_checkpoint_is_not_a_result_file(self):
        path = os.path.join(self.directory.name, "out.ckpt.h5")
        write_checkpoint(path)
        # The run stored its output file as given (out.h5, relative to where it started): named
        # as found beside the checkpoint, or else said to be relative to the run's directory.
        message = f"{path} is an msflex checkpoint, not a result file; its run's results are in {self.h5}"
        self.assert_every_tool_refuses(path, message, ([], ["--names"], ["time"]))
        os.remove(self.h5)
        message = f"{path} is an msflex checkpoint, not a result file; its run's results are in out.h5 (relative to the directory its run started in)"
        self.assert_every_tool_refuses(path, message, ([], ["--names"]))

    def test_other_files_are_not_result_files(self):
        sidecar = os.path.join(self.directory.name, "out.xmf")
        with open(sidecar, "w") as f:
            f.write('<?xml version="1.0" ?>\n<!-- msflex results (layout: docs/output.md). -->\n<Xdmf Version="3.0">\n</Xdmf>\n')
        text = os.path.join(self.directory.name, "notes.txt")
        with open(text, "w") as f:
            f.write("not a result\n")
        foreign = os.path.join(self.directory.name, "other.h5")
        with h5py.File(foreign, "w") as f:
            f["x"] = [1.0, 2.0]
        missing = os.path.join(self.directory.name, "missing.h5")
        cases = {sidecar: f"{sidecar} is an msflex XDMF sidecar, not a result file; the results are in the HDF5 file beside it"
                          f" ({os.path.join(self.directory.name, 'out.h5')})",
                 text: f"{text} is not an HDF5 file, so not an msflex result file",
                 foreign: f"{foreign} is not an msflex result file (an HDF5 file without /history)",
                 missing: f"{missing}: no such file"}
        for path, message in cases.items():
            self.assert_one_line_error(run("msflex-history", path), "msflex-history", message)
            self.assert_one_line_error(run("msflex-modes", path), "msflex-modes", message)

    def energy_momentum_axes(self, path, **options):
        with __import__("msflex_h5").HistoryFile(path) as history:
            figure = script_module("plot-energy-momentum").plot(history, title="t", **options)
        top, bottom = figure.axes
        return {line.get_label(): line for line in top.get_lines()}, bottom

    def test_energy_plot_shows_the_energy_balance_of_a_damped_model(self):
        sys.path.insert(0, POSTPROC)
        path = os.path.join(self.directory.name, "damped.h5")
        write_dynamic_file(path)
        lines, bottom = self.energy_momentum_axes(path)
        balance = [line for label, line in lines.items() if label.startswith("energy_balance")]
        self.assertEqual(len(balance), 1, list(lines))
        np.testing.assert_array_equal(balance[0].get_ydata(), MECHANISM_BALANCE)
        self.assertIn("= total − external work + dissipated", balance[0].get_label())
        # total - work falls by the dissipated energy: not plotted when energy_balance exists.
        self.assertNotIn("total − external work", lines)
        np.testing.assert_array_equal(lines["dissipated"].get_ydata(), MECHANISM_DISSIPATED)
        np.testing.assert_array_equal(lines["spring"].get_ydata(), MECHANISM_SPRING)
        self.assertEqual(bottom.figure.axes[0].get_ylabel(), "energy [J]")
        # Held by a joint to the ground, and the motor works until the end: the momenta are not
        # conserved, so their values are shown over the whole run, and the panel says why.
        self.assertEqual(len(bottom.get_lines()), 6)
        for line in bottom.get_lines():
            self.assertEqual(len(line.get_xdata()), len(MECHANISM_TIME))
        self.assertIn("momenta not conserved", bottom.get_title().replace("\n", " "))
        self.assertIn("joints to the ground (rotor)", bottom.get_title().replace("\n", " "))
        self.assertIn("external work changes until the end", bottom.get_title().replace("\n", " "))
        self.assertEqual(bottom.get_xlabel(), "time [s]")
        # An older file without energy_balance: total - external work.
        write_dynamic_file(path, damped=False)
        lines, _ = self.energy_momentum_axes(path)
        self.assertFalse(any(label.startswith("energy_balance") for label in lines))
        np.testing.assert_allclose(lines["total − external work"].get_ydata(), 3e-11 * np.cos(7 * MECHANISM_TIME), rtol=0, atol=1e-15)

    def test_momentum_deviation_from_the_end_of_the_loading(self):
        sys.path.insert(0, POSTPROC)
        path = os.path.join(self.directory.name, "free.h5")
        work = np.minimum(MECHANISM_TIME, 0.4)  # the loads stop at t = 0.4
        write_dynamic_file(path, held=False, work=work)
        _, bottom = self.energy_momentum_axes(path)
        self.assertEqual(len(bottom.get_lines()), 6)
        first = int(np.searchsorted(MECHANISM_TIME, 0.4 - 1e-12))
        for k, line in enumerate(bottom.get_lines()):
            np.testing.assert_array_equal(line.get_xdata(), MECHANISM_TIME[first:])
            self.assertEqual(line.get_ydata()[0], 0.0)
        self.assertIn("from t₀ = 0.4 s, when the external work stops changing", bottom.get_title().replace("\n", " "))
        # The motor works until the end and nothing holds the model: values, and the panel says why.
        write_dynamic_file(path, held=False)
        _, bottom = self.energy_momentum_axes(path)
        self.assertEqual([len(line.get_xdata()) for line in bottom.get_lines()], [len(MECHANISM_TIME)] * 6)
        self.assertIn("external work changes until the end", bottom.get_title().replace("\n", " "))
        self.assertNotIn("held", bottom.get_title().replace("\n", " "))
        # --from-time: deviations from there, even where the momenta are not conserved.
        write_dynamic_file(path)
        _, bottom = self.energy_momentum_axes(path, from_time=0.5)
        self.assertEqual([len(line.get_xdata()) for line in bottom.get_lines()], [6] * 6)
        self.assertIn("they are not", bottom.get_title().replace("\n", " "))
        png = os.path.join(self.directory.name, "energy.png")
        result = run("plot-energy-momentum", path, "-o", png, "--from-time", "2")
        self.assertEqual(result.returncode, 2)
        self.assertIn("--from-time 2.0 is after the last time 1", result.stderr)
        result = run("plot-energy-momentum", path, "-o", png)
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(png, "rb") as image:
            self.assertEqual(image.read(8), b"\x89PNG\r\n\x1a\n")
        result = run("plot-energy-momentum", self.h5, "-o", png)
        self.assertEqual(result.returncode, 2)
        self.assertIn("it holds a static analysis, not a dynamic one", result.stderr)

    def test_plot_history_refuses_an_unknown_image_format(self):
        # matplotlib's own message was a traceback; exit 2, one line naming the format and the known ones.
        target = os.path.join(self.directory.name, "plot.xyz")
        for script, arguments in (("plot-history", [self.h5, "time", "-o", target]),
                                  ("plot-energy-momentum", [self.h5, "-o", target]),
                                  ("plot-rack-pinion", [self.h5, "-o", target])):
            result = run(script, *arguments)
            self.assertEqual(result.returncode, 2, result.stderr)
            self.assertEqual(len(result.stderr.splitlines()), 1, result.stderr)
            self.assertIn("'.xyz'", result.stderr)
            self.assertIn(".png", result.stderr)
            self.assertNotIn("Traceback", result.stderr)
            self.assertFalse(os.path.exists(target))

    def test_history_arguments(self):
        # SERIES is optional: only FILE is missing.
        result = run("msflex-history")
        self.assertEqual(result.returncode, 2)
        self.assertIn("the following arguments are required: FILE", result.stderr)
        self.assertNotIn("SERIES", result.stderr.splitlines()[-1])
        # Each column once, time first, whether or not it is asked for.
        for series, header in ((["time"], ["time"]), (["load_factor", "time", "load_factor"], ["time", "load_factor"])):
            result = run("msflex-history", self.h5, *series)
            self.assertEqual(result.returncode, 0, result.stderr)
            rows = list(csv.reader(io.StringIO(result.stdout)))
            self.assertEqual(rows[0], header)
            self.assertEqual([len(row) for row in rows], [len(header)] * (len(TIME) + 1))

    def test_reads_a_file_that_another_process_holds_open_for_writing(self):
        # msflex holds its result file open for writing while it runs; HDF5's file locking (on by
        # default) made every tool fail with "unable to lock file" ([Errno 11]) instead of reading the
        # last flush. The writer here locks; the tools run without HDF5_USE_FILE_LOCKING set.
        environment = {k: v for k, v in os.environ.items() if k != "HDF5_USE_FILE_LOCKING"}
        holder = subprocess.Popen([sys.executable, "-c", "import sys, h5py\n"
                                   "f = h5py.File(sys.argv[1], 'a', locking=True)\nprint('open', flush=True)\nsys.stdin.read()\n", self.h5],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=environment)
        try:
            self.assertEqual(holder.stdout.readline().strip(), "open")
            result = subprocess.run([sys.executable, os.path.join(POSTPROC, "msflex-history"), self.h5, "load_factor"],
                                    capture_output=True, text=True, env=environment)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertEqual(len(result.stdout.splitlines()), len(TIME) + 1)
            png = os.path.join(self.directory.name, "plot.png")
            result = subprocess.run([sys.executable, os.path.join(POSTPROC, "plot-history"), self.h5, "load_factor", "-o", png],
                                    capture_output=True, text=True, env=environment)
            self.assertEqual(result.returncode, 0, result.stderr)
        finally:
            holder.communicate("")
        # Where HDF5 locks all the same, the one line says that the file is locked.
        sys.path.insert(0, POSTPROC)
        import msflex_h5

        def locked(*args, **kwargs):
            raise OSError(11, "Unable to synchronously open file (unable to lock file, errno = 11, error message = 'Resource temporarily unavailable')")
        original = msflex_h5.h5py.File
        msflex_h5.h5py.File = locked
        try:
            with self.assertRaises(msflex_h5.FileError) as caught:
                msflex_h5.open_result_file(self.h5)
        finally:
            msflex_h5.h5py.File = original
        self.assertIn("could not lock", str(caught.exception))
        self.assertIn("a running msflex", str(caught.exception))
        self.assertEqual(len(str(caught.exception).splitlines()), 1)

    def test_render_paraview_names_what_a_frame_time_is(self):
        # The title of a rendered frame said "t = ..." for static and eigenanalysis frames too:
        # "load factor" (load control: time = load factor), "path parameter" (they differ: arc
        # length), "mode", and "t" in dynamics.
        module = script_module("render-paraview")
        expectations = []
        for analysis, load_factor, expected in (("static", TIME, "load factor"), ("static", LOAD_FACTOR, "path parameter"), ("dynamic", None, "t")):
            path = os.path.join(self.directory.name, f"label_{analysis}_{expected.replace(' ', '_')}.h5")
            write_result_file(path, analysis)
            if load_factor is not None:
                with h5py.File(path, "r+") as f:
                    names = [name.decode() for name in f["history/names"][:]]
                    f["history/values"][:, names.index("load_factor")] = load_factor
            expectations.append((path, expected))
        for path, expected in expectations:
            os.environ.pop(module.FRAME_LABEL, None)
            self.assertEqual(module.frame_label(path), expected)
        os.environ.pop(module.FRAME_LABEL, None)

    def test_rack_pinion_drive_work(self):
        # The drive work W = integral of (a1.M + b a2.F) dphi over the history rows: with a moment
        # linear in phi, W = phi^2 / 2 exactly by the trapezoid rule (a right-endpoint rectangle
        # rule, as plot-rack-pinion had, errs by sum phi_i dphi / 2: 0.64 J on input/rack_pinion.yaml).
        # Where the file has external_work, the energy error is total - external_work.
        sys.path.insert(0, POSTPROC)
        import types
        module = script_module("plot-rack-pinion")
        time = np.linspace(0.0, 1.0, 21)
        phi = 3.0 * time ** 2
        exact = 0.5 * phi ** 2
        np.testing.assert_allclose(module.drive_work(phi, phi), exact, rtol=0, atol=1e-12)
        path = os.path.join(self.directory.name, "rack_pinion.h5")
        zero = 0 * time
        for with_work in (True, False):
            columns = {"time": time, "gear.rx": phi, "total_energy": exact, "gear.force_x": zero, "gear.force_y": zero, "gear.force_z": zero,
                       "gear.moment_x": zero, "gear.moment_y": zero, "gear.moment_z": phi,
                       "contact.position.x": zero + 1, "contact.position.y": zero, "contact.position.z": zero,
                       "contact.rotation.w": zero + 1, "contact.rotation.x": zero, "contact.rotation.y": zero, "contact.rotation.z": zero,
                       "pinion.position.x": 1 + 0.1 * phi, "pinion.position.y": zero + 0.1, "pinion.position.z": zero}
            if with_work:
                columns["external_work"] = exact
            with h5py.File(path, "w") as f:
                f.attrs["msflex_format"] = "msflex result 3"
                f.attrs["analysis_type"] = np.bytes_(b"dynamic")
                write_table(f, columns)
            arguments = types.SimpleNamespace(file=path, radius=0.1, joint="gear", contact="contact", pinion="pinion")
            bottom = module.plot(arguments).axes[2]  # (a), (b), (c), then the twin axes of (a)
            lines = {line.get_label(): line for line in bottom.get_lines()}
            np.testing.assert_allclose(lines["drive work W (trapezoid rule)"].get_ydata(), exact, rtol=0, atol=1e-12)
            error = [line for label, line in lines.items() if label.startswith("total −")]
            self.assertEqual(len(error), 1, list(lines))
            self.assertIn("external work (file)" if with_work else "total − W", error[0].get_label())
            self.assertLess(np.abs(error[0].get_ydata()).max(), 1e-12)


if __name__ == "__main__":
    unittest.main()
