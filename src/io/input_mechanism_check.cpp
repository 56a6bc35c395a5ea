// Static mechanism check: every connected group of beams, and every group of rigid bodies outside
// all beams, must be held by its supports and its joints to the ground against the six linearised
// rigid-body motions, or the static tangent stiffness is singular from the first step. Elements and
// joints between two nodes, and bushings stiff in all six directions, connect nodes into groups. Caught here, the user gets a message naming
// the beams or the node instead of a failed solve. Dynamic analyses skip the check: there the mass
// holds free motions. Mechanisms inside a group (e.g. a free revolute joint between two supported
// beams) are not detected.
#include "io/input_reader_internal.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <numeric>

namespace msflex::input_detail {

namespace {

// Connected components of the node graph (nodes linked by elements and by joints between two
// nodes), by union-find.
class NodeComponents {
public:
  explicit NodeComponents(const Model &model) : parent_(model.nodes.size())
  {
    std::iota(parent_.begin(), parent_.end(), 0);
    for (const BeamElement &element : model.elements)
      for (int a = 1; a <= element.order; ++a) Join(element.nodes[0], element.nodes[a]);
    for (const Joint &joint : model.joints)
      if (joint.master >= 0) Join(joint.master, joint.slave);
    // A bushing stiff in all six directions ties its nodes like an element.
    for (const ForceElement &element : model.force_elements)
      if (element.kind == ForceElement::Kind::Bushing && element.bushing_stiffness.llt().info() == Eigen::Success) Join(element.nodes[0], element.nodes[1]);
  }
  int Root(int node)
  {
    while (parent_[node] != node) node = parent_[node] = parent_[parent_[node]];
    return node;
  }

private:
  void             Join(int first, int second) { parent_[Root(first)] = Root(second); }
  std::vector<int> parent_;
};

// Which of the six DOFs of each node some support fixes or prescribes.
std::vector<std::array<bool, 6>> ConstrainedDofs(const Model &model)
{
  std::vector<std::array<bool, 6>> constrained(model.nodes.size(), std::array<bool, 6>{});
  for (const Support &support : model.supports)
    for (int node : support.nodes)
      for (int dof = 0; dof < 6; ++dof) constrained[node][dof] = constrained[node][dof] || support.kind[dof] != Support::Kind::Free;
  return constrained;
}

using ModeRow = Eigen::Matrix<double, 1, 6>;

// The constraint "displacement along a = 0" at a point with (scaled) arm from the centroid, in the
// six modes: mode k < 3 translates along e_k, mode 3 + k rotates about e_k through the centroid.
ModeRow TranslationRow(const Vec3 &a, const Vec3 &arm)
{
  ModeRow row;
  for (int axis = 0; axis < 3; ++axis) {
    row(axis)     = a(axis);
    row(3 + axis) = a.dot(Vec3::Unit(axis).cross(arm));
  }
  return row;
}

// The constraint "rotation about a = 0" in the six modes.
ModeRow RotationRow(const Vec3 &a)
{
  ModeRow row   = ModeRow::Zero();
  row.tail<3>() = a.transpose();
  return row;
}

// The joint axes along which a joint to the ground holds its slave: translations not released
// (the dependent translation of a screw, rack or cam counts as released) and rotations not released.
void GroundJointConstraints(const Joint &joint, std::vector<Vec3> *translations, std::vector<Vec3> *rotations)
{
  std::array<bool, 3> translation_released{};
  for (int k = 0; k < joint.num_translations; ++k) translation_released[joint.translation_axis[k]] = true;
  if (joint.dependence != Joint::Dependence::None) translation_released[joint.dependent_axis] = true;
  std::array<bool, 3> rotation_released{};
  switch (joint.rotation) {
  case Joint::Rotation::None:
    break;
  case Joint::Rotation::OneAxis:
    rotation_released[joint.rotation_axis[0]] = true;
    break;
  case Joint::Rotation::TwoAxes:
    rotation_released[joint.rotation_axis[0]] = rotation_released[joint.rotation_axis[1]] = true;
    break;
  case Joint::Rotation::Free:
    rotation_released.fill(true);
    break;
  }
  for (int axis = 0; axis < 3; ++axis) {
    if (!translation_released[axis]) translations->push_back(joint.axes.col(axis));
    if (!rotation_released[axis]) rotations->push_back(joint.axes.col(axis));
  }
}

// Number of independent rigid-body modes of the component's nodes held by the constraints: the
// supported DOFs and the joints to the ground (indices into Model::joints) whose slaves lie in
// the component. Each constraint contributes the row of its values in the six modes. Lengths are
// divided by the component size so the rank threshold does not depend on units.
int RestrainedRigidBodyModes(const Model &model, const std::vector<int> &nodes, const std::vector<std::array<bool, 6>> &constrained,
                             const std::vector<int> &ground_joints)
{
  Vec3 centroid = Vec3::Zero();
  for (int node : nodes) centroid += model.nodes[node].position;
  centroid /= static_cast<double>(nodes.size());
  double size = 0.0;
  for (int node : nodes) size = std::max(size, (model.nodes[node].position - centroid).norm());
  if (size == 0.0) size = 1.0;
  const auto arm_of = [&](int node) -> Vec3 { return (model.nodes[node].position - centroid) / size; };

  std::vector<ModeRow> rows;
  for (int node : nodes)
    for (int dof = 0; dof < 6; ++dof) {
      if (!constrained[node][dof]) continue;
      rows.push_back(dof < 3 ? TranslationRow(Vec3::Unit(dof), arm_of(node)) : RotationRow(Vec3::Unit(dof - 3)));
    }
  for (int index : ground_joints) {
    const Joint      &joint = model.joints[index];
    std::vector<Vec3> translations, rotations;
    GroundJointConstraints(joint, &translations, &rotations);
    for (const Vec3 &axis : translations) rows.push_back(TranslationRow(axis, arm_of(joint.slave)));
    for (const Vec3 &axis : rotations) rows.push_back(RotationRow(axis));
  }
  if (rows.empty()) return 0;
  Eigen::MatrixXd modes(rows.size(), 6);
  for (size_t row = 0; row < rows.size(); ++row) modes.row(static_cast<Eigen::Index>(row)) = rows[row];
  Eigen::FullPivLU<Eigen::MatrixXd> decomposition(modes);
  decomposition.setThreshold(1e-10);
  return static_cast<int>(decomposition.rank());
}

std::string BeamList(const Model &model, const std::vector<int> &beams)
{
  constexpr size_t kNamesShown = 3;
  std::string      list;
  for (size_t index = 0; index < beams.size() && index < kNamesShown; ++index) list += (index > 0 ? ", " : "") + Quote(model.beams[beams[index]].name);
  if (beams.size() > kNamesShown) list += " and " + std::to_string(beams.size() - kNamesShown) + " more";
  return list;
}

} // namespace

void CheckStaticMechanisms(const Model &model)
{
  NodeComponents                components(model);
  const auto                    constrained = ConstrainedDofs(model);
  std::vector<std::vector<int>> nodes_of_component(model.nodes.size()); // indexed by component root
  std::vector<std::vector<int>> beams_of_component(model.nodes.size());
  std::vector<std::vector<int>> ground_joints_of_component(model.nodes.size());
  for (size_t node = 0; node < model.nodes.size(); ++node) nodes_of_component[components.Root(static_cast<int>(node))].push_back(static_cast<int>(node));
  for (size_t beam = 0; beam < model.beams.size(); ++beam)
    beams_of_component[components.Root(model.beams[beam].nodes.front())].push_back(static_cast<int>(beam));
  for (size_t joint = 0; joint < model.joints.size(); ++joint)
    if (model.joints[joint].master < 0) ground_joints_of_component[components.Root(model.joints[joint].slave)].push_back(static_cast<int>(joint));
  // Components in the order of their first beam, so the first mechanism reported is the first
  // one in the file.
  for (size_t beam = 0; beam < model.beams.size(); ++beam) {
    const int               root  = components.Root(model.beams[beam].nodes.front());
    const std::vector<int> &beams = beams_of_component[root];
    if (beams.front() != static_cast<int>(beam)) continue;
    const int restrained = RestrainedRigidBodyModes(model, nodes_of_component[root], constrained, ground_joints_of_component[root]);
    if (restrained < 6)
      FailAt(model.beams[beam].mark, "mechanism: beam(s) " + BeamList(model, beams) + " can move as a rigid body (" + std::to_string(restrained) +
                                         " of 6 rigid-body modes restrained); add supports");
  }
  // A group of nodes outside every beam (carrying rigid bodies, possibly joined by joints) has no
  // stiffness at all: statics needs supports and joints to the ground that hold it completely.
  // Checked once per group, at its first rigid body.
  std::vector<bool> checked(model.nodes.size(), false);
  for (const RigidBody &body : model.rigid_bodies) {
    const int root = components.Root(body.node);
    if (!beams_of_component[root].empty() || checked[root]) continue;
    checked[root]        = true;
    const int restrained = RestrainedRigidBodyModes(model, nodes_of_component[root], constrained, ground_joints_of_component[root]);
    if (restrained < 6)
      FailAt(body.mark, "mechanism: the rigid body at node " + Quote(model.nodes[body.node].name) + " is not connected to any beam and can move freely (" +
                            std::to_string(restrained) + " of 6 rigid-body modes restrained); in a static analysis add supports or use type: dynamic");
  }
}

} // namespace msflex::input_detail
