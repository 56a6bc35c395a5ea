"""Cantilever roll-up (input/cantilever_rollup.yaml): the end moment 2 pi EI/L rolls the beam into
a full circle. Checks, at the output times t = 0.25, 0.5, 0.75, 1:
 - the tip against the discrete closed form of the 2-node strain-invariant element under pure
   bending (zero axial/shear strain at the Gauss point, element rotation kappa L_e, chord L_e
   along the mid-element tangent): tip = sum_k L_e (cos, sin)((k - 1/2) kappa L_e), to 1e-9 L;
 - the tip against the exact circle to the element's O(h^2) accuracy (1e-2 L);
 - at t = 1: the tip returns to the root (|tip - root| < 1e-6 L) with a tracked rotation of 2 pi
   (quaternion -1)."""

import math

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
output = f"{args.work_dir}/rollup.h5"
mt.run_msflex(args, f"{args.source_dir}/input/cantilever_rollup.yaml", output)
tip = mt.probe_history(output, "tip")
check = mt.Checker("cantilever roll-up")

L, elements = 10.0, 16
Le = L / elements
for t in (0.25, 0.5, 0.75, 1.0):
    row = mt.row_at_time(tip, t)
    position = tip["position"][row]
    phi = 2 * math.pi * t
    angles = (np.arange(elements) + 0.5) * phi / elements
    discrete = np.array([Le * np.cos(angles).sum(), Le * np.sin(angles).sum(), 0.0])
    exact = np.array([L * math.sin(phi) / phi, L * (1 - math.cos(phi)) / phi, 0.0])
    check.less(f"t = {t}: tip vs discrete closed form / L", np.linalg.norm(position - discrete) / L, 1e-9)
    check.less(f"t = {t}: tip vs exact circle / L", np.linalg.norm(position - exact) / L, 1e-2)
    check.less(f"t = {t}: tracked tip rotation angle - 2 pi t", abs(tip["rotation_angle"][row] - phi), 1e-9)

row = mt.row_at_time(tip, 1.0)
check.less("t = 1: |tip - root| / L", np.linalg.norm(tip["position"][row]) / L, 1e-6)
check.less("t = 1: |q - (-1, 0, 0, 0)|", np.linalg.norm(tip["rotation"][row] - np.array([-1.0, 0, 0, 0])), 1e-9)
check.finish()
