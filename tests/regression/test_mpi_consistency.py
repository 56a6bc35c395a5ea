"""The same input run on 1 and on --np ranks gives the same final state to 1e-10: node positions
(relative to the model's extent) and rotations (quaternion components). Element stress
resultants, derived from position differences times the stiffness, agree to 1e-8 of the largest
resultant (they amplify the state's round-off by roughly EA / |N|). Input: --input."""

import numpy as np

import msflex_testing as mt

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
check.finish()
