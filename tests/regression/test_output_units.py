"""The units and descriptions msflex writes into its result files (src/output/output_units.cpp,
docs/output.md), on the files of real runs: every example in input/ (the long ones shortened), the
force-element tests' models (a spring-damper; a coordinate element on a translation), and a
buckling analysis.

- No history column of any of them has an empty unit or "a series of unknown meaning"
  (postproc/msflex-history lists none as unknown).
- The units of the series of force elements, probes of kind beam and reaction, joints' rates and
  dependent translations, the energies, and the eigenanalyses' series.
- The descriptions say what the numbers are: total_energy = kinetic + strain + spring energy,
  energy_balance = total - external work + dissipated energy, algorithmic_dissipation = external
  work - dissipated - (total - its start), each checked on the data; in a modes or buckling file
  `time` (and `/frames/time`) is the mode number.
- postproc/msflex-history on a result file whose run stopped before its first history row and on
  a checkpoint: one line on stderr, exit status 1.
- postproc/plot-energy-momentum on the damped slider-crank plots energy_balance (constant to the
  Newton tolerance), not total - external work, and the momenta over the whole run (the mechanism
  is held and driven to the end); on the free top, the deviations from t = 0.
- postproc/plot-history labels the axes with the series' names and units.
"""

import glob
import importlib.machinery
import importlib.util
import os
import subprocess
import sys

import h5py
import numpy as np

import msflex_testing as mt

UNKNOWN = "a series of unknown meaning"
# Long runs shortened: the series do not depend on the end time.
SHORTENED = {"rotating_shaft": 0.2, "inclined_screw": 1.0, "spin_up": 2.0, "flying_spaghetti": 2.0, "force_element_energy": 0.2,
             "spring_mass_damper": 0.2}

args = mt.parse_arguments(__doc__)
check = mt.Checker("output_units")
postproc = os.path.join(args.source_dir, "postproc")


def columns(path):
    """{name: (unit, description)} of the history table of a result file."""
    with h5py.File(path, "r") as f:
        names, units, descriptions = ([text.decode() for text in f[f"history/{what}"][()]] for what in ("names", "units", "descriptions"))
    return {name: (unit, description) for name, unit, description in zip(names, units, descriptions)}


def run_tool(script, *arguments):
    return subprocess.run([sys.executable, os.path.join(postproc, script), *arguments], capture_output=True, text=True, check=False)


def script_module(script):
    name = script.replace("-", "_")
    loader = importlib.machinery.SourceFileLoader(name, os.path.join(postproc, script))
    module = importlib.util.module_from_spec(importlib.util.spec_from_loader(name, loader))
    loader.exec_module(module)
    return module


# --- Every example, two force-element models and a buckling analysis -----------------------------
runs = {}
for source in sorted(glob.glob(f"{args.source_dir}/input/*.yaml")):
    runs[os.path.basename(source)[:-5]] = (source, [])
for name in ("force_element_energy", "spring_mass_damper"):
    runs[name] = (f"{args.source_dir}/tests/regression/inputs/{name}.yaml", [])
runs["right_angle_frame_buckling"] = (f"{args.source_dir}/input/right_angle_frame.yaml", ["-analysis_type", "buckling"])
files = {}
for name, (source, options) in runs.items():
    end = SHORTENED.get(name)
    files[name] = f"{args.work_dir}/{name}.h5"
    mt.run_msflex(args, source, files[name], extra=["-quiet", "-output_every", "1000000"] + options + (["-analysis_end_time", str(end)] if end else []))
check.true(f"at least 15 examples run ({len(runs) - 3})", len(runs) - 3 >= 15)

series = {}
for name, path in files.items():
    series[name] = columns(path)
    unknown = [column for column, (unit, description) in series[name].items() if not unit or not description or description == UNKNOWN]
    check.true(f"{name}: every one of its {len(series[name])} history columns has a unit and a description (without: {unknown})", not unknown)

listing = run_tool("msflex-history", files["slider_crank"])
check.equal("slider_crank: msflex-history's exit status", listing.returncode, 0)
check.equal("slider_crank: series msflex-history lists as unknown", sum("unknown" in line for line in listing.stdout.splitlines()), 0)

