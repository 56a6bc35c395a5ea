// Reading `rigid_bodies` and `initial_conditions`, the parts of the input that only carry mass and
// motion (docs/input.md, "rigid_bodies" and "initial_conditions").
#include "io/input_reader_internal.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace msflex::input_detail {

namespace {

// Relative tolerances of the inertia tensor checks (docs/input.md).
constexpr double kInertiaSymmetryTolerance   = 1e-12;
constexpr double kInertiaEigenvalueTolerance = 1e-12;

// 3 numbers: the diagonal (principal moments about the global axes); or 3 rows of 3 numbers: the
// full tensor, which must be symmetric and positive semi-definite.
Mat3 ReadInertia(const YAML::Node &value, const std::string &body)
{
  const std::string key = "inertia";
  if (!value.IsSequence() || value.size() != 3)
    FailAt(ValueMark(value), "expected 3 numbers (the diagonal) or a 3x3 list of lists for " + Quote(key) + " of " + body + ", got " +
                                 (value.IsSequence() ? "a list of " + std::to_string(value.size()) : DescribeValue(value)));
  if (!value[0].IsSequence()) return ReadNonNegativeVec3(value, key).asDiagonal();
  Mat3 inertia;
  for (int row = 0; row < 3; ++row) inertia.row(row) = ReadVec3(value[row], key).transpose();
  const double scale = inertia.cwiseAbs().maxCoeff();
  for (int row = 0; row < 3; ++row)
    for (int column = row + 1; column < 3; ++column)
      if (std::abs(inertia(row, column) - inertia(column, row)) > kInertiaSymmetryTolerance * scale)
        FailAt(value[column][row].Mark(), Quote(key) + " of " + body + " is not symmetric: entry (" + std::to_string(row + 1) + ", " +
                                              std::to_string(column + 1) + ") is " + FormatNumber(inertia(row, column)) + " but entry (" +
                                              std::to_string(column + 1) + ", " + std::to_string(row + 1) + ") is " + FormatNumber(inertia(column, row)));
  const Mat3                                symmetric = 0.5 * (inertia + inertia.transpose());
  const Eigen::SelfAdjointEigenSolver<Mat3> eigen(symmetric, Eigen::EigenvaluesOnly);
  const Vec3                               &eigenvalues = eigen.eigenvalues(); // ascending
  if (eigenvalues(0) < -kInertiaEigenvalueTolerance * eigenvalues.cwiseAbs().maxCoeff())
    FailAt(ValueMark(value), Quote(key) + " of " + body + " is not positive semi-definite: its eigenvalues are " + FormatNumber(eigenvalues(0)) + ", " +
                                 FormatNumber(eigenvalues(1)) + " and " + FormatNumber(eigenvalues(2)));
  return symmetric;
}

RigidBody ReadRigidBody(const YAML::Node &item, const ReaderContext &context)
{
  const MappingReader entry(item, "rigid body", {"name", "node", "mass", "inertia", "offset"});
  RigidBody           body;
  body.mark = context.MarkOf(entry.Mark());
  if (entry.Has("name")) {
    body.name = entry.String("name");
    for (const RigidBody &other : context.model.rigid_bodies)
      if (other.name == body.name)
        FailAt(entry.Required("name").Mark(),
               "duplicate rigid body name " + Quote(body.name) + " (first defined at line " + std::to_string(other.mark.line) + ")");
  }
  body.node               = context.NodeIndex(entry, "node");
  const std::string where = "the rigid body at node " + Quote(context.model.nodes[body.node].name);
  body.mass               = entry.PositiveNumber("mass");
  body.inertia            = ReadInertia(entry.Required("inertia"), where);
  body.offset             = entry.Has("offset") ? ReadPosition(entry.Required("offset"), "offset") : Vec3::Zero();
  return body;
}

} // namespace

void ReadRigidBodies(const std::vector<YAML::Node> &items, ReaderContext &context)
{
  for (const YAML::Node &item : items) context.model.rigid_bodies.push_back(ReadRigidBody(item, context));
}

