#include "output/output_units.hpp"

namespace msflex {

namespace {

struct Entry {
  const char *group, *name, *unit, *description;
};

// Every dataset of the root (group ""), /mesh, /frames and /history, as in a dynamic analysis (kByAnalysis
// below has what differs in the others). "TIME" in a unit stands for the unit of time: s in dynamics, 1
// (the pseudo-time, the load factor under load control) in statics.
const Entry kDatasets[] = {
    {"", "input", "", "the input file's text (YAML), verbatim"},
    {"mesh", "node_coordinates", "m", "reference position (x, y, z) of each node"},
    {"mesh", "node_names", "", "node name; nodes generated inside a beam line are <beam>.<k>"},
    {"mesh", "element_nodes", "1", "node indices of each element (end, middle, end for 3 nodes; 2-node elements padded with -1)"},
    {"mesh", "element_order", "1", "element order: 1 (2 nodes) or 2 (3 nodes)"},
    {"mesh", "element_beam", "1", "index into beam_names of the element's beam"},
    {"mesh", "beam_names", "", "beam names from the input"},
    {"mesh", "segments", "1", "node indices of the 2-node polyline segments drawn for the elements"},
    {"mesh", "segment_element", "1", "element each segment belongs to"},
    {"mesh", "node_rank", "1", "MPI rank that owned each node (the partition of the run that created the file; a restart on other ranks keeps it)"},
    {"mesh", "joint_names", "", "joint names from the input"},
    {"mesh", "joint_types", "", "joint types from the input (revolute, screw, ...)"},
    {"mesh", "joint_master", "1", "master node index of each joint; -1 is the ground"},
    {"mesh", "joint_slave", "1", "slave node index of each joint"},
    {"mesh", "joint_axes", "1", "joint axes a1, a2, a3 (3 components each) in global axes at the reference configuration"},
    {"mesh", "joint_offset", "m", "slave minus master reference position (0 for a joint to the ground)"},
    {"mesh", "joint_vertices", "1", "point index of each joint marker (the vertex cells of the XDMF joints grid)"},
    {"mesh", "body_names", "", "rigid body name: its name in the input, or its node's name when it has none"},
    {"mesh", "body_node", "1", "node index each rigid body is attached to"},
    {"mesh", "body_mass", "kg", "mass of each rigid body"},
    {"mesh", "body_inertia", "kg m^2", "inertia tensor about the centre of mass in global axes at the reference configuration (row-major, 9)"},
    {"mesh", "body_offset", "m", "centre of mass minus node position at the reference configuration"},
    {"mesh", "body_principal_moments", "kg m^2", "principal moments of inertia about the centre of mass, ascending"},
    {"mesh", "body_principal_axes", "1", "principal axes (3 unit vectors, one after the other) at the reference configuration, right-handed"},
    {"mesh", "body_semi_axes", "m", "semi-axes along the principal axes of the uniform solid ellipsoid of the same mass and inertia"},
    {"mesh", "body_vertices", "1", "point index of each rigid body (the vertex cells of the XDMF bodies grid)"},
    {"mesh", "ground_names", "", "what each ground marker stands for: a joint name (joint to the ground) or a node name (fixed support or pin)"},
    {"mesh", "ground_kinds", "", "kind of each ground marker: joint, support (six DOFs fixed) or pin (translations fixed, a rotation free or prescribed)"},
    {"mesh", "ground_position", "m", "position of each ground marker (fixed)"},
    {"mesh", "ground_a1", "1", "first axis of each ground marker: the joint's a1, or x for a support"},
    {"mesh", "ground_a2", "1", "second axis of each ground marker: the joint's a2, or y for a support"},
    {"mesh", "ground_a3", "1", "third axis of each ground marker: the joint's a3, or z for a support"},
    {"mesh", "ground_vertices", "1", "point index of each ground marker (the vertex cells of the XDMF ground grid)"},
    {"mesh", "force_element_names", "", "force element names from the input"},
    {"mesh", "force_element_kinds", "", "kind of each force element: coordinate, spring_damper or bushing"},
    {"mesh", "force_element_kind_codes", "1",
     "kind of each force element as a code: 0 coordinate, 1 spring_damper, 2 bushing (the XDMF force_elements grid's kind)"},
    {"mesh", "force_element_vertices", "1",
     "node indices of the segment drawn for each force element: its two nodes, a coordinate element's joint master and slave (the slave twice for a joint to "
     "the ground)"},
    {"frames", "step", "1", "step number of each frame (0: the initial state)"},
    {"frames", "time", "TIME", "time of each frame"},
    {"frames", "contents", "1", "what each frame holds besides nodes and elements, bits: 1 velocities, 2 section triads, 4 rigid bodies, 8 joints"},
    {"frames", "position", "m", "current position of each node"},
    {"frames", "displacement", "m", "current minus reference position of each node"},
    {"frames", "rotation", "1", "rotation of each node from the reference configuration, unit quaternion (w, x, y, z)"},
    {"frames", "element_resultants", "N, N, N, N m, N m, N m",
     "section forces N1 N2 N3 and moments M1 M2 M3 in the section frame (1 = beam axis), mean over the element's Gauss points"},
    {"frames", "element_strains", "1, 1, 1, 1/m, 1/m, 1/m", "strains Gamma - Gamma0 and curvatures K - K0 in the section frame, mean over the Gauss points"},
    {"frames", "segment_force", "N", "section force N1 N2 N3 of the segment's element, section frame"},
    {"frames", "segment_moment", "N m", "section moment M1 M2 M3 of the segment's element, section frame"},
    {"frames", "segment_e1", "1", "current section axis e1 (the beam axis) at the segment's first node"},
    {"frames", "segment_e2", "1", "current section axis e2 at the segment's first node"},
    {"frames", "segment_e3", "1", "current section axis e3 at the segment's first node"},
    {"frames", "velocity", "m/s", "velocity of each node"},
    {"frames", "angular_velocity", "rad/s", "angular velocity of each node in global axes"},
    {"frames", "body_center", "m", "current position of each rigid body's centre of mass"},
    {"frames", "body_axis_1", "m", "first principal axis of each rigid body, current orientation, length the semi-axis body_semi_axes[0]"},
    {"frames", "body_axis_2", "m", "second principal axis of each rigid body, current orientation, length the semi-axis body_semi_axes[1]"},
    {"frames", "body_axis_3", "m", "third principal axis of each rigid body, current orientation, length the semi-axis body_semi_axes[2]"},
    {"frames", "body_rotation", "1", "rotation of each rigid body (of its node) from the reference configuration, unit quaternion (w, x, y, z)"},
    {"frames", "joint_position", "m", "current position of each joint marker: its slave node"},
    {"frames", "joint_a1", "1", "joint axis a1 in its current orientation: master rotation times reference axis"},
    {"frames", "joint_a2", "1", "joint axis a2 in its current orientation: master rotation times reference axis"},
    {"frames", "joint_a3", "1", "joint axis a3 in its current orientation: master rotation times reference axis"},
    {"history", "values", "mixed", "the history: one row per converged step (row 0: the initial state), one column per series, named in /history/names"},
    {"history", "names", "", "name of each column of /history/values"},
    {"history", "units", "", "unit of each column of /history/values"},
    {"history", "descriptions", "", "what each column of /history/values holds"},
};

// The columns of a probe's sample, in the order of ProbeSample: quantity, component, unit, description.
const struct {
  const char *quantity, *component, *unit, *description;
} kProbeSeries[kProbeColumns] = {
    {"position", "x", "m", "current position of the probed point (node, its offset point or a rigid body's centre of mass)"},
    {"position", "y", "m", "current position of the probed point (node, its offset point or a rigid body's centre of mass)"},
    {"position", "z", "m", "current position of the probed point (node, its offset point or a rigid body's centre of mass)"},
    {"displacement", "x", "m", "displacement of the probed point (node, its offset point or a rigid body's centre of mass)"},
    {"displacement", "y", "m", "displacement of the probed point (node, its offset point or a rigid body's centre of mass)"},
    {"displacement", "z", "m", "displacement of the probed point (node, its offset point or a rigid body's centre of mass)"},
    {"rotation", "w", "1", "rotation of the probed node, unit quaternion (w, x, y, z)"},
    {"rotation", "x", "1", "rotation of the probed node, unit quaternion (w, x, y, z)"},
    {"rotation", "y", "1", "rotation of the probed node, unit quaternion (w, x, y, z)"},
    {"rotation", "z", "1", "rotation of the probed node, unit quaternion (w, x, y, z)"},
    {"rotation_angle", "", "rad", "angle of the probed node's rotation, 2 atan2(|q_v|, q_w) of its tracked quaternion, in [0, 2 pi]: not unwrapped"},
};

// The fixed history series. "TIME" as above.
const Entry kHistory[] = {
    {"", "time", "TIME", "time"},
    {"", "step", "1", "converged step number"},
    {"", "step_size", "TIME", "the step that reached this row (0 in the first row)"},
    {"", "newton_iterations", "1", "Newton iterations of the step"},
    {"", "residual_norm", "mixed", "2-norm of the final residual of the step: forces (N) and moments (N m) together"},
    {"", "strain_energy", "J", "strain energy of the beams"},
    {"", "spring_energy", "J", "energy stored in the force elements: their springs and bushings"},
    {"", "kinetic_energy", "J", "kinetic energy of the beams and rigid bodies"},
    {"", "total_energy", "J", "kinetic_energy + strain_energy + spring_energy"},
    {"", "external_work", "J", "work done on the model since t = 0 by the loads, actuators, prescribed supports and drives"},
    {"", "dissipated_energy", "J", "energy dissipated since t = 0 by the force elements' dampers and the beams' structural damping"},
    {"", "energy_balance", "J", "total_energy - external_work + dissipated_energy: constant when the time scheme conserves energy (em)"},
    {"", "linear_momentum_x", "kg m/s", "total linear momentum, x"},
    {"", "linear_momentum_y", "kg m/s", "total linear momentum, y"},
    {"", "linear_momentum_z", "kg m/s", "total linear momentum, z"},
    {"", "angular_momentum_x", "kg m^2/s", "total angular momentum about the origin, x"},
    {"", "angular_momentum_y", "kg m^2/s", "total angular momentum about the origin, y"},
    {"", "angular_momentum_z", "kg m^2/s", "total angular momentum about the origin, z"},
    {"", "energy_correction", "1", "the energy-momentum scheme's correction factor beta of the step (0 for the other schemes)"},
    {"", "algorithmic_dissipation", "J",
     "external_work - dissipated_energy - (total_energy - total_energy at t = 0): the energy the time scheme itself dissipates (< 0: creates)"},
    {"", "load_factor", "1",
     "load factor at which the loads are evaluated (the pseudo-time under load control; solved for under arc-length or displacement control)"},
    {"", "negative_pivots", "1", "negative pivots of the tangent at the equilibrium (-1: the tangent is not symmetric)"},
    {"", "determinant_sign", "1", "sign of the tangent's determinant (0: it could not be factored)"},
    {"", "lowest_eigenvalue", "1", "eigenvalue of smallest magnitude of K phi = mu D phi, D = |diag K0|"},
    {"", "stiffness_parameter", "1", "current stiffness parameter c0 / c: 1 at the start, 0 at a limit point"},
    {"", "critical_point", "1", "critical point passed in the step: 1 limit, 2 bifurcation, 3 branch jump, 0 none"},
    {"", "critical_load_factor", "1", "located load factor of that critical point (NaN: none)"},
    {"", "mode", "1", "mode number of an eigenanalysis"},
    {"", "eigenvalue", "mixed", "eigenvalue: omega^2 in (rad/s)^2 (modes), the load-factor increment (buckling)"},
    {"", "backward_error", "1", "relative backward error of the eigenpair"},
    {"", "angular_frequency", "rad/s", "angular frequency of the mode (0 for a rigid or unstable mode)"},
    {"", "frequency", "Hz", "frequency of the mode"},
    {"", "rigid_mode", "1", "1: a rigid mode (eigenvalue at round-off), else 0"},
};

// What differs with the kind of analysis: what time is, and the eigenanalyses' series. Looked up
// before kDatasets and kHistory (the latter's entries are those of a dynamic analysis).
const struct {
  AnalysisType analysis;
  Entry        entry;
} kByAnalysis[] = {
    {AnalysisType::Static,
     {"", "time", "1", "pseudo-time of the static analysis: the load factor under load control with the default ramp (load_factor under any control)"}},
    {AnalysisType::Modes, {"", "time", "1", "mode number: one row per mode (the same as step and mode)"}},
    {AnalysisType::Buckling, {"", "time", "1", "mode number: one row per buckling mode (the same as step and mode)"}},
    {AnalysisType::Modes, {"", "step", "1", "mode number (the same as time and mode)"}},
    {AnalysisType::Buckling, {"", "step", "1", "mode number (the same as time and mode)"}},
    {AnalysisType::Modes, {"", "eigenvalue", "(rad/s)^2", "eigenvalue omega^2 of the mode (K phi = omega^2 M phi)"}},
    {AnalysisType::Buckling, {"", "eigenvalue", "1", "eigenvalue mu of the mode: the load-factor increment from the equilibrium to buckling"}},
    {AnalysisType::Buckling, {"", "load_factor", "1", "buckling load factor of the mode: the equilibrium's load factor plus the eigenvalue"}},
    {AnalysisType::Static, {"frames", "time", "1", "pseudo-time of each frame: the load factor under load control with the default ramp"}},
    {AnalysisType::Modes, {"frames", "time", "1", "mode number of each frame: 0 the equilibrium, k the k-th mode added to it"}},
    {AnalysisType::Buckling, {"frames", "time", "1", "mode number of each frame: 0 the equilibrium, k the k-th buckling mode added to it"}},
    {AnalysisType::Modes, {"frames", "step", "1", "mode number of each frame (0: the equilibrium)"}},
    {AnalysisType::Buckling, {"frames", "step", "1", "mode number of each frame (0: the equilibrium)"}},
};

// The series "<name>.<suffix>" of joints, force elements and probes of kind reaction or beam, by
// suffix; `kind` names what writes them. "TIME" as above; rates are per unit of time. A suffix
// that more than one kind writes has one unit for all of them and a description that names each
// kind's meaning: the name alone does not tell the kind.
const struct {
  const char *kind, *suffix, *unit, *description;
} kNamedSeries[] = {
    // Joints: released coordinates (a dependent translation under its axis), their rates.
    {"joint", "tx", "m", "translation along the joint axis a1, slave relative to master: a released coordinate, or a screw's dependent translation"},
    {"joint", "ty", "m",
     "translation along the joint axis a2, slave relative to master: a released coordinate, or a rack-and-pinion's or cam's dependent translation"},
    {"joint", "tz", "m", "translation along the joint axis a3, slave relative to master: a released coordinate"},
    {"joint", "rx", "rad", "rotation about the joint axis a1, a released angle (spherical and free joints: the rotation vector's component in joint axes)"},
    {"joint", "ry", "rad", "rotation about the joint axis a2, a released angle (spherical and free joints: the rotation vector's component in joint axes)"},
    {"joint", "rz", "rad", "rotation about the joint axis a3, a released angle (spherical and free joints: the rotation vector's component in joint axes)"},
    {"joint", "tx_rate", "m/TIME", "mean rate over the step of the translation along a1"},
    {"joint", "ty_rate", "m/TIME", "mean rate over the step of the translation along a2"},
    {"joint", "tz_rate", "m/TIME", "mean rate over the step of the translation along a3"},
    {"joint", "rx_rate", "rad/TIME", "mean rate over the step of the rotation about a1"},
    {"joint", "ry_rate", "rad/TIME", "mean rate over the step of the rotation about a2"},
    {"joint", "rz_rate", "rad/TIME", "mean rate over the step of the rotation about a3"},
    // Joints, bushings and reaction probes (which may not share a name).
    {"joint, bushing or reaction probe", "force_x", "N",
     "force along global x (a joint: on its slave; a bushing: on its second node; a reaction probe: the supports' reaction at its node)"},
    {"joint, bushing or reaction probe", "force_y", "N",
     "force along global y (a joint: on its slave; a bushing: on its second node; a reaction probe: the supports' reaction at its node)"},
    {"joint, bushing or reaction probe", "force_z", "N",
     "force along global z (a joint: on its slave; a bushing: on its second node; a reaction probe: the supports' reaction at its node)"},
    {"joint, bushing or reaction probe", "moment_x", "N m",
     "moment about global x, about the node it acts on (a joint: on its slave; a bushing: on its second node; a reaction probe: the supports' reaction at its "
     "node)"},
    {"joint, bushing or reaction probe", "moment_y", "N m",
     "moment about global y, about the node it acts on (a joint: on its slave; a bushing: on its second node; a reaction probe: the supports' reaction at its "
     "node)"},
    {"joint, bushing or reaction probe", "moment_z", "N m",
     "moment about global z, about the node it acts on (a joint: on its slave; a bushing: on its second node; a reaction probe: the supports' reaction at its "
     "node)"},
    // Driven joints.
    {"driven joint", "drive_force", "N or N m",
     "generalised force its drive exerts on the driven coordinate: N on a translation, N m on a rotation (a screw driven by its angle: the motor's "
     "torque; by its translation: the force along it), positive when it pushes the coordinate forward; its work is in external_work"},
    // Force elements.
    {"coordinate force element", "force", "N or N m",
     "generalised force of its spring, damper and actuator on its joint coordinate: N on a translation (tx, ty, tz), N m on a rotation (rx, ry, rz)"},
    {"force element", "power", "W", "power it delivers to the model: its work over the step divided by the step (0 in the first row)"},
    {"spring-damper", "length", "m", "current distance between its two nodes"},
    {"spring-damper", "tension", "N", "tension: spring plus damper force along the line of its nodes (positive: it pulls them together)"},
    // Beam probes: the section forces of an element, section frame (1 = beam axis), mean over its Gauss points.
    {"beam probe", "N1", "N", "axial force N1 of the element, section frame, mean over its Gauss points"},
    {"beam probe", "N2", "N", "shear force N2 of the element, section frame, mean over its Gauss points"},
    {"beam probe", "N3", "N", "shear force N3 of the element, section frame, mean over its Gauss points"},
    {"beam probe", "M1", "N m", "torsional moment M1 of the element, section frame, mean over its Gauss points"},
    {"beam probe", "M2", "N m", "bending moment M2 of the element, section frame, mean over its Gauss points"},
    {"beam probe", "M3", "N m", "bending moment M3 of the element, section frame, mean over its Gauss points"},
};

// Replaces TIME by the unit of time: "TIME" -> s | 1, "m/TIME" -> m/s | m.
std::string TimeUnit(const char *unit, bool dynamic)
{
  const std::string text = unit;
  const size_t      at   = text.find("TIME");
  if (at == std::string::npos) return text;
  if (dynamic) return text.substr(0, at) + "s";
  return at == 0 ? "1" : text.substr(0, at - 1); // "m/TIME" -> "m": per unit load factor
}

Quantity Found(const char *unit, const char *description, AnalysisType analysis) { return {TimeUnit(unit, analysis == AnalysisType::Dynamic), description}; }
Quantity Found(const Entry &entry, AnalysisType analysis) { return Found(entry.unit, entry.description, analysis); }

// The entry of `name` in `group` that depends on the analysis, or null.
const Entry *ByAnalysis(const char *group, const std::string &name, AnalysisType analysis)
{
  for (const auto &special : kByAnalysis)
    if (special.analysis == analysis && name == special.entry.name && std::string(group) == special.entry.group) return &special.entry;
  return nullptr;
}

} // namespace

Quantity DatasetQuantity(const std::string &group, const std::string &name, AnalysisType analysis)
{
  if (const Entry *special = ByAnalysis(group.c_str(), name, analysis)) return Found(*special, analysis);
  for (const Entry &entry : kDatasets)
    if (group == entry.group && name == entry.name) return Found(entry, analysis);
  return {};
}

Quantity HistoryQuantity(const std::string &name, AnalysisType analysis)
{
  if (const Entry *special = ByAnalysis("", name, analysis)) return Found(*special, analysis);
  for (const Entry &entry : kHistory)
    if (name == entry.name) return Found(entry, analysis);
  const size_t dot = name.rfind('.');
  if (dot != std::string::npos && dot > 0) {
    const std::string owner = name.substr(0, dot), suffix = name.substr(dot + 1);
    for (const auto &series : kNamedSeries)
      if (suffix == series.suffix) {
        Quantity quantity    = Found(series.unit, series.description, analysis);
        quantity.description = owner + " (" + series.kind + "): " + quantity.description;
        if (analysis != AnalysisType::Dynamic && suffix.size() > 5 && suffix.compare(suffix.size() - 5, 5, "_rate") == 0)
          quantity.description += ", per unit pseudo-time (the load factor under load control)";
        return quantity;
      }
  }
  return {"", "a series of unknown meaning"};
}

void ProbeColumnNames(const std::string &probe, std::string names[kProbeColumns])
{
  for (int c = 0; c < kProbeColumns; ++c) {
    names[c] = probe + "." + kProbeSeries[c].quantity;
    if (*kProbeSeries[c].component) names[c] += std::string(".") + kProbeSeries[c].component;
  }
}

Quantity ProbeColumnQuantity(const std::string &probe, int column)
{
  const auto &series      = kProbeSeries[column];
  std::string description = "probe " + probe + ": " + series.description;
  if (*series.component) description += std::string(", ") + series.component;
  return {series.unit, description};
}

std::string NameWithUnit(const std::string &name, const std::string &unit)
{
  if (unit.empty() || unit == "1") return name;
  return name + " [" + unit + "]";
}

} // namespace msflex
