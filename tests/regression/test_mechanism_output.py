"""The rigid bodies, joints and ground in the result file agree with the nodes and the model.

Runs input/driven_screw.yaml (a rigid body, four joints, two of them to the ground) to t = 0.3,
input/turning_arm_screw.yaml (a screw joint, a clamped base) to t = 0.2 and
tests/regression/inputs/joint_mechanism.yaml to t = 0.2 (a rigid body with a full inertia tensor
and an offset centre of mass, a driven revolute, universal, screw and prismatic joints), on --np
ranks, and checks:
 - the ground markers: the joints to the ground at their slave's reference position with the
   joint's axes (driven screw: hinge at A, pivot at R, a1 = z), the fully fixed node with the global
   axes (turning arm: base);
 - the rigid body's mesh data: mass, inertia, principal moments (0.225, 0.225, 0.45) and the
   semi-axes of the uniform solid ellipsoid of the same mass and inertia, a_k^2 = 5 (I_i + I_j - I_k) / (2 m);
 - every frame: each joint marker at its slave node's position (difference 0) with the axes
   R_master a_k (the reference axes for a joint to the ground) to 1e-12; the body's rotation equal
   to its node's (difference 0), its centre of mass x + R c and its axes R a_k e_k (the principal
   axes scaled by the semi-axes) to 1e-12;
 - the force elements of input/bushing_mount.yaml (to t = 0.04: a bushing between the beam's tip
   and the box) and input/slider_crank.yaml (to t = 0.04: two coordinate elements, one on a
   revolute joint to the ground, one on a joint between two nodes): /mesh/force_element_names,
   _kinds, _kind_codes (0 coordinate, 1 spring_damper, 2 bushing) and _vertices (the two nodes; a
   coordinate element's joint master and slave, the slave twice for a joint to the ground), and in
   the sidecar a temporal collection `force_elements` with a grid per frame whose points are the
   frame's /frames/position, whose cells are the 2-node polylines of /mesh/force_element_vertices
   and whose cell array `kind` is /mesh/force_element_kind_codes; the models without force elements
   have neither the datasets nor the grid;
 - provenance and units in each file, and in that of tests/regression/inputs/joint_mechanism.yaml
   run as an eigenanalysis (-analysis_type modes): the root attributes msflex_version, git_hash,
   command_line (naming the input), options, ranks (= --np) and start_time; a `unit` and a
   `description` attribute on every dataset, and every /history series known to the table of units
   (no "a series of unknown meaning")."""

import os
import re

import h5py
import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("mechanism output")


def strings(dataset):
    return [s.decode() if isinstance(s, bytes) else s for s in dataset[()]]


def run(name, end_time, directory="input"):
    output = f"{args.work_dir}/{name}.h5"
    mt.run_msflex(args, f"{args.source_dir}/{directory}/{name}.yaml", output, extra=["-analysis_end_time", str(end_time), "-quiet"])
    return output


def check_units_and_provenance(label, path, input_name):
    with h5py.File(path, "r") as f:
        root = {key: f.attrs[key] for key in f.attrs}
        text = {key: (value.decode() if isinstance(value, bytes) else str(value)) for key, value in root.items()}
        missing = [key for key in ("msflex_version", "git_hash", "command_line", "options", "ranks", "start_time") if not text.get(key)]
        check.equal(f"{label}: provenance attributes missing ({missing})", len(missing), 0)
        check.true(f"{label}: command_line names the input", input_name in text.get("command_line", ""))
        check.equal(f"{label}: ranks attribute = np", root.get("ranks", -1), args.np)
        datasets = []
        f.visititems(lambda name, item: datasets.append(name) if isinstance(item, h5py.Dataset) else None)
        bare = [name for name in datasets if "unit" not in f[name].attrs or "description" not in f[name].attrs]
        check.equal(f"{label}: datasets without unit or description, of {len(datasets)} ({bare[:5]})", len(bare), 0)
        names, descriptions = f["history/names"][()], f["history/descriptions"][()]
        unknown = [name.decode() for name, description in zip(names, descriptions) if b"unknown" in description]
        check.equal(f"{label}: history series of unknown unit ({unknown[:5]})", len(unknown), 0)


