#!/usr/bin/env python3
"""Runs postproc/msflex-history, postproc/plot-history and postproc/msflex-modes on synthetic result
files that follow docs/output.md (a history and one probe; modes; critical points). Run: python3 tests/regression/test_postproc.py"""

import csv
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


def write_result_file(path):
    with h5py.File(path, "w") as f:
        f["history/time"] = TIME
        f["history/load_factor"] = LOAD_FACTOR
        f["history/newton_iterations"] = NEWTON_ITERATIONS
        f["probes/tip/position"] = TIP_POSITION
        f["probes/tip/displacement"] = TIP_POSITION - TIP_POSITION[0]
        f["probes/tip/rotation"] = TIP_ROTATION
        f["probes/tip/rotation_angle"] = TIP_ROTATION_ANGLE


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
        result = run("msflex-history", self.h5)
        self.assertEqual(result.returncode, 0, result.stderr)
        names = result.stdout.split()
        self.assertEqual(names[:3], ["time", "load_factor", "newton_iterations"])
        for name in ["tip.position.x", "tip.position.z", "tip.displacement.y", "tip.rotation.w",
                     "tip.rotation.z", "tip.rotation_angle"]:
            self.assertIn(name, names)
        self.assertEqual(len(names), 3 + 3 + 3 + 4 + 1)

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
            for name, values in {"time": [1, 2], "step": [1, 2], "mode": [1, 2], "eigenvalue": [-1e-9, 400.0], "angular_frequency": [0.0, 20.0],
                                 "frequency": [0.0, 20.0 / (2 * np.pi)], "rigid_mode": [1, 0], "backward_error": [1e-16, 2e-16]}.items():
                f[f"history/{name}"] = np.array(values, dtype=float)
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
            for name, values in {"time": [0, 1, 2, 3], "step": [0, 1, 2, 3], "critical_point": [0, 1, 0, 2],
                                 "critical_load_factor": [np.nan, 0.38, np.nan, 0.5], "negative_pivots": [0, 1, 1, 2]}.items():
                f[f"history/{name}"] = np.array(values, dtype=float)
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
