"""Joint constraints hold exactly (tests/regression/inputs/joint_mechanism.yaml, genalpha, output at
every step): for every joint and every step, the slave's position and triad equal eq. (1) from the
master's and the released coordinates written in the history,
    x_s = x_m + R_m (d0 + A t),   R_s = R_m C,
to 1e-12; and the dependent laws hold to 1e-12: screw translation = pitch x angle, rack
translation = radius x angle, cam lift = R (cos angle - 1); the driven revolute follows its drive."""

import math

import h5py
import numpy as np

import msflex_testing as mt


args = mt.parse_arguments(__doc__)
output = f"{args.work_dir}/mechanism.h5"
mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/joint_mechanism.yaml", output, extra=["-quiet"])
check = mt.Checker("joint constraints")
h = mt.history(output)
with h5py.File(output, "r") as f:
    names = [n.decode() if isinstance(n, bytes) else n for n in f["mesh/joint_names"][()]]
    types = [n.decode() if isinstance(n, bytes) else n for n in f["mesh/joint_types"][()]]
    masters, slaves = f["mesh/joint_master"][()], f["mesh/joint_slave"][()]
    axes, offsets = f["mesh/joint_axes"][()], f["mesh/joint_offset"][()]
    reference = f["mesh/node_coordinates"][()]
    frames = mt.frames(f)
    times = [frame["time"] for frame in frames]
    positions = [frame["position"] for frame in frames]
    rotations = [frame["rotation"] for frame in frames]
check.equal("frames written at every step: frames = history rows", len(frames), len(h["time"]))

pitch, rack_radius, cam_radius = 0.3, 0.2, 0.15  # as in the input
worst_position = worst_rotation = 0.0
for j, (name, kind) in enumerate(zip(names, types)):
    A = axes[j].reshape(3, 3).T  # columns a1, a2, a3
    series = lambda q: h.get(f"{name}.{q}", np.zeros(len(h["time"])))
    for row, (t, x, q) in enumerate(zip(times, positions, rotations)):
        assert abs(h["time"][row] - t) < 1e-12
        if masters[j] >= 0:
            x_m, R_m = x[masters[j]], mt.quaternion_matrix(q[masters[j]])
        else:  # the ground frame sits at the slave's reference position
            x_m, R_m = reference[slaves[j]], np.eye(3)
        x_s, R_s = x[slaves[j]], mt.quaternion_matrix(q[slaves[j]])
        t_joint = np.array([series("tx")[row], series("ty")[row], series("tz")[row]])
        rx, ry, rz = series("rx")[row], series("ry")[row], series("rz")[row]
        if kind == "universal":
            C = mt.expm(rx * A[:, 0]) @ mt.expm(ry * A[:, 1])
        elif kind in ("spherical", "free"):
            C = mt.expm(A @ np.array([rx, ry, rz]))
        else:
            C = mt.expm(rx * A[:, 0] + ry * A[:, 1] + rz * A[:, 2])
        worst_position = max(worst_position, np.abs(x_s - (x_m + R_m @ (offsets[j] + A @ t_joint))).max())
        worst_rotation = max(worst_rotation, np.abs(R_s - R_m @ C).max())
    print(f"{name} ({kind}): checked {len(frames)} steps")
check.less("max |x_s - eq. (1)| over joints and steps", worst_position, 1e-12)
check.less("max |R_s - R_m C| over joints and steps", worst_rotation, 1e-12)
check.less("screw: max |tx - pitch rx|", np.abs(h["lead.tx"] - pitch * h["lead.rx"]).max(), 1e-12)
check.less("rack: max |ty - radius rx|", np.abs(h["pinion.ty"] - rack_radius * h["pinion.rx"]).max(), 1e-12)
check.less("cam: max |ty - R (cos rx - 1)|", np.abs(h["lobe.ty"] - cam_radius * (np.cos(h["lobe.rx"]) - 1)).max(), 1e-12)
drive = 0.4 * np.sin(2 * math.pi * 0.5 * h["time"])
check.less("driven revolute: max |rx - drive(t)|", np.abs(h["hinge.rx"] - drive).max(), 1e-12)
check.less("the mechanism moves: 1 / max |screw angle|", 1.0 / np.abs(h["lead.rx"]).max(), 1e6)
check.finish()