FORCE_ELEMENT_DATASETS = ("force_element_names", "force_element_kinds", "force_element_kind_codes", "force_element_vertices")


def check_force_elements(label, path, expected):
    """`expected`: (name, kind, code, (node name, node name)) per force element, in order; none: the
    file and its sidecar have no force elements."""
    with h5py.File(path, "r") as f:
        mesh = f["mesh"]
        frame_count, n_nodes = mt.frame_count(f), len(mesh["node_names"])
        if not expected:
            present = [name for name in FORCE_ELEMENT_DATASETS if name in mesh]
            check.equal(f"{label}: no force-element datasets ({present})", len(present), 0)
        else:
            nodes = strings(mesh["node_names"])
            check.true(f"{label}: force-element names", strings(mesh["force_element_names"]) == [e[0] for e in expected])
            check.true(f"{label}: force-element kinds", strings(mesh["force_element_kinds"]) == [e[1] for e in expected])
            check.true(f"{label}: force-element kind codes", mesh["force_element_kind_codes"][()].tolist() == [e[2] for e in expected])
            vertices = mesh["force_element_vertices"][()]
            check.true(f"{label}: force-element segments' nodes {vertices.tolist()}",
                       vertices.shape == (len(expected), 2) and [[nodes[i] for i in row] for row in vertices] == [list(e[3]) for e in expected])
    with open(os.path.splitext(path)[0] + ".xmf", encoding="utf-8") as f:
        xmf = f.read()
    if not expected:
        check.equal(f"{label}: no force_elements grid in the sidecar", xmf.count("force_element"), 0)
        return
    h5 = os.path.basename(path)
    check.equal(f"{label}: a force_elements collection", xmf.count('<Grid Name="force_elements" GridType="Collection" CollectionType="Temporal">'), 1)
    grids = re.findall(r'<Grid Name="force_elements" GridType="Uniform">(.*?)</Grid>', xmf, re.S)
    check.equal(f"{label}: a force_elements grid per frame", len(grids), frame_count)
    wrong = [k for k, grid in enumerate(grids) if f">{h5}:/frames/position|{k} 0 0:1 1 1:1 {n_nodes} 3:{k + 1} {n_nodes} 3<" not in grid]
    check.equal(f"{label}: frames whose force_elements points are not that frame's positions ({wrong[:5]})", len(wrong), 0)
    shared = re.search(r'<Information Name="shared".*?<Grid Name="force_elements">(.*?)</Grid>', xmf, re.S)
    shared = shared.group(1) if shared else ""
    check.true(f"{label}: force_elements topology: a 2-node polyline per element from /mesh/force_element_vertices",
               f'<Topology TopologyType="Polyline" NodesPerElement="2" NumberOfElements="{len(expected)}">' in shared
               and f">{h5}:/mesh/force_element_vertices<" in shared)
    check.true(f"{label}: force_elements cell array kind from /mesh/force_element_kind_codes",
               '<Attribute Name="kind" AttributeType="Scalar" Center="Cell">' in shared and f">{h5}:/mesh/force_element_kind_codes<" in shared)


