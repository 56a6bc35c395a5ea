// Static mechanism check: every connected group of beams, and every rigid body on a node outside
// all beams, must be held by its supports against the six linearised rigid-body motions, or the
// static tangent stiffness is singular from the first step. Caught here, the user gets a message
// naming the beams or the node instead of a failed solve. Dynamic analyses skip the check: there
// the mass holds free motions.
#include "io/input_reader_internal.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <numeric>

namespace msflex::input_detail {

namespace {

// Connected components of the node graph (nodes linked by elements), by union-find.
class NodeComponents {
public:
  explicit NodeComponents(const Model &model) : parent_(model.nodes.size())
  {
    std::iota(parent_.begin(), parent_.end(), 0);
    for (const BeamElement &element : model.elements)
      for (int a = 1; a <= element.order; ++a) Join(element.nodes[0], element.nodes[a]);
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

// Number of independent rigid-body modes of the component's nodes held by the constraints.
// Mode k < 3 translates along e_k; mode 3 + k rotates about e_k through the centroid. Each
// constrained DOF contributes the row of its values in the six modes. Lengths are divided by the
// component size so the rank threshold does not depend on units.
int RestrainedRigidBodyModes(const Model &model, const std::vector<int> &nodes, const std::vector<std::array<bool, 6>> &constrained)
{
  Vec3 centroid = Vec3::Zero();
  for (int node : nodes) centroid += model.nodes[node].position;
  centroid /= static_cast<double>(nodes.size());
  double size = 0.0;
  for (int node : nodes) size = std::max(size, (model.nodes[node].position - centroid).norm());
  if (size == 0.0) size = 1.0;

  std::vector<Eigen::Matrix<double, 1, 6>> rows;
  for (int node : nodes) {
    const Vec3 arm = (model.nodes[node].position - centroid) / size;
    for (int dof = 0; dof < 6; ++dof) {
      if (!constrained[node][dof]) continue;
      Eigen::Matrix<double, 1, 6> row = Eigen::Matrix<double, 1, 6>::Zero();
      row(dof) = 1.0; // translation mode along the DOF's axis, or rotation mode about it
      if (dof < 3)
        for (int axis = 0; axis < 3; ++axis) row(3 + axis) = Vec3::Unit(axis).cross(arm)(dof);
      rows.push_back(row);
    }
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
  for (size_t index = 0; index < beams.size() && index < kNamesShown; ++index)
    list += (index > 0 ? ", " : "") + Quote(model.beams[beams[index]].name);
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
  for (size_t node = 0; node < model.nodes.size(); ++node)
    nodes_of_component[components.Root(static_cast<int>(node))].push_back(static_cast<int>(node));
  for (size_t beam = 0; beam < model.beams.size(); ++beam)
    beams_of_component[components.Root(model.beams[beam].nodes.front())].push_back(static_cast<int>(beam));
  // Components in the order of their first beam, so the first mechanism reported is the first
  // one in the file.
  for (size_t beam = 0; beam < model.beams.size(); ++beam) {
    const int               root  = components.Root(model.beams[beam].nodes.front());
    const std::vector<int> &beams = beams_of_component[root];
    if (beams.front() != static_cast<int>(beam)) continue;
    const int restrained = RestrainedRigidBodyModes(model, nodes_of_component[root], constrained);
    if (restrained < 6)
      FailAt(model.beams[beam].mark, "mechanism: beam(s) " + BeamList(model, beams) + " can move as a rigid body (" +
                                         std::to_string(restrained) + " of 6 rigid-body modes restrained); add supports");
  }
  // A node outside every beam (it carries a rigid body) has no stiffness at all: statics needs all
  // six of its DOFs constrained.
  for (const RigidBody &body : model.rigid_bodies) {
    if (!beams_of_component[components.Root(body.node)].empty()) continue;
    const int restrained = RestrainedRigidBodyModes(model, {body.node}, constrained);
    if (restrained < 6)
      FailAt(body.mark, "mechanism: the rigid body at node " + Quote(model.nodes[body.node].name) +
                            " is not connected to any beam and can move freely (" + std::to_string(restrained) +
                            " of 6 rigid-body modes restrained); in a static analysis add supports or use type: dynamic");
  }
}

} // namespace msflex::input_detail
