"""ParaView reads what msflex writes, and postproc/render-paraview renders it.

Three runs: input/flying_spaghetti.yaml (em, dt = 0.01) to t = 7.5 with a frame every 50 steps (with
the input's output_times 2.5, 5, 7.5: 16 frames), beams only; and input/driven_screw.yaml to
t = 0.3 (a frame every step), with a rigid body, four joints and two joints to the ground; and
input/bushing_mount.yaml to t = 0.06 (a static stage, then a frame every 20 steps), with a rigid
body, a clamped node and a bushing between two nodes; each
twice, with the default sidecar (-output_xdmf xdmf3) and with -output_xdmf xdmf2. The xdmf3
sidecars are opened with ParaView's Xdmf3 readers (Xdmf3ReaderS and Xdmf3ReaderT), the xdmf2 ones
with its XDMF Reader (XDMFReader), in pvpython (paraview_read.py, which dumps what ParaView sees
into a .npz file), and compared with the HDF5 file read by h5py:
 - time steps: one per frame (/frames/step), at the frames' times (/frames/time);
 - per time step, the grids in order: beams, then bodies, joints, ground and force_elements when
   the model has them (XDMFReader names its blocks so; a single grid comes alone);
 - beams: n_nodes points at the frame's `position`, n_segments 2-node poly-line cells with the point
   ids of /mesh/segments; point arrays displacement [m], rotation (4 components), velocity [m/s],
   angular_velocity [rad/s], cell arrays force [N], moment [N m] and section_e1..e3, and no others
   (velocities and section triads where the frame's /frames/contents has them: in every frame of
   these dynamic runs);
 - bodies: a vertex at each centre of mass (`body_center`) with axis_1..3 [m] (`body_axis_1..3`),
   rotation (`body_rotation`), semi_axes [m] and mass [kg] (/mesh/body_semi_axes, body_mass) and
   the body index; joints: a vertex at each slave node (`joint_position`) with a1..a3 (`joint_a1..3`)
   and the joint index; ground: a vertex at each /mesh/ground_position with a1..a3 (/mesh/ground_a1..3);
   force_elements: the frame's `position` as points, the 2-node poly-lines of
   /mesh/force_element_vertices as cells, cell array kind (/mesh/force_element_kind_codes);
 - values: every array at every time step equals its dataset, difference 0.
Then renders PNGs with postproc/render-paraview (the spaghetti's last frame coloured by
displacement; t = 2.5 in grey with the section triads; the driven screw with its body, joints and
ground, from both sidecars) and checks that each has the requested size and is not blank, that the triads put red,
green and blue pixels into the second and the joint axes (magenta), body (orange) and ground
(brown) show in the third; the bushing mount's force element (cyan) from both sidecars, and not with
--no-force-elements; and a movie of the driven screw (--movie, every 4th frame): the PNG
series and an .mp4 file made by ffmpeg. Last the errors, one line each: a missing file (named as
given), a sidecar without frames of either syntax (exit 1), an unknown --colormap and a --range
with MIN >= MAX (exit 2); input/rack_pinion.yaml's default colour range is over the nodes its
beams draw (not the pinion's node), with --nodes over all; and its result renders while another
process holds it open for writing with HDF5 file locking."""

import os
import shutil
import subprocess
import sys

import h5py
import matplotlib.image
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("paraview")
here = os.path.dirname(os.path.abspath(__file__))
render_paraview = os.path.join(args.source_dir, "postproc", "render-paraview")

pvpython = shutil.which("pvpython")
if not pvpython:
    raise SystemExit("pvpython not found: scripts/setup installs it (Debian package paraview)")