# --- Units ---------------------------------------------------------------------------------------
# (A coordinate element's force and a drive's force in the unit of their coordinate: N m on a
# rotation, N on a translation; the series' names alone said "N or N m".)
EXPECTED_UNITS = {
    "slider_crank": {"spring_energy": "J", "dissipated_energy": "J", "total_energy": "J", "energy_balance": "J", "algorithmic_dissipation": "J",
                     "energy_correction": "1", "motor.force": "N m", "motor.power": "W", "torsional_damper.force": "N m",
                     "torsional_damper.power": "W", "rod_middle.N1": "N", "rod_middle.N3": "N", "rod_middle.M1": "N m", "rod_middle.M3": "N m",
                     "rotor.rx": "rad", "rotor.rx_rate": "rad/s", "slide.tx": "m", "slide.tx_rate": "m/s", "slide.force_x": "N",
                     "slide.moment_z": "N m", "slider_mass.position.x": "m", "time": "s"},
    "bushing_mount": {"mount.force_x": "N", "mount.force_z": "N", "mount.moment_x": "N m", "mount.moment_z": "N m", "mount.power": "W",
                      "root.force_y": "N", "root.moment_z": "N m", "root_section.N2": "N", "root_section.M2": "N m", "spring_energy": "J",
                      "box_centre.rotation_angle": "rad"},
    "force_element_energy": {"strut.length": "m", "strut.tension": "N", "strut.power": "W", "torsion.force": "N m", "mount.moment_y": "N m",
                             "hinge.rx_rate": "rad/s"},
    "spring_mass_damper": {"spring.force": "N", "spring.power": "W", "slide.tx": "m", "slide.tx_rate": "m/s"},
    "turning_arm_screw": {"screw.tx": "m", "screw.rx": "rad", "screw.rx_rate": "rad/s"},
    # a screw driven by its translation: the force along it; a rack's pinion driven by its angle: a torque
    "driven_screw": {"screw.drive_force": "N"},
    "rack_pinion": {"gear.drive_force": "N m"},
    "von_mises_truss": {"time": "1", "load_factor": "1", "hinge.rx": "rad", "hinge.rx_rate": "rad", "critical_load_factor": "1"},
    "hinged_beam_modes": {"time": "1", "mode": "1", "eigenvalue": "(rad/s)^2", "angular_frequency": "rad/s", "frequency": "Hz"},
    "right_angle_frame_buckling": {"time": "1", "eigenvalue": "1", "load_factor": "1"},
}
for name, expected in EXPECTED_UNITS.items():
    wrong = {column: (series[name].get(column, ("(no such series)",))[0], unit) for column, unit in expected.items()
             if series[name].get(column, ("(no such series)",))[0] != unit}
    check.true(f"{name}: the units of {len(expected)} series (wrong, as (written, expected): {wrong})", not wrong)

# Where the unit depends on what the name does not tell, the description says which.
force = series["spring_mass_damper"]["spring.force"][1]
check.true(f"a coordinate element's force says its unit: N on a translation, N m on a rotation ('{force}')",
           "N on a translation" in force and "N m on a rotation" in force)
check.true(f"a screw's tx says it may be a dependent translation ('{series['turning_arm_screw']['screw.tx'][1]}')",
           "dependent translation" in series["turning_arm_screw"]["screw.tx"][1])
# Each owner named with its kind from the input (the generic text named every kind, and so every owner).
for column, head in (("root.force_x", "root (reaction probe): "), ("mount.force_x", "mount (bushing): "), ("slide.force_x", "slide (prismatic joint): ")):
    description = series["bushing_mount" if column.startswith(("root", "mount")) else "slider_crank"][column][1]
    check.true(f"{column}: the description begins '{head}' ('{description}')", description.startswith(head))

# --- Descriptions against the data ---------------------------------------------------------------
for name, path in files.items():
    if "kinetic_energy" not in series[name]:
        continue
    data = mt.history(path)
    zero = np.zeros_like(data["time"])
    spring, dissipated = data.get("spring_energy", zero), data.get("dissipated_energy", zero)
    total, work = data["total_energy"], data["external_work"]
    scale = max(np.max(np.abs(total)), np.max(np.abs(work)), 1e-300)
    described = series[name]
    check.true(f"{name}: total_energy's description has the spring energy", "spring_energy" in described["total_energy"][1])
    check.less(f"{name}: max |total_energy - (kinetic + strain + spring)| / scale", np.max(np.abs(total - data["kinetic_energy"] - data["strain_energy"] - spring)) / scale, 1e-12)
    check.true(f"{name}: energy_balance's description adds the dissipated energy", "+ dissipated_energy" in described["energy_balance"][1])
    check.less(f"{name}: max |energy_balance - (total - work + dissipated)| / scale", np.max(np.abs(data["energy_balance"] - (total - work + dissipated))) / scale, 1e-12)
    check.true(f"{name}: algorithmic_dissipation's description takes off the dissipated energy", "- dissipated_energy" in described["algorithmic_dissipation"][1])
    check.less(f"{name}: max |algorithmic_dissipation - (work - dissipated - (total - total_0))| / scale",
               np.max(np.abs(data["algorithmic_dissipation"] - (work - dissipated - (total - total[0])))) / scale, 1e-12)

