"""METIS partitioning (issue 5): a mechanism with joints (tests/regression/inputs/joint_mechanism.yaml)
run on 1, 2 and 3 ranks (oversubscribed) with -partitioner metis gives the same final state to
1e-9 relative; the partition is written to /mesh/node_rank, uses every rank, differs between
the rank counts, and never splits a joint (master and slave on one rank). A model whose nodes all belong to one
group leaves a rank without nodes, and the run says so in one warning."""

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("METIS partition")
source = f"{args.source_dir}/tests/regression/inputs/joint_mechanism.yaml"
frames, partitions = {}, {}
for ranks in (1, 2, 3):
    output = f"{args.work_dir}/np{ranks}.h5"
    mt.run_msflex(args, source, output, np_ranks=ranks, extra=["-partitioner", "metis", "-analysis_end_time", "0.2", "-quiet"])
    frames[ranks] = mt.final_frame(output)
    with h5py.File(output, "r") as f:
        partitions[ranks] = f["mesh/node_rank"][()]
        masters, slaves = f["mesh/joint_master"][()], f["mesh/joint_slave"][()]
    counts = np.bincount(partitions[ranks], minlength=ranks)
    print(f"np {ranks}: nodes per rank {counts.tolist()}")
    check.equal(f"np {ranks}: ranks without nodes", np.count_nonzero(counts == 0), 0)
    split = sum(1 for m, s in zip(masters, slaves) if m >= 0 and partitions[ranks][m] != partitions[ranks][s])
    check.equal(f"np {ranks}: joints split between ranks", split, 0)
extent = np.ptp(frames[1]["position"], axis=0).max()
for ranks in (2, 3):
    check.less(f"np {ranks} vs 1: max position difference / extent", np.abs(frames[ranks]["position"] - frames[1]["position"]).max() / extent, 1e-9)
    check.less(f"np {ranks} vs 1: max quaternion difference", np.abs(frames[ranks]["rotation"] - frames[1]["rotation"]).max(), 1e-9)
check.true("the partitions of 2 and 3 ranks differ", not np.array_equal(partitions[2], partitions[3]))

# A model of fewer nodes than ranks (a rigid body hinged to the ground: one node) leaves a rank
# without nodes, which runs then silently did: said once, on stderr; a serial run says nothing.
with open(f"{args.work_dir}/one_group.yaml", "w") as f:
    f.write("""nodes: {pivot: [0, 0, 0]}
rigid_bodies: [{node: pivot, mass: 1.0, inertia: [1, 1, 1], offset: [1, 0, 0]}]
joints: [{name: hinge, type: revolute, master: ground, slave: pivot, axis: [0, 0, 1]}]
loads: [{gravity: [0, -9.81, 0]}]
analysis: {type: dynamic, end_time: 0.02, initial_step: 0.01, max_step: 0.01}
""")
for ranks in (1, 2):
    _, _, stderr = mt.run_msflex(args, f"{args.work_dir}/one_group.yaml", f"{args.work_dir}/one_group_{ranks}.h5", np_ranks=ranks, extra=["-quiet"])
    warnings = [line for line in stderr.splitlines() if line.startswith("msflex: warning: the partition leaves rank(s) 1 without a node")]
    check.equal(f"one group of nodes on {ranks} rank(s): warnings of a rank without nodes", len(warnings), 1 if ranks > 1 else 0)
check.finish()