def check_frames(label, path):
    with h5py.File(path, "r") as f:
        mesh = f["mesh"]
        slaves, masters = mesh["joint_slave"][()], mesh["joint_master"][()]
        axes = mesh["joint_axes"][()].reshape(-1, 3, 3)  # [joint, k, component]: a_k
        worst = {"joint position": 0.0, "joint axes": 0.0, "body rotation": 0.0, "body centre": 0.0, "body axes": 0.0}
        frames = mt.frames(f)
        has_bodies = "body_names" in mesh
        missing = [frame["step"] for frame in frames if "joint_position" not in frame or (has_bodies and "body_center" not in frame)]
        check.equal(f"{label}: frames without the joints{' or bodies' if has_bodies else ''} ({missing[:5]})", len(missing), 0)
        for frame in frames:
            if frame["step"] in missing:
                continue
            position, rotation = frame["position"], frame["rotation"]
            worst["joint position"] = max(worst["joint position"], np.abs(frame["joint_position"] - position[slaves]).max())
            for k in range(3):
                expected = np.array([axes[j, k] if m < 0 else mt.quaternion_matrix(rotation[m]) @ axes[j, k] for j, m in enumerate(masters)])
                worst["joint axes"] = max(worst["joint axes"], np.abs(frame[f"joint_a{k + 1}"] - expected).max())
            if not has_bodies:
                continue
            nodes = mesh["body_node"][()]
            worst["body rotation"] = max(worst["body rotation"], np.abs(frame["body_rotation"] - rotation[nodes]).max())
            for b, node in enumerate(nodes):
                R = mt.quaternion_matrix(rotation[node])
                centre = position[node] + R @ mesh["body_offset"][b]
                worst["body centre"] = max(worst["body centre"], np.abs(frame["body_center"][b] - centre).max())
                principal = mesh["body_principal_axes"][b].reshape(3, 3)
                for k in range(3):
                    expected = mesh["body_semi_axes"][b, k] * (R @ principal[k])
                    worst["body axes"] = max(worst["body axes"], np.abs(frame[f"body_axis_{k + 1}"][b] - expected).max())
    limits = {"joint position": 1e-300, "joint axes": 1e-12, "body rotation": 1e-300, "body centre": 1e-12, "body axes": 1e-12}
    for what, value in worst.items():
        if what.startswith("body") and label == "turning_arm":
            continue  # no rigid bodies
        check.less(f"{label}: {what}, max difference over {len(frames)} frames", value, limits[what])


screw = run("driven_screw", 0.3)
with h5py.File(screw, "r") as f:
    mesh = f["mesh"]
    check.true("driven screw: ground markers hinge and pivot, joints",
               strings(mesh["ground_names"]) == ["hinge", "pivot"] and strings(mesh["ground_kinds"]) == ["joint", "joint"])
    check.less("driven screw: ground at A and R", np.abs(mesh["ground_position"][()] - [[1.2, -1.2, 0], [0, 0, 0]]).max(), 1e-15)
    check.less("driven screw: ground axis a1 = z", np.abs(mesh["ground_a1"][()] - [[0, 0, 1], [0, 0, 1]]).max(), 1e-15)
    check.true("driven screw: one body, T", strings(mesh["body_names"]) == ["T"])
    check.less("driven screw: the body's mass, 40 kg (|mass - 40|)", abs(float(mesh["body_mass"][0]) - 40.0), 1e-15)
    moments = mesh["body_principal_moments"][0]
    check.less("driven screw: principal moments (0.225, 0.225, 0.45)", np.abs(moments - [0.225, 0.225, 0.45]).max(), 1e-14)
    total = moments.sum()
    semi = np.sqrt(np.maximum(0.0, 2.5 * (total - 2 * moments) / 40.0))
    check.less("driven screw: semi-axes sqrt(5 (I_i + I_j - I_k) / (2 m))", np.abs(mesh["body_semi_axes"][0] - semi).max(), 1e-15)
    principal = mesh["body_principal_axes"][0].reshape(3, 3)
    check.less("driven screw: principal axes orthonormal, right-handed", np.abs(principal @ principal.T - np.eye(3)).max()
               + abs(np.linalg.det(principal) - 1.0), 1e-14)
    check.less("driven screw: the axis of the largest moment is x", np.abs(np.abs(principal[2]) - [1, 0, 0]).max(), 1e-14)
check_frames("driven_screw", screw)
check_force_elements("driven_screw", screw, [])
check_units_and_provenance("driven_screw", screw, "driven_screw.yaml")