results = {}  # (model, flavour) -> result file
for flavour in ("xdmf3", "xdmf2"):
    suffix = "" if flavour == "xdmf3" else "_xdmf2"
    results["spaghetti", flavour] = os.path.join(args.work_dir, f"flying_spaghetti{suffix}.h5")
    mt.run_msflex(args, f"{args.source_dir}/input/flying_spaghetti.yaml", results["spaghetti", flavour],
                  extra=["-analysis_end_time", "7.5", "-output_every", "50", "-quiet", "-output_xdmf", flavour])
    results["screw", flavour] = os.path.join(args.work_dir, f"driven_screw{suffix}.h5")
    mt.run_msflex(args, f"{args.source_dir}/input/driven_screw.yaml", results["screw", flavour],
                  extra=["-analysis_end_time", "0.3", "-quiet", "-output_xdmf", flavour])
    results["bushing", flavour] = os.path.join(args.work_dir, f"bushing_mount{suffix}.h5")
    mt.run_msflex(args, f"{args.source_dir}/input/bushing_mount.yaml", results["bushing", flavour],
                  extra=["-analysis_end_time", "0.06", "-quiet", "-output_xdmf", flavour])
spaghetti, screw = results["spaghetti", "xdmf3"], results["screw", "xdmf3"]


def expected_grids(path):
    """Per frame, per grid kind: points, cells (None: one vertex per point), point and cell arrays
    (XDMF name -> values), all from the HDF5 file. A frame has the velocities, section triads,
    bodies and joints that its bit of /frames/contents says (mt.frame leaves out the others)."""
    with h5py.File(path, "r") as f:
        mesh = f["mesh"]
        frames = mt.frames(f)
        times = f["frames/time"][()]
        result = []
        for frame in frames:
            point = {"displacement [m]": frame["displacement"], "rotation": frame["rotation"]}
            if "velocity" in frame:
                point.update({"velocity [m/s]": frame["velocity"], "angular_velocity [rad/s]": frame["angular_velocity"]})
            cell = {"force [N]": frame["segment_force"], "moment [N m]": frame["segment_moment"]}
            if "segment_e1" in frame:
                cell.update({f"section_e{k}": frame[f"segment_e{k}"] for k in (1, 2, 3)})
            grids = {"beams": {"points": frame["position"], "cells": mesh["segments"][()], "point": point, "cell": cell}}
            if "body_center" in frame:
                n = len(mesh["body_names"])
                grids["bodies"] = {"points": frame["body_center"], "cells": None, "cell": {},
                                   "point": {**{f"axis_{k} [m]": frame[f"body_axis_{k}"] for k in (1, 2, 3)},
                                             "rotation": frame["body_rotation"], "semi_axes [m]": mesh["body_semi_axes"][()],
                                             "mass [kg]": mesh["body_mass"][()].reshape(n, 1), "body": np.arange(n).reshape(n, 1)}}
            if "joint_position" in frame:
                n = len(mesh["joint_names"])
                grids["joints"] = {"points": frame["joint_position"], "cells": None, "cell": {},
                                   "point": {**{f"a{k}": frame[f"joint_a{k}"] for k in (1, 2, 3)}, "joint": np.arange(n).reshape(n, 1)}}
            if "ground_names" in mesh:
                grids["ground"] = {"points": mesh["ground_position"][()], "cells": None, "cell": {},
                                   "point": {f"a{k}": mesh[f"ground_a{k}"][()] for k in (1, 2, 3)}}
            if "force_element_names" in mesh:
                grids["force_elements"] = {"points": frame["position"], "cells": mesh["force_element_vertices"][()], "point": {},
                                           "cell": {"kind": mesh["force_element_kind_codes"][()]}}
            result.append(grids)
    return times, result


def difference(paraview, hdf5):
    """max |paraview - hdf5|, or inf when the shapes differ."""
    if paraview.shape != hdf5.shape:
        print(f"     shape {paraview.shape} in ParaView, {hdf5.shape} in HDF5")
        return np.inf
    return float(np.abs(paraview - hdf5).max()) if paraview.size else 0.0