namespace {

// An initial condition on a joint's released coordinate: `joint`, `coordinate`, `value` and/or `rate`.
void ReadCoordinateInitialCondition(const MappingReader &entry, ReaderContext &context)
{
  entry.RequireOnlyKeys({"joint", "coordinate", "value", "rate"});
  Model                     &model = context.model;
  CoordinateInitialCondition condition;
  condition.mark                = context.MarkOf(entry.Mark());
  const YAML::Node &joint_value = entry.Required("joint");
  const std::string joint_name  = ReadString(joint_value, "joint");
  const auto        found       = context.joint_names.find(joint_name);
  if (found == context.joint_names.end()) FailAt(joint_value.Mark(), "unknown joint " + Quote(joint_name) + " in " + entry.Description());
  condition.joint      = found->second;
  const Joint &joint   = model.joints[condition.joint];
  condition.coordinate = NamedJointCoordinate(joint, entry.Required("coordinate"), entry.Description());
  if (condition.coordinate == joint.driven_coordinate)
    FailAt(entry.Required("coordinate").Mark(),
           "coordinate " + entry.Required("coordinate").Scalar() + " of joint " + Quote(joint.name) + " is driven: its drive sets its value and rate");
  if (!entry.Has("value") && !entry.Has("rate")) FailAt(entry.Mark(), "an initial condition on a joint coordinate needs 'value', 'rate' or both");
  condition.has_value = entry.Has("value");
  condition.has_rate  = entry.Has("rate");
  condition.value     = entry.Number("value", 0.0);
  condition.rate      = entry.Number("rate", 0.0);
  for (const CoordinateInitialCondition &other : model.coordinate_initial_conditions)
    if (other.joint == condition.joint && other.coordinate == condition.coordinate)
      FailAt(entry.Mark(), "coordinate " + entry.Required("coordinate").Scalar() + " of joint " + Quote(joint.name) +
                               " already has an initial condition from the entry at line " + std::to_string(other.mark.line));
  model.coordinate_initial_conditions.push_back(condition);
}

} // namespace

void ReadInitialConditions(const YAML::Node *list, ReaderContext &context)
{
  Model           &model = context.model;
  std::vector<int> condition_of_node(model.nodes.size(), -1); // index into model.initial_conditions
  for (const YAML::Node &item : ReadOptionalList(list, "initial_conditions")) {
    const MappingReader entry(item, "initial condition");
    if (entry.Has("joint") && !entry.Has("nodes")) {
      ReadCoordinateInitialCondition(entry, context);
      continue;
    }
    entry.RequireOnlyKeys({"nodes", "velocity", "angular_velocity", "rigid_body_center", "displacement", "rotation"});
    if (!entry.Has("velocity") && !entry.Has("angular_velocity") && !entry.Has("displacement") && !entry.Has("rotation"))
      FailAt(entry.Mark(), "an initial condition needs 'velocity', 'angular_velocity', 'displacement' or 'rotation'");
    InitialCondition condition;
    condition.mark             = context.MarkOf(entry.Mark());
    const YAML::Node &nodes    = entry.Required("nodes");
    condition.nodes            = context.ResolveNodes(nodes, "nodes");
    condition.velocity         = entry.Vector("velocity", Vec3::Zero());
    condition.angular_velocity = entry.Vector("angular_velocity", Vec3::Zero());
    condition.has_velocity     = entry.Has("velocity") || entry.Has("angular_velocity");
    condition.displacement     = entry.Has("displacement") ? ReadPosition(entry.Required("displacement"), "displacement") : Vec3::Zero();
    condition.rotation         = entry.Vector("rotation", Vec3::Zero());
    condition.rigid_body_field = entry.Has("rigid_body_center");
    if (entry.Has("rigid_body_center")) condition.center = ReadPosition(entry.Required("rigid_body_center"), "rigid_body_center");
    const bool moves = entry.Has("displacement") || entry.Has("rotation");
    const int  index = static_cast<int>(model.initial_conditions.size());
    for (int node : condition.nodes) {
      if (const int first = condition_of_node[node]; first >= 0)
        FailAt(nodes.Mark(), "node " + Quote(model.nodes[node].name) + " already has an initial condition from the entry at line " +
                                 std::to_string(model.initial_conditions[first].mark.line) + "; a node may get at most one initial condition");
      if (const int joint = context.JointOfSlave(node); moves && joint >= 0)
        FailAt(nodes.Mark(), "node " + Quote(model.nodes[node].name) + " is the slave of joint " + Quote(model.joints[joint].name) +
                                 ", which places it: give the joint's coordinates an initial 'value' instead of a 'displacement' or 'rotation'");
      condition_of_node[node] = index;
    }
    model.initial_conditions.push_back(std::move(condition));
  }
}

} // namespace msflex::input_detail
