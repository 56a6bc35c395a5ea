"""A long chain of rigid bodies on revolute joints (scripts/make-chain --kind rigid: each body the
master of the next, body 0 turning about the ground at 0.1 rad/s) completes its step with
relay nodes (the default condensation depth) on 1 and 2 ranks. Its residual bottoms out at the
rounding of the inertia forces' moments about the masters, whose lever arms are as long as the
chain: 1000 joints stopped after 25 Newton iterations at |R| = 1.2e-2 against a needed 6.8e-7, and
the documented 6000-joint run failed likewise. Newton must finish within 6 iterations. A chain of
beams hanging at rest gives the projection of the initial velocities nothing to do: it skips its
solve and says so."""

import os
import subprocess
import sys

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("long chain")
for joints, ranks in ((1000, 1), (3000, 1), (1000, 2)):
    chain = f"{args.work_dir}/chain{joints}.yaml"
    subprocess.run([sys.executable, os.path.join(args.source_dir, "scripts", "make-chain"), "--joints", str(joints), "--kind", "rigid", "-o", chain],
                   check=True, capture_output=True)
    path = f"{args.work_dir}/chain{joints}_np{ranks}.h5"
    code, _, stderr = mt.run_msflex(args, chain, path, extra=["-quiet"], np_ranks=ranks, expect_success=False)
    label = f"{joints} joints on {ranks} rank(s)"
    print(f"{label}: exit {code} {stderr.strip()[:300]}")
    check.equal(f"{label}: exit status", code, 0)
    if code == 0:
        h = mt.history(path)
        check.equal(f"{label}: steps", len(h["time"]) - 1, 1)
        check.less(f"{label}: Newton iterations", float(h["newton_iterations"][-1]), 6.5)
# A chain of beams hanging at rest (nothing given, nothing driven): the projection of the initial
# velocities has nothing to do and skips its factorisation, and says so.
beams = f"{args.work_dir}/beam_chain.yaml"
subprocess.run([sys.executable, os.path.join(args.source_dir, "scripts", "make-chain"), "--joints", "20", "--kind", "beams", "-o", beams], check=True,
               capture_output=True)
code, stdout, _ = mt.run_msflex(args, beams, f"{args.work_dir}/beam_chain.h5", np_ranks=1)
check.true("beams at rest: the velocity projection is skipped (nothing strains)", "nothing strains, no solve" in stdout)
check.finish()
