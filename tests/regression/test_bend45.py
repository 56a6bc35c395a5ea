"""Bathe-Bolourchi 45-degree bend (input/bend45.yaml, 8 quadratic elements): tip displacements at
F = 300, 450, 600 within 0.5 % of the converged exact-arc values (benchmarks C2, BeamDyn
stiffness set), measured per component relative to the displacement magnitude."""

import numpy as np

import msflex_testing as mt

REFERENCE_TIP = {  # load factor: converged tip position (shooting solution on the exact arc)
    0.5: (58.7783, 22.2443, 40.1933),
    0.75: (52.2376, 18.5077, 48.5042),
    1.0: (47.1494, 15.6843, 53.4761),
}
UNDEFORMED_TIP = np.array([70.71067811865476, 29.289321881345245, 0.0])

args = mt.parse_arguments(__doc__)
output = f"{args.work_dir}/bend45.h5"
mt.run_msflex(args, f"{args.source_dir}/input/bend45.yaml", output)
tip = mt.probe_history(output, "tip")
check = mt.Checker("45-degree bend")
for t, reference in REFERENCE_TIP.items():
    row = mt.row_at_time(tip, t)
    displacement = tip["displacement"][row]
    reference_displacement = np.array(reference) - UNDEFORMED_TIP
    error = np.abs(displacement - reference_displacement).max() / np.linalg.norm(reference_displacement)
    print(f"F = {600 * t:.0f}: tip displacement {np.array2string(displacement, precision=4)}, reference {np.array2string(reference_displacement, precision=4)}")
    check.less(f"F = {600 * t:.0f}: max component error / |u_ref|", error, 5e-3)
check.finish()