def compare(name, h5, expected_kinds, readers, every_frame_full=True):
    times_h5, frames = expected_grids(h5)
    xmf = os.path.splitext(h5)[0] + ".xmf"
    print(f"{name}: {len(times_h5)} frames, t = {times_h5[0]:g} .. {times_h5[-1]:g}, grids {', '.join(frames[0])}")
    check.true(f"{name}: grids {expected_kinds} in the file", list(frames[0]) == expected_kinds)
    partial = [k for k, grids in enumerate(frames) if list(grids) != expected_kinds or "velocity [m/s]" not in grids["beams"]["point"]
               or "section_e1" not in grids["beams"]["cell"]]
    if every_frame_full:
        check.equal(f"{name}: frames without all grids, velocities and section triads ({partial[:5]})", len(partial), 0)
    for reader in readers:
        dump = os.path.join(args.work_dir, f"{name}.{reader}.npz")
        result = subprocess.run([pvpython, os.path.join(here, "paraview_read.py"), xmf, dump, "--reader", reader],
                                capture_output=True, text=True, timeout=600)
        if result.returncode != 0 or not os.path.isfile(dump):
            sys.stderr.write(result.stdout + result.stderr[-4000:])
            raise SystemExit(f"pvpython paraview_read.py failed ({result.returncode}) with {reader}")
        pv = np.load(dump)
        times = pv["times"]
        check.equal(f"{name}, {reader}: time steps = frames", len(times), len(times_h5))
        if len(times) != len(times_h5):
            continue
        check.less(f"{name}, {reader}: max |time - frame time|", float(np.abs(times - times_h5).max()), 1e-300)
        worst = {"points": 0.0, "values": 0.0}
        failing = {"grids": set(), "names": set(), "cells": set(), "array set": set()}  # steps where the check fails
        worst_by_grid = {kind: 0.0 for kind in expected_kinds}
        for step, grids in enumerate(frames):
            key = f"step{step}"
            blocks = pv[f"{key}.blocks"].tolist()
            if len(blocks) != len(grids):
                failing["grids"].add(step)
            if reader == "XDMFReader" and len(grids) > 1 and blocks != list(grids):  # a single grid comes alone, not as a named block
                failing["names"].add(step)
            if len(blocks) != len(grids):
                print(f"     {key}: blocks {blocks}")
                continue
            for index, (kind, grid) in enumerate(grids.items()):
                prefix = f"{key}.block{index}"
                worst["points"] = max(worst["points"], difference(pv[f"{prefix}.points"], grid["points"]))
                n = len(grid["points"])
                if grid["cells"] is None:  # one vertex cell (VTK_VERTEX 1 or VTK_POLY_VERTEX 2) per point
                    cells_ok = (np.all(np.isin(pv[f"{prefix}.cell_types"], (1, 2))) and pv[f"{prefix}.cells"].shape == (n, 1)
                                and np.array_equal(pv[f"{prefix}.cells"][:, 0], np.arange(n)))
                else:  # VTK_POLY_LINE (4) cells of two points each, with the point ids of /mesh/segments
                    cells_ok = (np.all(pv[f"{prefix}.cell_types"] == 4) and pv[f"{prefix}.cells"].shape == grid["cells"].shape
                                and np.array_equal(pv[f"{prefix}.cells"], grid["cells"]))
                if not cells_ok:
                    failing["cells"].add(step)
                names_ok = (sorted(pv[f"{prefix}.point_arrays"].tolist()) == sorted(grid["point"])
                            and sorted(pv[f"{prefix}.cell_arrays"].tolist()) == sorted(grid["cell"]))
                if not names_ok:
                    failing["array set"].add(step)
                    print(f"     {key} {kind}: point arrays {pv[f'{prefix}.point_arrays']}, cell arrays {pv[f'{prefix}.cell_arrays']}")
                    continue
                for where in ("point", "cell"):
                    for array, values in grid[where].items():
                        d = difference(pv[f"{prefix}.{where}.{array}"], values.reshape(len(values), -1).astype(float))
                        worst["values"] = max(worst["values"], d)
                        worst_by_grid[kind] = max(worst_by_grid[kind], d)
        steps = len(frames)
        check.equal(f"{name}, {reader}: steps with grids missing or extra", len(failing["grids"]), 0)
        if reader == "XDMFReader" and len(frames[0]) > 1:
            check.equal(f"{name}, {reader}: steps whose block names differ from {list(frames[0])}", len(failing["names"]), 0)
        check.less(f"{name}, {reader}: points vs positions, max difference over {steps} steps", worst["points"], 1e-300)
        check.equal(f"{name}, {reader}: steps whose cells are not poly-lines of /mesh/segments or one vertex per point", len(failing["cells"]), 0)
        check.equal(f"{name}, {reader}: steps whose array names differ from the HDF5 datasets' with units", len(failing["array set"]), 0)
        for kind, value in worst_by_grid.items():
            check.less(f"{name}, {reader}: {kind} arrays vs their datasets, max difference over {steps} steps", value, 1e-300)


