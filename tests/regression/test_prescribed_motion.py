"""Prescribed displacements and rotations (tests/regression/inputs/prescribed_motion.yaml):
 - a prescribed tip rotation of 2 pi rolls a cantilever into a circle: the tip returns to the
   root (< 1e-6 L), its tracked rotation is 2 pi (to 1e-10), every element carries the
   curvature 2 pi / L (to 1e-9 relative);
 - a prescribed axial tip displacement 0.5 of a 10 m bar: tip displacement exact (1e-12) and
   axial force EA 0.05 = 500 in every element (to 1e-9 relative);
 - the roller again with its tip rotation given by its rate (prescribe_rate, a constant function):
   the same path, tip positions and tracked rotation equal to the roller's at every step (1e-12)."""

import math

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
output = f"{args.work_dir}/prescribed.h5"
mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/prescribed_motion.yaml", output)
check = mt.Checker("prescribed motion")
roller = mt.probe_history(output, "roller_tip")
puller = mt.probe_history(output, "puller_tip")
rate_roller = mt.probe_history(output, "rate_roller_tip")
row = mt.row_at_time(roller, 1.0)
# The rate roller sits 5 m below the roller: its positions are the roller's shifted by (0, -5, 0).
shift = np.array([0.0, -5.0, 0.0])
check.less("rate roller: largest |tip position - roller's - (0, -5, 0)| over the steps",
           float(np.abs(rate_roller["position"] - roller["position"] - shift).max()), 1e-12)
check.less("rate roller: largest |tracked rotation - roller's| over the steps",
           float(np.abs(rate_roller["rotation_angle"] - roller["rotation_angle"]).max()), 1e-12)
check.less("roller: |tip - root| / L", np.linalg.norm(roller["position"][row]) / 10.0, 1e-6)
check.less("roller: |tracked tip rotation - 2 pi|", abs(roller["rotation_angle"][row] - 2 * math.pi), 1e-10)
check.less("puller: |tip displacement - (0.5, 0, 0)|", np.linalg.norm(puller["displacement"][row] - np.array([0.5, 0, 0])), 1e-12)

frame = mt.final_frame(output)
with h5py.File(output, "r") as f:
    beam_names = [name.decode() if isinstance(name, bytes) else name for name in f["mesh/beam_names"][()]]
    element_beam = f["mesh/element_beam"][()]
roller_elements = element_beam == beam_names.index("roller")
puller_elements = element_beam == beam_names.index("puller")
curvature = frame["element_strains"][roller_elements, 5]
check.less("roller: max |K3 - 2 pi / L| / (2 pi / L)", np.abs(curvature / (2 * math.pi / 10) - 1).max(), 1e-9)
axial_force = frame["element_resultants"][puller_elements, 0]
check.less("puller: max |N1 - 500| / 500", np.abs(axial_force / 500.0 - 1).max(), 1e-9)
check.finish()
