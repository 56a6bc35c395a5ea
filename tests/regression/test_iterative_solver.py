"""An iterative alternative to MUMPS (docs/solvers.md): input/bend45.yaml on 2 ranks with GMRES
preconditioned by overlapping Schwarz (ASM, overlap 1, LU subdomain solves) gives the tip
positions of the default direct solve to 1e-8 relative at F = 300, 450, 600."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("iterative solver")
source = f"{args.source_dir}/input/bend45.yaml"
mt.run_msflex(args, source, f"{args.work_dir}/direct.h5", np_ranks=2, extra=["-quiet"])
mt.run_msflex(args, source, f"{args.work_dir}/asm.h5", np_ranks=2,
              extra=["-quiet", "-ksp_type", "gmres", "-ksp_rtol", "1e-12", "-ksp_max_it", "1000", "-ksp_gmres_restart", "200", "-pc_type", "asm",
                     "-sub_pc_type", "lu", "-pc_asm_overlap", "1"])
direct, iterative = mt.probe_history(f"{args.work_dir}/direct.h5", "tip"), mt.probe_history(f"{args.work_dir}/asm.h5", "tip")
for t in (0.5, 0.75, 1.0):
    a, b = direct["position"][mt.row_at_time(direct, t)], iterative["position"][mt.row_at_time(iterative, t)]
    check.less(f"F = {600 * t:.0f}: |tip ASM - tip MUMPS| / |tip|", np.linalg.norm(a - b) / np.linalg.norm(a), 1e-8)
check.finish()