for name in ("hinged_beam_modes", "right_angle_frame_buckling"):
    data = mt.history(files[name])
    check.equal(f"{name}: rows, one per mode", len(data["time"]), len(data["mode"]))
    check.less(f"{name}: max |time - mode|", np.max(np.abs(data["time"] - data["mode"])), 1e-12)
    for column in ("time", "step"):
        description = series[name][column][1]
        check.true(f"{name}: {column} is described as the mode number ('{description}')", description.startswith("mode number"))
    with h5py.File(files[name], "r") as f:
        description = f["frames/time"].attrs["description"]
        description = description.decode() if isinstance(description, bytes) else str(description)
    check.true(f"{name}: /frames/time is described as the mode number ('{description}')", description.startswith("mode number"))
for name in ("von_mises_truss", "cantilever_rollup"):
    description = series[name]["time"][1]
    check.true(f"{name}: a static time is the pseudo-time, the load factor under load control ('{description}')",
               description.startswith("pseudo-time") and "load factor" in description)

# --- msflex-history on a file without history rows and on a checkpoint --------------------------
stopped = f"{args.work_dir}/stopped.h5"
# The pendulum hangs sideways: a static stage finds no equilibrium and the run stops before row 0.
status, _, _ = mt.run_msflex(args, f"{args.source_dir}/input/massless_pendulum.yaml", stopped, extra=["-quiet", "-analysis_static_stage", "true"],
                             expect_success=False)
with h5py.File(stopped, "r") as f:
    check.true("the stopped run left a result file without history rows", "values" not in f["history"])
for arguments in ([], ["--names"], ["time"]):
    result = run_tool("msflex-history", stopped, *arguments)
    check.equal(f"msflex-history {' '.join(arguments)} of a file without history rows: exit status", result.returncode, 1)
    check.true(f"  one line on stderr saying so, nothing on stdout ({result.stderr!r})",
               result.stdout == "" and len(result.stderr.splitlines()) == 1 and "holds no history rows" in result.stderr)
ckpt_out = f"{args.work_dir}/with_checkpoint.h5"
mt.run_msflex(args, f"{args.source_dir}/input/cantilever_rollup.yaml", ckpt_out, extra=["-quiet", "-checkpoint_every", "1"])
checkpoint = f"{args.work_dir}/with_checkpoint.ckpt.h5"
for arguments in ([], ["time"]):
    result = run_tool("msflex-history", checkpoint, *arguments)
    check.equal(f"msflex-history {' '.join(arguments)} of a checkpoint: exit status", result.returncode, 1)
    check.true(f"  one line: '{checkpoint} is an msflex checkpoint, not a result file' ({result.stderr!r})",
               result.stdout == "" and len(result.stderr.splitlines()) == 1
               and f"error: {checkpoint} is an msflex checkpoint, not a result file" in result.stderr)