for flavour, readers in (("xdmf3", ("Xdmf3ReaderS", "Xdmf3ReaderT")), ("xdmf2", ("XDMFReader",))):
    compare(f"flying_spaghetti ({flavour})", results["spaghetti", flavour], ["beams"], readers)
    compare(f"driven_screw ({flavour})", results["screw", flavour], ["beams", "bodies", "joints", "ground"], readers)
    # Its static stage's frame has no velocities.
    compare(f"bushing_mount ({flavour})", results["bushing", flavour], ["beams", "bodies", "ground", "force_elements"], readers, every_frame_full=False)
xmf = os.path.splitext(spaghetti)[0] + ".xmf"


def render(png, *options):
    command = [sys.executable, render_paraview, xmf, "-o", png, "--xvfb", *options]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr[-4000:])
        raise SystemExit(f"render-paraview failed ({result.returncode}): {' '.join(command)}")
    image = matplotlib.image.imread(png)[:, :, :3]  # floats in [0, 1]
    height, width = image.shape[:2]
    background = image[0, -1]  # the upper right corner, away from title, legend and axes
    drawn = np.abs(image - background).max(axis=2) > 0.1
    print(f"{os.path.basename(png)}: {width} x {height}, background {background}, drawn {drawn.mean():.4f} of the pixels, "
          f"grey-level standard deviation {image.mean(axis=2).std():.4f}")
    return image, drawn


def pixel_size_check(name, image, size):
    height, width = image.shape[:2]
    check.equal(f"{name}: width in pixels", width, size[0])
    check.equal(f"{name}: height in pixels", height, size[1])


png = os.path.join(args.work_dir, "last.png")
image, drawn = render(png, "--size", "640", "360")
pixel_size_check("last.png", image, (640, 360))
check.less("last.png: not blank (0.01 / fraction of drawn pixels)", 0.01 / max(drawn.mean(), 1e-12), 1.0)
check.less("last.png: varied (0.02 / grey-level standard deviation)", 0.02 / max(image.mean(axis=2).std(), 1e-12), 1.0)
chroma = image.max(axis=2) - image.min(axis=2)
check.true(f"last.png: coloured by displacement (more than 200 pixels of chroma > 0.3: {(chroma > 0.3).sum()})", bool((chroma > 0.3).sum() > 200))

png = os.path.join(args.work_dir, "triads.png")
# (--title '': no title; an empty argument crashed the pvpython it was passed on to, SIGSEGV)
image, drawn = render(png, "--time", "2.5", "--size", "500", "400", "--view", "+y", "--color", "none", "--triads", "--radius", "0.03", "--triad-length", "0.8", "--no-axes",
                      "--title", "")
pixel_size_check("triads.png", image, (500, 400))
check.less("triads.png: not blank (0.01 / fraction of drawn pixels)", 0.01 / max(drawn.mean(), 1e-12), 1.0)
r, g, b = image[:, :, 0], image[:, :, 1], image[:, :, 2]
for colour, count in (("red", (r > 0.4) & (g < 0.2) & (b < 0.2)), ("green", (g > 0.3) & (r < 0.2) & (b < 0.2)),
                      ("blue", (b > 0.4) & (r < 0.2) & (g < 0.2))):
    check.true(f"triads.png: {colour} arrows drawn (more than 50 {colour} pixels: {count.sum()})", bool(count.sum() > 50))

