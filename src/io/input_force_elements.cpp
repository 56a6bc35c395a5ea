// Reading `force_elements`: springs, dampers and actuators on joint coordinates, axial
// spring-dampers and bushings between two nodes (docs/input.md, "force_elements"; the physics is
// in elements/force_elements.hpp).
#include "io/input_reader_internal.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace msflex::input_detail {

namespace {

// Relative tolerances of the symmetry and definiteness checks of a bushing's matrices.
constexpr double kSymmetryTolerance   = 1e-12;
constexpr double kEigenvalueTolerance = 1e-12;

// `force_table`: at least two [deflection, force] pairs, deflections strictly increasing.
void ReadForceTable(const YAML::Node &value, const std::string &element, SpringLaw &spring)
{
  const std::vector<YAML::Node> points = ReadNonEmptyList(value, "force_table");
  if (points.size() < 2) FailAt(ValueMark(value), "'force_table' of " + element + " needs at least two [deflection, force] pairs, got 1");
  for (const YAML::Node &point : points) {
    if (!point.IsSequence() || point.size() != 2)
      FailAt(point.Mark(), "expected a [deflection, force] pair in 'force_table' of " + element + ", got " + DescribeValue(point));
    const double deflection = ReadNumber(point[0], "force_table");
    if (!spring.deflections.empty() && !(deflection > spring.deflections.back()))
      FailAt(point[0].Mark(), "deflections in 'force_table' of " + element + " must be strictly increasing, got " + point[0].Scalar() + " after " +
                                  FormatNumber(spring.deflections.back()));
    spring.deflections.push_back(deflection);
    spring.forces.push_back(ReadNumber(point[1], "force_table"));
  }
}

// `stiffness` or `force_table` (not both), with the free value under `free_key`.
void ReadSpringLaw(const MappingReader &entry, const std::string &free_key, double default_free_value, SpringLaw &spring)
{
  if (entry.Has("stiffness") && entry.Has("force_table"))
    FailAt(entry.Required("force_table").Mark(), "give either 'stiffness' or 'force_table' in " + entry.Description() + ", not both");
  spring.free_value = default_free_value;
  if (!entry.Has("stiffness") && !entry.Has("force_table")) {
    if (const YAML::Node *free = entry.Find(free_key))
      FailAt(free->Mark(), Quote(free_key) + " of " + entry.Description() + " needs a spring ('stiffness' or 'force_table')");
    return;
  }
  spring.present = true;
  if (entry.Has("stiffness")) spring.stiffness = entry.NonNegativeNumber("stiffness", 0.0);
  else ReadForceTable(entry.Required("force_table"), entry.Description(), spring);
  spring.free_value = entry.Number(free_key, default_free_value);
}

// 6 numbers >= 0 (a diagonal) or a symmetric positive semi-definite 6x6 matrix, row by row.
Eigen::Matrix<double, 6, 6> ReadBushingMatrix(const YAML::Node &value, const std::string &key, const std::string &element)
{
  if (!value.IsSequence() || value.size() != 6)
    FailAt(ValueMark(value), "expected 6 numbers (the diagonal) or a 6x6 list of lists for " + Quote(key) + " of " + element + ", got " +
                                 (value.IsSequence() ? "a list of " + std::to_string(value.size()) : DescribeValue(value)));
  Eigen::Matrix<double, 6, 6> matrix = Eigen::Matrix<double, 6, 6>::Zero();
  if (!value[0].IsSequence()) {
    for (int i = 0; i < 6; ++i) matrix(i, i) = ReadNonNegativeNumber(value[i], key);
    return matrix;
  }
  for (int row = 0; row < 6; ++row) {
    const YAML::Node &line = value[row];
    if (!line.IsSequence() || line.size() != 6)
      FailAt(line.Mark(), "row " + std::to_string(row + 1) + " of " + Quote(key) + " of " + element + " must hold 6 numbers, got " + DescribeValue(line));
    for (int column = 0; column < 6; ++column) matrix(row, column) = ReadNumber(line[column], key);
  }
  const double scale = matrix.cwiseAbs().maxCoeff();
  for (int row = 0; row < 6; ++row)
    for (int column = row + 1; column < 6; ++column)
      if (std::abs(matrix(row, column) - matrix(column, row)) > kSymmetryTolerance * scale)
        FailAt(value[column][row].Mark(), Quote(key) + " of " + element + " is not symmetric: entry (" + std::to_string(row + 1) + ", " +
                                              std::to_string(column + 1) + ") is " + FormatNumber(matrix(row, column)) + " but entry (" +
                                              std::to_string(column + 1) + ", " + std::to_string(row + 1) + ") is " + FormatNumber(matrix(column, row)));
  const Eigen::Matrix<double, 6, 6>                                symmetric = 0.5 * (matrix + matrix.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(symmetric, Eigen::EigenvaluesOnly);
  if (eigen.eigenvalues()(0) < -kEigenvalueTolerance * eigen.eigenvalues().cwiseAbs().maxCoeff())
    FailAt(ValueMark(value),
           Quote(key) + " of " + element + " is not positive semi-definite: its smallest eigenvalue is " + FormatNumber(eigen.eigenvalues()(0)));
  return symmetric;
}

// `nodes: [a, b]`: two different nodes.
std::array<int, 2> ReadNodePair(const MappingReader &entry, const ReaderContext &context)
{
  const YAML::Node &value = entry.Required("nodes");
  if (!value.IsSequence() || value.size() != 2)
    FailAt(ValueMark(value), "'nodes' of " + entry.Description() + " must list two nodes, got " + DescribeValue(value));
  std::array<int, 2> nodes{{-1, -1}};
  for (int k = 0; k < 2; ++k) {
    const std::string name  = ReadString(value[k], "nodes");
    const auto        found = context.names.find(name);
    if (found == context.names.end() || found->second.kind != NameKind::Node)
      FailAt(value[k].Mark(), "unknown node " + Quote(name) + " in 'nodes' of " + entry.Description());
    nodes[k] = found->second.index;
  }
  if (nodes[0] == nodes[1])
    FailAt(value[1].Mark(), "the two nodes of " + entry.Description() + " are the same node " + Quote(context.model.nodes[nodes[0]].name));
  return nodes;
}

void ReadCoordinateElement(const MappingReader &entry, const ReaderContext &context, ForceElement &element)
{
  entry.RequireOnlyKeys({"name", "type", "joint", "coordinate", "stiffness", "force_table", "free_value", "damping", "actuator", "function"});
  const YAML::Node &joint_value = entry.Required("joint");
  const std::string joint_name  = ReadString(joint_value, "joint");
  const auto        found       = context.joint_names.find(joint_name);
  if (found == context.joint_names.end()) FailAt(joint_value.Mark(), "unknown joint " + Quote(joint_name) + " in " + entry.Description());
  element.joint      = found->second;
  element.coordinate = NamedJointCoordinate(context.model.joints[element.joint], entry.Required("coordinate"), entry.Description());
  ReadSpringLaw(entry, "free_value", 0.0, element.spring);
  element.damping      = entry.NonNegativeNumber("damping", 0.0);
  element.has_actuator = entry.Has("actuator");
  element.actuator     = entry.Number("actuator", 0.0);
  if (entry.Has("function") && !element.has_actuator)
    FailAt(entry.Required("function").Mark(), "'function' of " + entry.Description() + " scales 'actuator', which is missing");
  element.actuator_function = context.OptionalFunctionIndex(entry, "function");
  if (!element.spring.present && !entry.Has("damping") && !element.has_actuator)
    FailAt(entry.Mark(), entry.Description() + " needs a spring ('stiffness' or 'force_table'), 'damping' or 'actuator'");
}

void ReadSpringDamper(const MappingReader &entry, const ReaderContext &context, ForceElement &element)
{
  entry.RequireOnlyKeys({"name", "type", "nodes", "stiffness", "force_table", "free_length", "damping"});
  element.nodes         = ReadNodePair(entry, context);
  const double distance = (context.model.nodes[element.nodes[1]].position - context.model.nodes[element.nodes[0]].position).norm();
  if (!(distance > 0.0))
    FailAt(entry.Required("nodes").Mark(), "the nodes of " + entry.Description() + " are at the same place, so it has no direction; use a bushing");
  ReadSpringLaw(entry, "free_length", distance, element.spring);
  if (const YAML::Node *free = entry.Find("free_length"); free && !(element.spring.free_value > 0.0))
    FailAt(free->Mark(), "'free_length' of " + entry.Description() + " must be positive, got " + free->Scalar());
  element.damping = entry.NonNegativeNumber("damping", 0.0);
  if (!element.spring.present && !entry.Has("damping"))
    FailAt(entry.Mark(), entry.Description() + " needs a spring ('stiffness' or 'force_table') or 'damping'");
}

void ReadBushing(const MappingReader &entry, const ReaderContext &context, ForceElement &element)
{
  entry.RequireOnlyKeys({"name", "type", "nodes", "stiffness", "damping", "axis", "second_axis"});
  element.nodes = ReadNodePair(entry, context);
  if (!entry.Has("stiffness") && !entry.Has("damping")) FailAt(entry.Mark(), entry.Description() + " needs 'stiffness', 'damping' or both");
  if (const YAML::Node *value = entry.Find("stiffness")) element.bushing_stiffness = ReadBushingMatrix(*value, "stiffness", entry.Description());
  if (const YAML::Node *value = entry.Find("damping")) element.bushing_damping = ReadBushingMatrix(*value, "damping", entry.Description());
  Vec3 axis = Vec3::UnitX();
  if (const YAML::Node *value = entry.Find("axis")) {
    axis = ReadVec3(*value, "axis");
    if (const std::string problem = JointAxisProblem(axis); !problem.empty()) FailAt(value->Mark(), "'axis' of " + entry.Description() + " " + problem);
  }
  if (const YAML::Node *value = entry.Find("second_axis")) {
    const Vec3 second = ReadVec3(*value, "second_axis");
    if (const std::string problem = JointSecondAxisProblem(axis, second); !problem.empty())
      FailAt(value->Mark(), "'second_axis' of " + entry.Description() + " " + problem);
    element.axes = JointAxesFrom(axis, &second);
  } else {
    element.axes = entry.Has("axis") ? JointAxesFrom(axis, nullptr) : Mat3::Identity();
  }
}

} // namespace

void ReadForceElements(const YAML::Node *list, ReaderContext &context)
{
  Model                               &model = context.model;
  std::unordered_map<std::string, int> lines;
  for (const YAML::Node &item : ReadOptionalList(list, "force_elements")) {
    const MappingReader entry(item, "force element");
    ForceElement        element;
    element.number = static_cast<int>(model.force_elements.size());
    element.name   = entry.String("name");
    element.mark   = context.MarkOf(entry.Mark());
    if (const std::string problem = OutputNameProblem(element.name); !problem.empty())
      FailAt(entry.Required("name").Mark(),
             "force element name " + Quote(element.name) + " cannot begin the names of its history series <name>.force, ... in the result file: " + problem);
    if (const auto other = lines.find(element.name); other != lines.end())
      FailAt(entry.Required("name").Mark(),
             "duplicate force element name " + Quote(element.name) + " (first defined at line " + std::to_string(other->second) + ")");
    // Their history series are named after them, like the joints'.
    if (const auto joint = context.joint_names.find(element.name); joint != context.joint_names.end())
      FailAt(entry.Required("name").Mark(), "force element name " + Quote(element.name) + " is already the name of the joint at line " +
                                                std::to_string(model.joints[joint->second].mark.line) + "; their history series would mix");
    lines.emplace(element.name, element.mark.line);
    const std::string type = entry.String("type");
    if (type == "coordinate") {
      element.kind = ForceElement::Kind::Coordinate;
      ReadCoordinateElement(entry, context, element);
    } else if (type == "spring_damper") {
      element.kind = ForceElement::Kind::SpringDamper;
      ReadSpringDamper(entry, context, element);
    } else if (type == "bushing") {
      element.kind = ForceElement::Kind::Bushing;
      ReadBushing(entry, context, element);
    } else {
      FailAt(entry.Required("type").Mark(),
             "unknown force element type " + Quote(type) + " in " + entry.Description() + "; expected coordinate, spring_damper or bushing");
    }
    model.force_elements.push_back(std::move(element));
  }
}

} // namespace msflex::input_detail
