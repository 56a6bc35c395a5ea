#!/usr/bin/env python3
"""The layers of src/ (docs/architecture.md), checked on the sources: every quoted include names a
header of its own layer or of a layer it may use, no include climbs out of its folder with '..',
and the kernel layers (math, schemes, elements, joints, model) include no PETSc, MPI, HDF5,
METIS or yaml-cpp header. The build enforces the same rule for what compiles (CMakeLists.txt); this
test also catches includes the compiler would find through a relative path.

Usage: check_layers.py SOURCE_DIR   (exit status 1 and one line per violation when any)."""
import pathlib
import re
import sys

# Folder -> the folders whose headers it may include (its own included), bottom up.
ALLOWED = {
    "math": {"math"},
    "schemes": {"schemes", "math"},
    "elements": {"elements", "schemes", "math"},
    "joints": {"joints", "math"},
    "model": {"model", "joints", "schemes", "math"},
    "core": {"core"},
    "io": {"io", "model", "joints", "schemes", "math", "core"},
    "dofs": {"dofs", "parallel", "model", "joints", "schemes", "math", "core"},
    "parallel": {"parallel", "dofs", "model", "joints", "schemes", "math", "core"},
    "state": {"state", "dofs", "parallel", "model", "joints", "schemes", "math", "core"},
    "contributors": {"contributors", "state", "elements", "dofs", "parallel", "model", "joints", "schemes", "math", "core"},
    "assembly": {"assembly", "contributors", "state", "elements", "dofs", "parallel", "model", "joints", "schemes", "math", "core"},
    "integrators": {"integrators", "assembly", "contributors", "state", "elements", "dofs", "parallel", "model", "joints", "schemes", "math",
                    "core"},
    "output": {"output", "contributors", "state", "elements", "dofs", "parallel", "model", "joints", "schemes", "math", "core"},
    "eigen": {"eigen", "core"},
    "app": set(),  # the top: anything
}
KERNEL_LAYERS = {"math", "schemes", "elements", "joints", "model"}
# System headers a kernel layer must not see: the parallel and I/O libraries.
FORBIDDEN_IN_KERNELS = re.compile(r"^(petsc|mpi|H5|hdf5|metis|yaml-cpp|slepc)", re.IGNORECASE)
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def violations(source_dir):
    src = pathlib.Path(source_dir) / "src"
    folders = {p.name for p in src.iterdir() if p.is_dir()}
    unknown = folders - set(ALLOWED)
    for folder in sorted(unknown):
        yield f"src/{folder}: a folder that belongs to no layer (add it to tests/check_layers.py and CMakeLists.txt)"
    for path in sorted(src.rglob("*")):
        if path.suffix not in (".cpp", ".hpp", ".h"):
            continue
        layer = path.relative_to(src).parts[0]
        allowed = ALLOWED.get(layer)
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            match = INCLUDE.match(line)
            if not match:
                continue
            kind, header = match.groups()
            where = f"{path.relative_to(source_dir)}:{number}"
            if ".." in pathlib.PurePosixPath(header).parts:
                yield f"{where}: includes '{header}', climbing out of its folder"
                continue
            if kind == "<":
                if layer in KERNEL_LAYERS and FORBIDDEN_IN_KERNELS.match(header):
                    yield f"{where}: the {layer} layer is a kernel layer (Eigen only) but includes <{header}>"
                continue
            top = pathlib.PurePosixPath(header).parts[0]
            if top not in folders:
                yield f"{where}: includes \"{header}\", which is not a header of src/"
            elif allowed and top not in allowed:
                yield f"{where}: the {layer} layer includes \"{header}\" of the higher layer {top}"


def main():
    found = list(violations(sys.argv[1] if len(sys.argv) > 1 else "."))
    for line in found:
        print(line)
    print(f"layers: {len(found)} violation(s)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