arm = run("turning_arm_screw", 0.2)
with h5py.File(arm, "r") as f:
    mesh = f["mesh"]
    check.true("turning arm: one ground marker, the clamped base",
               strings(mesh["ground_names"]) == ["base"] and strings(mesh["ground_kinds"]) == ["support"])
    check.less("turning arm: ground at the base with the global axes",
               np.abs(mesh["ground_position"][0]).max() + sum(np.abs(mesh[f"ground_a{k + 1}"][0] - np.eye(3)[k]).max() for k in range(3)), 1e-15)
    check.true("turning arm: no rigid bodies", "body_names" not in mesh)
check_frames("turning_arm", arm)

# Pinned nodes (translations fixed, a rotation free) are ground markers too: the deep arch's hinge
# (rz free: a1 = z) beside its clamp.
arch = run("deep_arch", 0.05)
with h5py.File(arch, "r") as f:
    mesh = f["mesh"]
    check.true("deep arch: ground markers, the clamp and the hinge",
               strings(mesh["ground_names"]) == ["clamped", "hinged"] and strings(mesh["ground_kinds"]) == ["support", "pin"])
    check.less("deep arch: the hinge's a1, a2, a3 = z, x, y",
               sum(np.abs(mesh[f"ground_a{k + 1}"][1] - np.eye(3)[(2 + k) % 3]).max() for k in range(3)), 1e-15)
    check.less("deep arch: the hinge at its node", np.abs(mesh["ground_position"][1] - [95.37169507482269, -30.070579950427295, 0]).max(), 1e-12)
check_units_and_provenance("turning_arm", arm, "turning_arm_screw.yaml")

mechanism = run("joint_mechanism", 0.2, "tests/regression/inputs")
with h5py.File(mechanism, "r") as f:
    mesh = f["mesh"]
    inertia = mesh["body_inertia"][0].reshape(3, 3)
    principal, moments, semi = mesh["body_principal_axes"][0].reshape(3, 3), mesh["body_principal_moments"][0], mesh["body_semi_axes"][0]
    check.less("joint mechanism: inertia = sum I_k v_k v_k^T over the principal axes",
               np.abs(sum(moments[k] * np.outer(principal[k], principal[k]) for k in range(3)) - inertia).max(), 1e-14)
    check.less("joint mechanism: the offset of the centre of mass (0.2, -0.1, 0.15)", np.abs(mesh["body_offset"][0] - [0.2, -0.1, 0.15]).max(), 1e-15)
    # The ellipsoid: I_k = m (a_i^2 + a_j^2) / 5.
    a2 = semi**2
    mass = float(mesh["body_mass"][0])
    check.less("joint mechanism: I_k = m (a_i^2 + a_j^2) / 5", np.abs([mass * (a2.sum() - a2[k]) / 5 - moments[k] for k in range(3)]).max(), 1e-14)
check_frames("joint_mechanism", mechanism)
check_units_and_provenance("joint_mechanism", mechanism, "joint_mechanism.yaml")
check_force_elements("joint_mechanism", mechanism, [])

bushing = run("bushing_mount", 0.04)
check_force_elements("bushing_mount", bushing, [("mount", "bushing", 2, ("tip", "box"))])
check_units_and_provenance("bushing_mount", bushing, "bushing_mount.yaml")
crank = run("slider_crank", 0.04)
check_force_elements("slider_crank", crank, [("motor", "coordinate", 0, ("rotor", "rotor")), ("torsional_damper", "coordinate", 0, ("rotor", "hub"))])
check_units_and_provenance("slider_crank", crank, "slider_crank.yaml")

modes = f"{args.work_dir}/joint_mechanism_modes.h5"
mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/joint_mechanism.yaml", modes, extra=["-analysis_type", "modes", "-quiet"])
check_units_and_provenance("joint_mechanism modes", modes, "joint_mechanism.yaml")
check.finish()
