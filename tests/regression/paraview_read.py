"""The ParaView side of test_paraview.py; runs under pvpython, not the test's python3.

Opens an msflex .xmf sidecar with one of ParaView's XDMF readers, reads every time step and
writes what ParaView sees into a .npz file, without judging it: the reader's time step values, and
per time step and per grid (beams, bodies, joints, ground: the leaves of the reader's output, in
order) the point coordinates, the cells (type and point ids) and every point and cell array
(values as a tuples x components array, with the number of components and tuples as VTK reports
them), and the block names the reader gives. test_paraview.py compares these numbers with the
HDF5 file read by h5py.

  pvpython paraview_read.py RESULT.xmf OUT.npz --reader XDMFReader|Xdmf3ReaderS
"""

import argparse
import os

import numpy as np
from paraview import servermanager
from paraview import simple
from vtkmodules.util.numpy_support import vtk_to_numpy

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("xmf", help="XDMF sidecar written by msflex")
parser.add_argument("output", help=".npz file to write")
parser.add_argument("--reader", default="XDMFReader", choices=["XDMFReader", "Xdmf3ReaderS", "Xdmf3ReaderT"],
                    help="ParaView reader (the GUI's 'XDMF Reader' and 'Xdmf3 Reader')")
args = parser.parse_args()

# The Xdmf3 readers resolve the .h5 name against the directory of the .xmf path as given, and
# fail on a bare file name: always give them an absolute path.
xmf = os.path.abspath(args.xmf)
if args.reader == "XDMFReader":
    reader = simple.XDMFReader(FileNames=[xmf])
else:
    reader = getattr(simple, args.reader)(FileName=[xmf])
reader.UpdatePipelineInformation()
times = np.array(reader.TimestepValues, dtype=float).reshape(-1)

result = {"times": times}


def array_entries(prefix, data):
    names = []
    for index in range(data.GetNumberOfArrays()):
        array = data.GetArray(index)
        name = array.GetName()
        tuples, components = array.GetNumberOfTuples(), array.GetNumberOfComponents()
        result[f"{prefix}.{name}"] = vtk_to_numpy(array).astype(float).reshape(tuples, components)
        result[f"{prefix}.{name}.shape"] = np.array([tuples, components])
        names.append(name)
    return names


def leaves(data, name=""):
    """(block name, data set) of every leaf of a composite data set, in order."""
    if not data.IsA("vtkCompositeDataSet"):
        return [(name, data)]
    found = []
    iterator = data.NewIterator()
    iterator.SetSkipEmptyNodes(False)
    iterator.InitTraversal()
    while not iterator.IsDoneWithTraversal():
        leaf = iterator.GetCurrentDataObject()
        metadata = iterator.GetCurrentMetaData()
        label = metadata.Get(data.NAME()) if metadata and metadata.Has(data.NAME()) else ""
        if leaf is not None:
            found.append((label, leaf))
        iterator.GoToNextItem()
    return found


for step, time in enumerate(times):
    reader.UpdatePipeline(time)
    blocks = leaves(servermanager.Fetch(reader))
    key = f"step{step}"
    result[f"{key}.blocks"] = np.array([label for label, _ in blocks])
    for index, (_, grid) in enumerate(blocks):
        prefix = f"{key}.block{index}"
        points = grid.GetPoints()
        result[f"{prefix}.points"] = vtk_to_numpy(points.GetData()).astype(float).reshape(-1, 3) if points else np.zeros((0, 3))
        cell_types, cell_points = [], []
        for cell in range(grid.GetNumberOfCells()):
            ids = grid.GetCell(cell).GetPointIds()
            cell_types.append(grid.GetCellType(cell))
            cell_points.append([ids.GetId(k) for k in range(ids.GetNumberOfIds())])
        result[f"{prefix}.cell_types"] = np.array(cell_types, dtype=int)
        lengths = {len(p) for p in cell_points}
        result[f"{prefix}.cells"] = np.array(cell_points, dtype=int) if len(lengths) <= 1 else np.array([], dtype=int)
        result[f"{prefix}.cell_sizes"] = np.array([len(p) for p in cell_points], dtype=int)
        result[f"{prefix}.point_arrays"] = np.array(array_entries(f"{prefix}.point", grid.GetPointData()))
        result[f"{prefix}.cell_arrays"] = np.array(array_entries(f"{prefix}.cell", grid.GetCellData()))

np.savez(args.output, **result)
print(f"{args.reader}: {len(times)} time steps written to {args.output}")
