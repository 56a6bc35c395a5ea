// Static mechanism check: every connected group of beams, and every group of rigid bodies outside
// all beams, must be held against the six linearised rigid-body motions, or the static tangent
// stiffness is singular from the first step. Caught here, the user gets a message naming the beams
// or the node instead of a failed solve. Dynamic analyses skip the check: there the mass holds free
// motions.
//
// Groups: elements, joints between two nodes and bushings stiff in all six directions connect
// nodes into groups. What holds a group: its supports, its joints to the ground (along the axes
// they do not release, and along a released coordinate that the spring of a coordinate element
// holds), and, from a group that is held completely, the springs between two nodes that restrain
// only part of their relative motion (a spring-damper its length, a bushing with a singular
// stiffness the relative motions that stiffness resists). Dampers and actuators hold nothing in
// statics. The check is conservative about partial restraints: they count outwards from the
// groups held completely, so groups that would only hold each other through springs between them
// are refused, and the stiffness that a preload or the loads add is not counted. Mechanisms inside
// a group (e.g. a free revolute joint between two supported beams) are not detected.
#include "io/input_reader_internal.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <numeric>
#include <utility>

namespace msflex::input_detail {

namespace {

// Relative threshold of the ranks: of the rigid-body modes held and of a bushing's stiffness
// scaled to unit diagonal.
constexpr double kRankThreshold = 1e-10;

using ModeRow = Eigen::Matrix<double, 1, 6>;
using Vec6    = Eigen::Matrix<double, 6, 1>;
using Mat6    = Eigen::Matrix<double, 6, 6>;

// Whether a spring has stiffness at `value` of its coordinate or length: a linear spring with
// k > 0, or a table whose slope there is not zero, on both sides when the deflection is a knot (a
// table flat on one side, as a cable slack in compression, does not certainly hold).
bool SpringHolds(const SpringLaw &spring, double value)
{
  if (!spring.present) return false;
  if (spring.deflections.empty()) return spring.stiffness > 0.0;
  const std::vector<double> &x = spring.deflections, &f = spring.forces;
  const int                  last_segment = static_cast<int>(x.size()) - 2;
  // Segment i, or the end segment continued beyond the table.
  const auto slope = [&](int i) {
    i = std::clamp(i, 0, last_segment);
    return (f[i + 1] - f[i]) / (x[i + 1] - x[i]);
  };
  const double deflection = value - spring.free_value;
  const int    segment    = static_cast<int>(std::upper_bound(x.begin(), x.end(), deflection) - x.begin()) - 1;
  if (slope(segment) == 0.0) return false;
  const bool at_knot = segment >= 0 && x[segment] == deflection;
  return !at_knot || slope(segment - 1) != 0.0;
}

// The deflections e = (d, eta) in bushing axes that a bushing's stiffness K resists, as rows r:
// K e = 0 exactly when r . e = 0 for every row, so the rows span the row space of K. Found on K
// scaled to unit diagonal, so that translations (N/m) and rotations (N m/rad) compare. Six rows:
// stiff in every direction; none: damping only.
std::vector<Vec6> BushingRows(const Mat6 &stiffness)
{
  const Vec6                                root    = stiffness.diagonal().cwiseMax(0.0).cwiseSqrt();
  const Vec6                                inverse = root.unaryExpr([](double value) { return value > 0.0 ? 1.0 / value : 0.0; });
  const Mat6                                scaled  = inverse.asDiagonal() * stiffness * inverse.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Mat6> eigen(scaled);
  std::vector<Vec6>                         rows;
  // K = D S D with D = diag(root): the row space of K is D times the range of S.
  for (int k = 0; k < 6; ++k)
    if (eigen.eigenvalues()(k) > kRankThreshold) rows.push_back(root.asDiagonal() * eigen.eigenvectors().col(k));
  return rows;
}

bool BushingStiffEverywhere(const ForceElement &element)
{
  return element.kind == ForceElement::Kind::Bushing && BushingRows(element.bushing_stiffness).size() == 6;
}

// Connected components of the node graph (nodes linked by elements, by joints between two nodes
// and by bushings stiff in every direction), by union-find.
class NodeComponents {
public:
  explicit NodeComponents(const Model &model) : parent_(model.nodes.size())
  {
    std::iota(parent_.begin(), parent_.end(), 0);
    for (const BeamElement &element : model.elements)
      for (int a = 1; a <= element.order; ++a) Join(element.nodes[0], element.nodes[a]);
    for (const Joint &joint : model.joints)
      if (joint.master >= 0) Join(joint.master, joint.slave);
    for (const ForceElement &element : model.force_elements)
      if (BushingStiffEverywhere(element)) Join(element.nodes[0], element.nodes[1]);
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

// The constraint "displacement along a = 0" at a point with (scaled) arm from the centroid, in the
// six modes: mode k < 3 translates along e_k, mode 3 + k rotates about e_k through the centroid
// (by an angle times the group's size, so that all six are lengths).
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

// The released coordinates of each joint (translations, then rotations) that the spring of a
// coordinate element holds at the reference configuration (q = 0), or a drive prescribes.
std::vector<std::array<bool, 5>> SprungCoordinates(const Model &model)
{
  std::vector<std::array<bool, 5>> sprung(model.joints.size(), std::array<bool, 5>{});
  for (const ForceElement &element : model.force_elements)
    if (element.kind == ForceElement::Kind::Coordinate && element.coordinate >= 0 && element.coordinate < 5 && SpringHolds(element.spring, 0.0))
      sprung[element.joint][element.coordinate] = true;
  for (size_t j = 0; j < model.joints.size(); ++j)
    if (model.joints[j].driven_coordinate >= 0 && model.joints[j].driven_coordinate < 5) sprung[j][model.joints[j].driven_coordinate] = true;
  return sprung;
}

// The joint axes along which a joint to the ground holds its slave: translations not released
// and rotations not released, or released but held by a spring (sprung: by coordinate). The
// dependent translation of a screw, rack or cam counts as released unless its rotation is sprung.
void GroundJointConstraints(const Joint &joint, const std::array<bool, 5> &sprung, std::vector<Vec3> *translations, std::vector<Vec3> *rotations)
{
  std::array<bool, 3> translation_released{};
  for (int k = 0; k < joint.num_translations; ++k)
    if (!sprung[k]) translation_released[joint.translation_axis[k]] = true;
  std::array<bool, 3> rotation_released{};
  const auto          release_rotation = [&](int k) {
    if (!sprung[joint.num_translations + k]) rotation_released[joint.rotation_axis[k]] = true;
  };
  switch (joint.rotation) {
  case Joint::Rotation::None:
    break;
  case Joint::Rotation::OneAxis:
    release_rotation(0);
    break;
  case Joint::Rotation::TwoAxes: // about a_[0], then about the carried a_[1]: a_[1] at the reference configuration
    release_rotation(0);
    release_rotation(1);
    break;
  case Joint::Rotation::Free:
    rotation_released.fill(true);
    break;
  }
  if (joint.dependence != Joint::Dependence::None && !sprung[joint.num_translations]) translation_released[joint.dependent_axis] = true;
  for (int axis = 0; axis < 3; ++axis) {
    if (!translation_released[axis]) translations->push_back(joint.axes.col(axis));
    if (!rotation_released[axis]) rotations->push_back(joint.axes.col(axis));
  }
}

// A spring between two nodes that holds only part of their relative motion (it does not join
// their groups): for each row (u, w), u . (dp_1 - dp_0) + w . (theta_1 - theta_0) = 0, with dp_s the
// displacement of points[s] carried with nodes[s] and theta_s the rotation of nodes[s].
struct PartialSpring {
  std::array<int, 2>                 nodes{{-1, -1}};
  std::array<Vec3, 2>                points;
  std::vector<std::pair<Vec3, Vec3>> rows;
};

// Spring-dampers with stiffness (along their line: the length, l = |x_1 - x_0|) and bushings
// with some stiffness but not in all six directions (the relative motion of the point at the
// second node carried by each node's frame, and the relative rotation, in bushing axes).
std::vector<PartialSpring> PartialSprings(const Model &model)
{
  std::vector<PartialSpring> springs;
  for (const ForceElement &element : model.force_elements) {
    PartialSpring spring;
    spring.nodes      = element.nodes;
    const Vec3 first  = model.nodes[element.nodes[0]].position;
    const Vec3 second = model.nodes[element.nodes[1]].position;
    if (element.kind == ForceElement::Kind::SpringDamper) {
      const double length = (second - first).norm();
      if (!(length > 0.0) || !SpringHolds(element.spring, length)) continue;
      spring.points = {first, second};
      spring.rows.emplace_back((second - first) / length, Vec3::Zero());
    } else if (element.kind == ForceElement::Kind::Bushing) {
      const std::vector<Vec6> rows = BushingRows(element.bushing_stiffness);
      if (rows.empty() || rows.size() == 6) continue; // nothing, or joins the groups
      spring.points = {second, second};
      for (const Vec6 &row : rows) spring.rows.emplace_back(element.axes * row.head<3>(), element.axes * row.tail<3>());
    } else {
      continue;
    }
    springs.push_back(std::move(spring));
  }
  return springs;
}

int Rank(const std::vector<ModeRow> &rows)
{
  if (rows.empty()) return 0;
  Eigen::MatrixXd modes(rows.size(), 6);
  for (size_t row = 0; row < rows.size(); ++row) modes.row(static_cast<Eigen::Index>(row)) = rows[row];
  Eigen::FullPivLU<Eigen::MatrixXd> decomposition(modes);
  decomposition.setThreshold(kRankThreshold);
  return static_cast<int>(decomposition.rank());
}

// A group of nodes that moves as one rigid body in the check. Lengths are divided by its size so
// that the rank threshold does not depend on units.
struct Group {
  std::vector<int>     nodes, beams, ground_joints, partial_springs;
  Vec3                 centroid = Vec3::Zero();
  double               size     = 1.0;
  std::vector<ModeRow> rows; // the constraints held so far, in the six modes
  int                  restrained = 0;
  bool                 held       = false;
  Vec3                 Arm(const Vec3 &point) const { return (point - centroid) / size; }
};

// The groups (indexed by their component root) with the constraints of their supports and
// joints to the ground, then of the partial springs from groups held completely, from the held
// groups outwards.
std::vector<Group> HeldGroups(const Model &model, NodeComponents &components)
{
  std::vector<Group> groups(model.nodes.size());
  for (size_t node = 0; node < model.nodes.size(); ++node) groups[components.Root(static_cast<int>(node))].nodes.push_back(static_cast<int>(node));
  for (size_t beam = 0; beam < model.beams.size(); ++beam) groups[components.Root(model.beams[beam].nodes.front())].beams.push_back(static_cast<int>(beam));
  for (size_t joint = 0; joint < model.joints.size(); ++joint)
    if (model.joints[joint].master < 0) groups[components.Root(model.joints[joint].slave)].ground_joints.push_back(static_cast<int>(joint));
  const std::vector<PartialSpring> springs = PartialSprings(model);
  for (size_t index = 0; index < springs.size(); ++index) {
    const int first = components.Root(springs[index].nodes[0]), second = components.Root(springs[index].nodes[1]);
    if (first == second) continue; // inside a group that moves as one body: holds nothing of it
    groups[first].partial_springs.push_back(static_cast<int>(index));
    groups[second].partial_springs.push_back(static_cast<int>(index));
  }

  const auto       constrained = ConstrainedDofs(model);
  const auto       sprung      = SprungCoordinates(model);
  std::vector<int> held_queue;
  for (Group &group : groups) {
    if (group.nodes.empty()) continue;
    for (int node : group.nodes) group.centroid += model.nodes[node].position;
    group.centroid /= static_cast<double>(group.nodes.size());
    double size = 0.0;
    for (int node : group.nodes) size = std::max(size, (model.nodes[node].position - group.centroid).norm());
    group.size = size > 0.0 ? size : 1.0;
    for (int node : group.nodes)
      for (int dof = 0; dof < 6; ++dof) {
        if (!constrained[node][dof]) continue;
        group.rows.push_back(dof < 3 ? TranslationRow(Vec3::Unit(dof), group.Arm(model.nodes[node].position)) : RotationRow(Vec3::Unit(dof - 3)));
      }
    for (int index : group.ground_joints) {
      const Joint      &joint = model.joints[index];
      std::vector<Vec3> translations, rotations;
      GroundJointConstraints(joint, sprung[index], &translations, &rotations);
      for (const Vec3 &axis : translations) group.rows.push_back(TranslationRow(axis, group.Arm(model.nodes[joint.slave].position)));
      for (const Vec3 &axis : rotations) group.rows.push_back(RotationRow(axis));
    }
    group.restrained = Rank(group.rows);
    group.held       = group.restrained == 6;
    if (group.held) held_queue.push_back(static_cast<int>(&group - groups.data()));
  }
  // A held group is the ground for the partial springs to the other groups: each spring's rows,
  // in the other group's modes, are added once, when the first of its groups is found held.
  while (!held_queue.empty()) {
    const int held = held_queue.back();
    held_queue.pop_back();
    for (int index : groups[held].partial_springs) {
      const PartialSpring &spring = springs[index];
      const int            side   = components.Root(spring.nodes[0]) == held ? 1 : 0;
      const int            other  = components.Root(spring.nodes[side]);
      Group               &group  = groups[other];
      if (group.held) continue;
      for (const auto &[u, w] : spring.rows) {
        const ModeRow row = TranslationRow(u, group.Arm(spring.points[side])) + RotationRow(w / group.size);
        if (row.norm() > 0.0) group.rows.push_back(row / row.norm());
      }
      group.restrained = Rank(group.rows);
      group.held       = group.restrained == 6;
      if (group.held) held_queue.push_back(other);
    }
  }
  return groups;
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

void CheckStaticMechanisms(const Model &model, AnalysisType type)
{
  // What needs the equilibrium, and the way out: the message named a static analysis for a
  // preloaded modes analysis as well.
  const std::string        way_out      = type == AnalysisType::Static  ? "add supports"
                                          : type == AnalysisType::Modes ? "add supports, or give preload: false (the modes of the free model)"
                                                                        : "add supports (buckling needs an equilibrium to buckle from)";
  const std::string        body_way_out = type == AnalysisType::Static ? "in a static analysis add supports or use type: dynamic" : way_out;
  NodeComponents           components(model);
  const std::vector<Group> groups = HeldGroups(model, components);
  // Groups in the order of their first beam, so the first mechanism reported is the first one in
  // the file.
  for (size_t beam = 0; beam < model.beams.size(); ++beam) {
    const Group &group = groups[components.Root(model.beams[beam].nodes.front())];
    if (group.beams.front() != static_cast<int>(beam) || group.held) continue;
    FailAt(model.beams[beam].mark, "mechanism: beam(s) " + BeamList(model, group.beams) + " can move as a rigid body (" + std::to_string(group.restrained) +
                                       " of 6 rigid-body modes restrained); " + way_out);
  }
  // A group of nodes outside every beam (carrying rigid bodies, possibly joined by joints) has no
  // stiffness of its own: statics needs what holds it completely. Reported at its first rigid body.
  for (const RigidBody &body : model.rigid_bodies) {
    const Group &group = groups[components.Root(body.node)];
    if (!group.beams.empty() || group.held) continue;
    FailAt(body.mark, "mechanism: the rigid body at node " + Quote(model.nodes[body.node].name) + " is not connected to any beam and can move freely (" +
                          std::to_string(group.restrained) + " of 6 rigid-body modes restrained); " + body_way_out);
  }
}

void CheckModelForAnalysis(const Model &model, AnalysisType type, bool preload)
{
  if (NeedsStaticStiffness(type, preload)) CheckStaticMechanisms(model, type);
  // Modes need mass: found here, before any file is made, instead of by the eigensolver after
  // -output_overwrite had replaced the old results with an empty file (a user trial).
  if (type == AnalysisType::Modes) {
    bool has_mass = false;
    for (const RigidBody &body : model.rigid_bodies) has_mass = has_mass || body.mass > 0.0 || body.inertia.norm() > 0.0;
    for (const BeamElement &element : model.elements) {
      const Section &section = model.sections[element.section];
      has_mass               = has_mass || section.rhoA > 0.0 || section.rhoJ.norm() > 0.0;
    }
    if (!has_mass) FailAt(model.analysis.mark, "a modes analysis needs mass, but no beam's section has rhoA or rhoJ (or density) and there is no rigid body");
  }
  // A follower load's stiffness is not symmetric: the symmetric eigenproblems of a buckling
  // analysis and of preloaded modes would give wrong answers (Beck's column, which loses stability
  // only by flutter at 20.05 EI/L^2, came out with a divergence load of 7.97 EI/L^2 and real
  // frequencies past flutter).
  const bool buckling = type == AnalysisType::Buckling;
  if (!buckling && !(type == AnalysisType::Modes && preload)) return;
  for (const NodalLoad &load : model.nodal_loads)
    if (load.follower)
      FailAt(load.mark, std::string("a follower load makes the load stiffness non-symmetric, which the ") + (buckling ? "buckling" : "preloaded modes") +
                            " analysis, a symmetric eigenproblem, cannot take: its answers would be wrong (a column under a follower force loses "
                            "stability by flutter, not divergence); a static analysis finds the path and its divergence points, a dynamic one flutter");
}

} // namespace msflex::input_detail
