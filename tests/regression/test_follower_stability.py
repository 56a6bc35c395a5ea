"""Stability along a path under a follower load (tests/regression/inputs/follower_cantilever.yaml).
A follower force makes the tangent non-symmetric however small the asymmetry is next to stiff
axial and shear terms; the symmetry test (relative asymmetry 1e-8) took it for symmetric there,
counted the pivots of an LDL^T and named bifurcations at load factors 2.4 and 9.7 and jumps at
16 and 19 on a smooth, non-singular path. Now: no critical point named, the pivots not counted
(negative_pivots -1, the non-symmetric marker), and the tip's deflection at load factor 20 as a
shooting solution of the planar elastica gives it, (x, y) = (0.2757101, -0.3301575) to 1e-3."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("follower-load stability")
path = f"{args.work_dir}/follower.h5"
mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/follower_cantilever.yaml", path, extra=["-quiet"])
h = mt.history(path)
named = int(np.count_nonzero(h["critical_point"]))
print(f"{len(h['time']) - 1} steps; critical points named {named}; negative_pivots {sorted(set(h['negative_pivots'].tolist()))}")
check.equal("critical points named along the smooth path", named, 0)
check.true("the tangent is taken as non-symmetric at every step (negative_pivots -1)", bool(np.all(h["negative_pivots"][1:] == -1)))
tip = mt.probe_history(path, "tip")
final = tip["position"][-1]
check.less("tip x at load factor 20 against the shooting solution", abs(final[0] - 0.2757101), 1e-3)
check.less("tip y at load factor 20 against the shooting solution", abs(final[1] + 0.3301575), 1e-3)
check.finish()