# The driven screw: joint axes (magenta), the rigid body (orange) and the ground (brown) show,
# whichever reader render-paraview picks for the sidecar.
for flavour in ("xdmf3", "xdmf2"):
    png = os.path.join(args.work_dir, f"driven_screw_{flavour}.png")
    command = [sys.executable, render_paraview, os.path.splitext(results["screw", flavour])[0] + ".xmf", "-o", png, "--xvfb", "--size", "640", "480",
               "--inertia", "--color", "none", "--zoom", "1.5"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr[-4000:])
        raise SystemExit(f"render-paraview failed ({result.returncode}): {' '.join(command)}")
    image = matplotlib.image.imread(png)[:, :, :3]
    pixel_size_check(os.path.basename(png), image, (640, 480))
    r, g, b = image[:, :, 0], image[:, :, 1], image[:, :, 2]
    for what, count in (("joint axes (magenta)", (r > 0.4) & (b > 0.4) & (g < 0.2)),
                        ("rigid body (orange)", (r > 0.6) & (g > 0.3) & (g < 0.6) & (b < 0.2)),
                        ("ground (brown)", (r > 0.15) & (r < 0.45) & (g > 0.1) & (g < 0.4) & (b < 0.3) & (r > b + 0.04))):
        check.true(f"{os.path.basename(png)}: {what} drawn (more than 30 pixels: {count.sum()})", bool(count.sum() > 30))

# The bushing mount: its force element (a bushing between two coincident nodes) shows as a cyan
# sphere, whichever reader render-paraview picks; --no-force-elements leaves it out.
for flavour, options in (("xdmf3", []), ("xdmf2", []), ("xdmf3", ["--no-force-elements"])):
    png = os.path.join(args.work_dir, f"bushing_mount_{flavour}{'_without' if options else ''}.png")
    command = [sys.executable, render_paraview, os.path.splitext(results["bushing", flavour])[0] + ".xmf", "-o", png, "--xvfb", "--size", "480", "360",
               "--color", "none", *options]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr[-4000:])
        raise SystemExit(f"render-paraview failed ({result.returncode}): {' '.join(command)}")
    image = matplotlib.image.imread(png)[:, :, :3]
    r, g, b = image[:, :, 0], image[:, :, 1], image[:, :, 2]
    cyan = int(((g > r + 0.2) & (b > r + 0.2) & (np.abs(g - b) < 0.25)).sum())
    if options:
        check.true(f"{os.path.basename(png)}: no force element (fewer than 30 cyan pixels: {cyan})", cyan < 30)
    else:
        check.true(f"{os.path.basename(png)}: force element (cyan) drawn (more than 100 pixels: {cyan})", cyan > 100)

# A movie of every 4th frame: the PNG series and an .mp4 by ffmpeg.
movie = os.path.join(args.work_dir, "driven_screw.mp4")
command = [sys.executable, render_paraview, os.path.splitext(screw)[0] + ".xmf", "--movie", movie, "--every", "4", "--xvfb", "--size", "320", "240"]
result = subprocess.run(command, capture_output=True, text=True, timeout=900)
if result.returncode != 0:
    sys.stderr.write(result.stdout + result.stderr[-4000:])
    raise SystemExit(f"render-paraview failed ({result.returncode}): {' '.join(command)}")
with h5py.File(screw, "r") as f:
    n_frames = mt.frame_count(f)
expected_pngs = len(range(0, n_frames, 4)) + (0 if (n_frames - 1) % 4 == 0 else 1)
pngs = sorted(p for p in os.listdir(os.path.join(args.work_dir, "driven_screw_frames")) if p.endswith(".png"))
mp4_bytes = os.path.getsize(movie) if os.path.isfile(movie) else 0
print(f"movie: {len(pngs)} PNGs of {n_frames} frames, {mp4_bytes} bytes of mp4")
check.equal("movie: PNGs", len(pngs), expected_pngs)
check.true(f"movie: an .mp4 file of more than 1000 bytes ({mp4_bytes})", mp4_bytes > 1000)