# --- plot-energy-momentum and plot-history --------------------------------------------------------
try:
    energy_momentum, plot_history = script_module("plot-energy-momentum"), script_module("plot-history")
    with mt.msflex_h5.HistoryFile(files["slider_crank"]) as history:
        figure = energy_momentum.plot(history, title="slider_crank")
        balance_series = history.read("energy_balance")
        rows = history.rows()
    top, bottom = figure.axes
    lines = {line.get_label(): line for line in top.get_lines()}
    balance = [line for label, line in lines.items() if label.startswith("energy_balance")]
    check.equal("slider_crank: energy_balance curves on the energy panel", len(balance), 1)
    if balance:
        check.less("slider_crank: max |plotted energy_balance - the series|", np.max(np.abs(balance[0].get_ydata() - balance_series)), 1e-300)
        check.less("slider_crank: range of the plotted energy_balance, J", np.ptp(balance[0].get_ydata()), 1e-9)
    check.true(f"slider_crank: no 'total - external work' curve (it falls with the dampers' dissipation; curves: {list(lines)})",
               "total − external work" not in lines)
    check.true(f"slider_crank: the energy axis is labelled with its unit ('{top.get_ylabel()}')", top.get_ylabel() == "energy [J]")
    check.equal("slider_crank: momentum curves", len(bottom.get_lines()), 6)
    check.true("slider_crank: every momentum curve spans the whole run (held and driven to the end: values)",
               all(len(line.get_xdata()) == rows for line in bottom.get_lines()))
    title = bottom.get_title().replace("\n", " ")
    check.true(f"slider_crank: the momentum panel says why they are not conserved ('{title}')", "not conserved" in title)
    with mt.msflex_h5.HistoryFile(files["torque_free_top"]) as history:
        figure = energy_momentum.plot(history, title="top")
        spin = np.max(np.abs(history.read("angular_momentum_z")))
        rows = history.rows()
    deviations = figure.axes[1].get_lines()
    check.true("torque_free_top: six momentum deviations from t = 0 over the whole run",
               len(deviations) == 6 and all(len(line.get_xdata()) == rows and line.get_xdata()[0] == 0.0 for line in deviations))
    check.less("torque_free_top: largest momentum deviation / |H|", max(np.max(np.abs(line.get_ydata())) for line in deviations) / spin, 1e-10)

    with mt.msflex_h5.HistoryFile(files["slider_crank"]) as history:
        axes = plot_history.plot(history, "time", ["motor.power"], "t").axes[0]
        labels = [axes.get_xlabel(), axes.get_ylabel()]
        axes = plot_history.plot(history, "rod_middle.N1", ["spring_energy", "dissipated_energy"], "t").axes[0]
        labels += [axes.get_xlabel(), axes.get_ylabel()] + [text.get_text() for text in axes.get_legend().get_texts()]
    with mt.msflex_h5.HistoryFile(files["hinged_beam_modes"]) as history:
        axes = plot_history.plot(history, "time", ["frequency"], "t").axes[0]
        labels += [axes.get_xlabel(), axes.get_ylabel()]
    # Statics: the time is the load factor under load control, the path parameter under arc length.
    for name in ("cantilever_rollup", "von_mises_truss"):
        with mt.msflex_h5.HistoryFile(files[name]) as history:
            labels.append(plot_history.plot(history, "time", ["load_factor"], "t").axes[0].get_xlabel())
    expected = ["time [s]", "motor.power [W]", "rod_middle.N1 [N]", "value [J]", "spring_energy [J]", "dissipated_energy [J]", "mode", "frequency [Hz]",
                "load factor", "path parameter"]
    check.true(f"plot-history's axis labels and legend {labels} (expected {expected})", labels == expected)
except Exception as error:  # an older tool without plot() or without these curves
    check.true(f"the post-processing tools plot the energies, momenta and series ({type(error).__name__}: {error})", False)


# A joint and a beam probe of one name: their series cannot be told apart by the name, so their
# descriptions keep the generic kinds (every one of the joint's was described as the beam probe's).
clash = os.path.join(args.work_dir, "name_clash.yaml")
with open(clash, "w") as f:
    f.write("""sections: [{name: s, EA: 1.0e6, GA2: 1.0e6, GA3: 1.0e6, GJ: 1.0e3, EI2: 1.0e3, EI3: 1.0e3, rhoA: 1.0, rhoJ: [0.01, 0.005, 0.005]}]
nodes: {a: [0, 0, 0], b: [1, 0, 0]}
beams: [{name: arm, section: s, from: a, to: b, elements: 2}]
joints: [{name: lead, type: revolute, master: ground, slave: a, axis: [0, 0, 1]}]
probes: [{name: lead, beam: arm, element: 0}]
loads: [{gravity: [0, -9.81, 0]}]
analysis: {type: dynamic, end_time: 0.02, initial_step: 0.01, max_step: 0.01}
""")
clash_h5 = os.path.join(args.work_dir, "name_clash.h5")
mt.run_msflex(args, clash, clash_h5, extra=["-quiet"])
clash_series = columns(clash_h5)
for column, head in (("lead.force_x", "lead (joint, bushing or reaction probe): "), ("lead.N1", "lead (beam probe): ")):
    description = clash_series.get(column, ("", ""))[1]
    check.true(f"name clash: {column} keeps the generic kind of its series ('{description}')", description.startswith(head))
check.finish()
