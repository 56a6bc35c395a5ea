"""The 215-degree deep arch (input/deep_arch.yaml) followed by arc length over its limit point: the
limit load P R^2 / EI within 1e-3 of the published 8.97 (DaDeppo & Schmidt 1975) and within 1e-4 of
8.97284, an independent shooting solution of the extensible planar Reissner rod with the same
stiffnesses (EA = GA = 1e8, EI = 1e6, R = 100); one negative pivot after it."""

import numpy as np

import msflex_testing as mt

PUBLISHED, SHOOTING, SCALE = 8.97, 8.97284, 10.0  # P R^2 / EI = 10 lambda

args = mt.parse_arguments(__doc__)
check = mt.Checker("deep arch")
path = f"{args.work_dir}/deep_arch.h5"
mt.run_msflex(args, f"{args.source_dir}/input/deep_arch.yaml", path)
history = mt.history(path)
limits = SCALE * history["critical_load_factor"][history["critical_point"] == 1]
print(f"limit points (P R^2 / EI): {limits}; largest load on the path {SCALE * history['load_factor'].max():.6f}")
check.true(f"at least 1 limit point found ({len(limits)})", len(limits) >= 1)
if len(limits):
    check.less("limit load relative to the published 8.97", abs(limits[0] / PUBLISHED - 1), 1e-3)
    check.less("limit load relative to the shooting solution 8.97284", abs(limits[0] / SHOOTING - 1), 1e-4)
    after = history["load_factor"] < history["load_factor"].max()
    after &= np.arange(len(after)) > np.argmax(history["load_factor"])
    check.true("states after the limit point exist, each with exactly 1 negative pivot",
               bool(after.any()) and bool(np.all(history["negative_pivots"][after] == 1)))
check.finish()