# A missing file fails at once, with one line naming the file given (not the sidecar beside a
# missing .h5, no raw [Errno 2]), before ParaView starts.
for missing in ("missing.xmf", "missing.ckpt.h5"):
    result = subprocess.run([sys.executable, render_paraview, os.path.join(args.work_dir, missing), "-o", png],
                            capture_output=True, text=True, timeout=60)
    print(f"{missing}: exit status {result.returncode}, stderr: {result.stderr.strip()}")
    check.equal(f"{missing}: exit status", result.returncode, 1)
    check.equal(f"{missing}: stderr lines", len(result.stderr.splitlines()), 1)
    check.true(f"{missing}: the message names the file given, and no errno",
               os.path.join(args.work_dir, missing) + "'" in result.stderr and "Errno" not in result.stderr
               and (missing.endswith(".xmf") or ".xmf" not in result.stderr))


def render_refused(what, command, status, message=None):
    """render-paraview `command` (its arguments) exits with `status` and the one line `message`
    (or any one line, or with status 2 any argparse usage error, when None)."""
    result = subprocess.run([sys.executable, render_paraview, *command], capture_output=True, text=True, timeout=300)
    print(f"{what}: exit status {result.returncode}, stderr: {result.stderr.strip().splitlines()[-1:] }")
    check.equal(f"{what}: exit status", result.returncode, status)
    if message is not None:
        check.true(f"{what}: the one line on stderr", result.stderr == f"render-paraview: error: {message}\n")
    else:
        lines = result.stderr.strip().splitlines()
        check.true(f"{what}: no traceback, an error line last", "Traceback" not in result.stderr
                   and bool(lines) and lines[-1].startswith("render-paraview: error: "))
    return result


# A sidecar that lists no frames (a run killed before its first flush), of either syntax: the same
# line (an xdmf2 sidecar without frames has no HDF data item at all).
for flavour in ("xdmf3", "xdmf2"):
    with open(os.path.splitext(results["spaghetti", flavour])[0] + ".xmf", encoding="utf-8") as f:
        text = f.read()
    start = text.index(">", text.index('<Information Name="frames"')) + 1
    empty = os.path.join(args.work_dir, f"no_frames_{flavour}.xmf")
    with open(empty, "w", encoding="utf-8") as f:
        f.write(text[:start] + "\n  " + text[text.rindex("</Information>"):])
    render_refused(f"{flavour} sidecar without frames", [empty, "-o", png], 1,
                   f"'{empty}' lists no frames: its run stopped before writing the first (or has not flushed it yet), so there is nothing to render")

# Arguments ParaView would ignore: an unknown colour map (ApplyPreset returns True for it in 5.11),
# a colour range whose MIN is not below MAX.
result = render_refused("--colormap Nope", [xmf, "-o", png, "--xvfb", "--colormap", "Nope"], 2)
check.true("--colormap Nope: one line naming the preset", len(result.stderr.splitlines()) == 1 and "no colour map preset 'Nope'" in result.stderr)
for low, high in (("1", "0"), ("0.5", "0.5")):
    render_refused(f"--range {low} {high}", [xmf, "-o", png, "--range", low, high], 2)
# An image name ParaView cannot write, refused before ParaView starts; a file that is no sidecar is a
# file problem (status 1, as the other tools).
render_refused("-o a.xyz", [xmf, "-o", os.path.join(args.work_dir, "a.xyz")], 2)
not_sidecar = os.path.join(args.work_dir, "not_a_sidecar.xmf")
with open(not_sidecar, "w", encoding="utf-8") as f:
    f.write("analysis: {type: static}\n")
render_refused("a YAML file as the result", [not_sidecar, "-o", png], 1, f"'{not_sidecar}' is not an msflex XDMF sidecar (no HDF data item found)")

