"""A lattice with spherical joints written by scripts/make-network twice, all in YAML and with the
nodes, beams and joints in an HDF5 mesh file (--hdf5), gives the same final frame to 1e-12:
node positions (relative to the lattice's extent) and rotations (quaternion components), on 1 rank
and, with --np N > 1, also on N ranks."""

import os
import subprocess
import sys

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
generator = os.path.join(args.source_dir, "scripts", "make-network")
network = ["lattice", "--n", "4", "4", "3", "--elements", "2", "--joint-every", "3"]
yaml_only = os.path.join(args.work_dir, "lattice.yaml")
# The mesh in a subdirectory: `mesh:` is relative to the YAML file, not to the working directory.
with_mesh = os.path.join(args.work_dir, "with_mesh.yaml")
mesh = os.path.join(args.work_dir, "mesh", "lattice_mesh.h5")
os.makedirs(os.path.dirname(mesh), exist_ok=True)
for extra in ([yaml_only], [with_mesh, "--hdf5", mesh]):
    subprocess.run([sys.executable, generator] + network + ["-o"] + extra, check=True)

check = mt.Checker("YAML vs HDF5 mesh")
with open(with_mesh) as stream:
    text = stream.read()
check.true("the short YAML file lists no nodes, beams or joints",
           not any(line.startswith(key) for line in text.splitlines() for key in ("nodes:", "beams:", "joints:")))
check.true("the short YAML file refers to the mesh", "mesh: mesh/lattice_mesh.h5" in text)

for ranks in sorted({1, args.np}):
    results = []
    for name, input_file in (("yaml", yaml_only), ("hdf5", with_mesh)):
        output = os.path.join(args.work_dir, f"{name}_np{ranks}.h5")
        mt.run_msflex(args, input_file, output, np_ranks=ranks)
        results.append(mt.final_frame(output))
    a, b = results
    check.less(f"np {ranks}: final times differ", abs(a["time"] - b["time"]), 1e-14)
    check.equal(f"np {ranks}: HDF5-mesh node count = YAML's", len(b["position"]), len(a["position"]))
    extent = np.ptp(a["position"], axis=0).max()
    check.less(f"np {ranks}: max position difference / extent", np.abs(a["position"] - b["position"]).max() / extent, 1e-12)
    check.less(f"np {ranks}: max rotation (quaternion) difference", np.abs(a["rotation"] - b["rotation"]).max(), 1e-12)
    check.less(f"np {ranks}: the run did something: 1 / max |displacement|", 1.0 / np.abs(a["displacement"]).max(), 1e8)
check.finish()
