"""Path independence (tests/regression/inputs/load_cycle.yaml): loading a curved, twisted
cantilever in steps and unloading it to zero returns every node to its initial position and
triad, to 1e-10 (displacements relative to the beam's extent; rotation angles in rad)."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
output = f"{args.work_dir}/load_cycle.h5"
mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/load_cycle.yaml", output)
check = mt.Checker("load cycle")
tip = mt.probe_history(output, "tip")
loaded = mt.row_at_time(tip, 1.0)
check.less("the load cycle deforms the beam: 1 / |tip displacement at t = 1|", 1.0 / np.linalg.norm(tip["displacement"][loaded]), 1.0)
frame = mt.final_frame(output)
check.less("final time - 2", abs(frame["time"] - 2.0), 1e-12)
extent = 4.031128874149275 * np.pi / 2
check.less("max |u| / extent after unloading", np.abs(frame["displacement"]).max() / extent, 1e-10)
q = frame["rotation"]
angles = 2 * np.arctan2(np.linalg.norm(q[:, 1:], axis=1), q[:, 0])
check.less("max nodal rotation angle after unloading", angles.max(), 1e-10)
check.finish()
