"""The same input run on 1 and on --np ranks gives the same results.

Final state to 1e-10: node positions (relative to the model's extent) and rotations (quaternion
components). Element stress resultants, derived from position differences times the stiffness,
agree to 1e-8 of the largest resultant (they amplify the state's round-off by roughly EA / |N|).

Every history series (energies, momenta, joint coordinates and reactions, force elements,
probes: node, element and reaction probes), row by row, to 1e-8 of the largest |value| among the
series of its unit (a series that is zero up to round-off is measured on the scale of its kind:
a free direction's reaction on that of the supported ones). The solver's own diagnostics
(residual norm, Newton iterations, em's beta) are left out: they differ at round-off between
partitions. Rank 0 writes the history from what every rank holds, so a series taken from one
rank's part only (a reaction probe at a node of rank 1, say) shows here. The input's `expected`
results, if it has any, are checked on both files. Input: --input."""

import collections

import numpy as np

import msflex_testing as mt

msflex_h5 = mt.msflex_h5

SOLVER_DIAGNOSTICS = ("residual_norm", "newton_iterations", "energy_correction")

args = mt.parse_arguments(__doc__)
input_file = args.input
serial = f"{args.work_dir}/np1.h5"
parallel = f"{args.work_dir}/np{args.np}.h5"
mt.run_msflex(args, f"{args.source_dir}/{input_file}", serial, np_ranks=1)
mt.run_msflex(args, f"{args.source_dir}/{input_file}", parallel)
a, b = mt.final_frame(serial), mt.final_frame(parallel)
check = mt.Checker(f"np 1 vs np {args.np}: {input_file}")
check.less("final times differ", abs(a["time"] - b["time"]), 1e-14)
extent = np.ptp(a["position"], axis=0).max()
check.less("max position difference / extent", np.abs(a["position"] - b["position"]).max() / extent, 1e-10)
check.less("max rotation (quaternion) difference", np.abs(a["rotation"] - b["rotation"]).max(), 1e-10)
scale = np.abs(a["element_resultants"]).max()
check.less("max stress resultant difference / max resultant", np.abs(a["element_resultants"] - b["element_resultants"]).max() / scale, 1e-8)
check.less("the run did something: 1 / max |displacement|", 1.0 / np.abs(a["displacement"]).max(), 1e6)

with msflex_h5.HistoryFile(serial) as hs, msflex_h5.HistoryFile(parallel) as hp:
    check.true("the same history series on 1 and on more ranks", hs.names() == hp.names())
    one, more = hs.read_all(), hp.read_all()
    units = {name: hs.quantity(name)[0] for name in one}
check.equal("history rows", len(more["time"]), len(one["time"]))
compared = [name for name in one if name.rsplit(".", 1)[-1] not in SOLVER_DIAGNOSTICS]
family_scale = collections.defaultdict(float)
for name in compared:
    family_scale[units[name]] = max(family_scale[units[name]], float(np.abs(one[name]).max()))
worst, worst_name = 0.0, None
for name in compared:
    difference = float(np.abs(one[name] - more[name]).max()) / max(family_scale[units[name]], 1e-300)
    if difference > worst:
        worst, worst_name = difference, name
print(f"{len(compared)} history series of {len(one['time'])} rows compared; largest difference {worst:.3e} of its unit's scale ({worst_name})")
check.less(f"history series: largest difference / the scale of its unit ({worst_name})", worst, 1e-8)
options = args.options.split()
end_time = float(options[options.index("-analysis_end_time") + 1]) if "-analysis_end_time" in options else None
for ranks, path in ((1, serial), (args.np, parallel)):
    mt.check_expected(check, f"{args.source_dir}/{input_file}", path, f"np {ranks}", end_time=end_time)
check.finish()