# The default colour range is over the nodes the beams draw: input/rack_pinion.yaml's beams grid
# also holds the pinion's node (a rigid body's), which moves 0.8 m while the rack's nodes move
# 0.038 m at most; --nodes draws every node, and its range is over all.
rack = os.path.join(args.work_dir, "rack_pinion.h5")
mt.run_msflex(args, f"{args.source_dir}/input/rack_pinion.yaml", rack, extra=["-quiet", "-output_every", "40"])
RANGE_PROBE = """
import importlib.machinery, importlib.util, os, sys
loader = importlib.machinery.SourceFileLoader("render_paraview", sys.argv[1])
spec = importlib.util.spec_from_loader("render_paraview", loader)
rp = importlib.util.module_from_spec(spec)
loader.exec_module(rp)
from paraview import simple
xmf, _ = rp.result_files(sys.argv[2])
reader, parts = rp.open_result(simple, os.path.abspath(xmf))
times = [float(t) for t in reader.TimestepValues]
beams = parts["beams"]
beams.UpdatePipeline(times[-1])
colour = rp.colour_array(beams, "displacement")
for nodes in (False, True):
    print("range", int(nodes), *rp.scan(reader, beams, [times[-1]], colour, nodes)[1])
"""
probe = os.path.join(args.work_dir, "range_probe.py")
with open(probe, "w") as f:
    f.write(RANGE_PROBE)
result = subprocess.run([pvpython, probe, render_paraview, os.path.splitext(rack)[0] + ".xmf"], capture_output=True, text=True, timeout=300)
ranges = {int(line.split()[1]): [float(v) for v in line.split()[2:]] for line in result.stdout.splitlines() if line.startswith("range ")}
if len(ranges) != 2:
    sys.stderr.write(result.stdout + result.stderr[-4000:])
with h5py.File(rack, "r") as f:
    magnitude = np.linalg.norm(f["frames/displacement"][-1], axis=1)
    drawn = magnitude[np.unique(f["mesh/segments"][()])]
print(f"rack_pinion: default colour range {ranges.get(0)}, with --nodes {ranges.get(1)}; |displacement| of the beams' nodes "
      f"{drawn.min():.6g} .. {drawn.max():.6g}, of all nodes .. {magnitude.max():.6g}")
check.true("rack_pinion: the pinion's node moves further than the rack's (the check means something)", magnitude.max() > 2 * drawn.max())
check.less("rack_pinion: default colour range vs |displacement| over the beams' nodes, max difference",
           float(np.abs(np.subtract(ranges.get(0, [np.inf] * 2), [drawn.min(), drawn.max()])).max()), 1e-12)
check.less("rack_pinion: --nodes colour range vs |displacement| over all nodes, max difference",
           float(np.abs(np.subtract(ranges.get(1, [np.inf] * 2), [magnitude.min(), magnitude.max()])).max()), 1e-12)

# A result file that a running msflex holds open for writing (with HDF5 file locking, as msflex's
# HDF5 has it by default): render-paraview and ParaView read it all the same (it sets
# HDF5_USE_FILE_LOCKING=FALSE), not "unable to lock file".
environment = {k: v for k, v in os.environ.items() if k != "HDF5_USE_FILE_LOCKING"}
holder = subprocess.Popen([sys.executable, "-c", "import sys, h5py\nf = h5py.File(sys.argv[1], 'a', locking=True)\n"
                           "print('open', flush=True)\nsys.stdin.read()\n", rack],
                          stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=environment)
try:
    check.true("locked file: the holder has it open", holder.stdout.readline().strip() == "open")
    # Given the .h5, render-paraview reads it with h5py first; given the .xmf, ParaView alone (5.11
    # aborted, SIGABRT, with locking on).
    for given in (rack, os.path.splitext(rack)[0] + ".xmf"):
        name = os.path.basename(given)
        locked_png = os.path.join(args.work_dir, f"locked_{name}.png")
        if os.path.exists(locked_png):
            os.remove(locked_png)
        result = subprocess.run([sys.executable, render_paraview, given, "-o", locked_png, "--xvfb", "--size", "320", "240"],
                                capture_output=True, text=True, timeout=300, env=environment)
        print(f"locked file, {name}: exit status {result.returncode}, stderr: {result.stderr.strip()[-300:]}")
        check.equal(f"locked file, {name}: render-paraview exit status", result.returncode, 0)
        check.true(f"locked file, {name}: no lock error", "lock" not in result.stderr)
        check.true(f"locked file, {name}: the image is written", os.path.isfile(locked_png))
finally:
    holder.communicate("")
check.finish()
