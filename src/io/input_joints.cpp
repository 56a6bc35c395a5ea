// Reading `joints`: master–slave joints between two nodes or between the ground and a node
// (docs/input.md, "joints"; the kinematics are in joints/joint_kinematics.hpp).
#include "io/input_reader_internal.hpp"

#include "joints/joint_kinematics.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace msflex::input_detail {

namespace {

constexpr double kTwoPi = 2.0 * M_PI;
// A `second_axis` v with |v x a1| < kParallelTolerance |v| is parallel to `axis`.
constexpr double kParallelTolerance = 1e-8;

// The released coordinates by name: translations along, and rotations about, the joint axes a1 a2 a3.
const std::array<const char *, 6> kCoordinateNames{{"tx", "ty", "tz", "rx", "ry", "rz"}};

std::string JoinWords(const std::vector<std::string> &words)
{
  std::string joined;
  for (const std::string &word : words) joined += (joined.empty() ? "" : ", ") + word;
  return joined;
}

// Axes a1 (`axis`), a2 (from `second_axis`) and a3 = a1 x a2 as the columns of a rotation matrix.
Mat3 ReadJointAxes(const MappingReader &entry)
{
  Vec3 axis = Vec3::UnitX();
  if (const YAML::Node *value = entry.Find("axis")) {
    axis = ReadVec3(*value, "axis");
    if (const std::string problem = JointAxisProblem(axis); !problem.empty()) FailAt(value->Mark(), "'axis' of " + entry.Description() + " " + problem);
  }
  const YAML::Node *value = entry.Find("second_axis");
  if (value == nullptr) return JointAxesFrom(axis, nullptr);
  const Vec3 second_axis = ReadVec3(*value, "second_axis");
  if (const std::string problem = JointSecondAxisProblem(axis, second_axis); !problem.empty())
    FailAt(value->Mark(),
           "'second_axis' " + (second_axis.stableNorm() == 0.0 ? std::string() : FormatVec3(second_axis) + " ") + "of " + entry.Description() + " " + problem);
  return JointAxesFrom(axis, &second_axis);
}

// Releases translations along the listed axes (in that order) and rotations about the listed axes:
// none, one (OneAxis), two (TwoAxes, in the order given) or three (Free).
void SetRelease(Joint &joint, const std::vector<int> &translations, const std::vector<int> &rotations)
{
  joint.num_translations = static_cast<int>(translations.size());
  for (size_t k = 0; k < translations.size(); ++k) joint.translation_axis[k] = translations[k];
  static const Joint::Rotation kinds[] = {Joint::Rotation::None, Joint::Rotation::OneAxis, Joint::Rotation::TwoAxes, Joint::Rotation::Free};
  joint.rotation                       = kinds[rotations.size()];
  if (rotations.size() == 1 || rotations.size() == 2)
    for (size_t k = 0; k < rotations.size(); ++k) joint.rotation_axis[k] = rotations[k];
}

// `release` of a custom joint: a non-empty list of distinct coordinate names.
void ReadCustomRelease(const YAML::Node &value, const MappingReader &entry, Joint &joint)
{
  std::array<bool, 6> released{};
  std::vector<int>    rotations;
  for (const YAML::Node &item : ReadNonEmptyList(value, "release")) {
    const std::string name  = ReadString(item, "release");
    int               index = -1;
    for (int coordinate = 0; coordinate < 6; ++coordinate)
      if (name == kCoordinateNames[coordinate]) index = coordinate;
    if (index < 0)
      FailAt(item.Mark(), "unknown coordinate " + Quote(name) + " in 'release' of " + entry.Description() +
                              "; expected tx, ty, tz (translations along the joint axes) or rx, ry, rz (rotations about them)");
    if (released[index]) FailAt(item.Mark(), "'release' of " + entry.Description() + " lists " + Quote(name) + " twice");
    released[index] = true;
    if (index >= 3) rotations.push_back(index - 3);
  }
  std::vector<int> translations;
  for (int axis = 0; axis < 3; ++axis)
    if (released[axis]) translations.push_back(axis);
  SetRelease(joint, translations, rotations);
}

double ReadNonZeroNumber(const MappingReader &entry, const std::string &key)
{
  const double number = entry.Number(key);
  if (number == 0.0) FailAt(entry.Required(key).Mark(), Quote(key) + " of " + entry.Description() + " must not be zero");
  // A subnormal pitch (1e-320) passed as non-zero and the run began with kinetic energy NaN.
  if (std::fpclassify(number) == FP_SUBNORMAL)
    FailAt(entry.Required(key).Mark(), Quote(key) + " of " + entry.Description() + " is too close to zero to compute with (a subnormal number)");
  return number;
}

// `profile` of a cam_table joint: a periodic cubic spline through [phi, lift] points.
void ReadProfile(const YAML::Node &value, const MappingReader &joint_entry, Joint &joint)
{
  const std::string   where = "the 'profile' of " + joint_entry.Description();
  const MappingReader entry(value, where, {"period", "points"});
  joint.profile_period     = entry.PositiveNumber("period", kTwoPi);
  const YAML::Node &points = entry.Required("points");
  const auto        items  = ReadNonEmptyList(points, "points");
  if (items.size() < 3) FailAt(points.Mark(), "'points' of " + where + " needs at least 3 [phi, lift] pairs, got " + std::to_string(items.size()));
  for (const YAML::Node &point : items) {
    if (!point.IsSequence() || point.size() != 2) FailAt(point.Mark(), "expected a [phi, lift] pair in 'points' of " + where + ", got " + DescribeValue(point));
    const double phi = ReadNumber(point[0], "points");
    if (!joint.profile_knots.empty() && !(phi > joint.profile_knots.back()))
      FailAt(point[0].Mark(), "angles in 'points' of " + where + " must be strictly increasing, got " + point[0].Scalar() + " after " +
                                  FormatNumber(joint.profile_knots.back()));
    joint.profile_knots.push_back(phi);
    joint.profile_values.push_back(ReadNumber(point[1], "points"));
  }
  const double first = joint.profile_knots.front(), last = joint.profile_knots.back();
  if (!(last < first + joint.profile_period))
    FailAt(items.back()[0].Mark(), "the last angle in 'points' of " + where + " (" + items.back()[0].Scalar() + ") must be less than the first (" +
                                       FormatNumber(first) + ") plus the period (" + FormatNumber(joint.profile_period) + ")");
  joint.profile_second.assign(joint.profile_knots.size(), 0.0);
  if (!PeriodicSplineSecondDerivatives(joint.profile_period, static_cast<int>(joint.profile_knots.size()), joint.profile_knots.data(),
                                       joint.profile_values.data(), joint.profile_second.data()))
    FailAt(ValueMark(value), "cannot fit a periodic spline through the 'points' of " + where);
}

// Everything a joint kind fixes: releases, dependent translation and the keys it allows.
void ReadRelease(const std::string &type, const MappingReader &entry, Joint &joint)
{
  const JointKindInfo *info = JointKindFind(type);
  if (!info)
    FailAt(entry.Required("type").Mark(), "unknown joint type " + Quote(type) + " in " + entry.Description() + "; expected one of " + JointKindNameList());
  // The keys every joint may have, plus the one of its kind; keys of other kinds are errors.
  static const char *const  kParameterKeys[] = {nullptr, "pitch", "radius", "release", "profile"};
  std::vector<const char *> keys{"name", "type", "master", "slave", "axis", "second_axis", "drive"};
  if (const char *parameter_key = kParameterKeys[static_cast<int>(info->parameter)]) keys.push_back(parameter_key);
  entry.RequireOnlyKeys(keys);
  switch (info->parameter) {
  case JointParameter::None:
    ApplyJointKind(*info, 0.0, joint);
    break;
  case JointParameter::Pitch:
    ApplyJointKind(*info, ReadNonZeroNumber(entry, "pitch"), joint);
    break;
  case JointParameter::Radius:
    ApplyJointKind(*info, info->kind == JointKind::Cam ? entry.PositiveNumber("radius") : ReadNonZeroNumber(entry, "radius"), joint);
    break;
  case JointParameter::Release:
    ApplyJointKind(*info, 0.0, joint);
    ReadCustomRelease(entry.Required("release"), entry, joint);
    break;
  case JointParameter::Profile:
    ApplyJointKind(*info, 0.0, joint);
    ReadProfile(entry.Required("profile"), entry, joint);
    break;
  }
}

// Names of the coordinates a drive may prescribe, in coordinate order (a free rotation has none).
std::vector<std::string> DrivableCoordinates(const Joint &joint)
{
  std::vector<std::string> names;
  for (int k = 0; k < joint.num_translations; ++k) names.push_back(kCoordinateNames[joint.translation_axis[k]]);
  if (joint.rotation == Joint::Rotation::OneAxis || joint.rotation == Joint::Rotation::TwoAxes)
    for (int k = 0; k < (joint.rotation == Joint::Rotation::OneAxis ? 1 : 2); ++k) names.push_back(kCoordinateNames[3 + joint.rotation_axis[k]]);
  return names;
}

void ReadDrive(const YAML::Node &value, const MappingReader &joint_entry, const ReaderContext &context, Joint &joint)
{
  const MappingReader            entry(value, "the 'drive' of " + joint_entry.Description(), {"coordinate", "value", "rate", "function"});
  const YAML::Node              &coordinate_node = entry.Required("coordinate");
  const std::string              coordinate      = ReadString(coordinate_node, "coordinate");
  const std::vector<std::string> names           = DrivableCoordinates(joint);
  std::vector<std::string>       choices         = names;
  if (joint.rotation == Joint::Rotation::OneAxis) choices.push_back("rotation");
  // The dependent translation also by the name its history series has (<joint>.tx for a screw along
  // its first axis), where that name is no released coordinate of its own.
  const std::string dependent_name =
      joint.dependence == Joint::Dependence::Linear && std::find(names.begin(), names.end(), kCoordinateNames[joint.dependent_axis]) == names.end()
          ? kCoordinateNames[joint.dependent_axis]
          : "";
  if (joint.dependence == Joint::Dependence::Linear) choices.push_back(dependent_name.empty() ? "translation" : "translation (or " + dependent_name + ")");
  const std::string joint_kind = joint_entry.Description() + " (" + JointKindName(joint.kind) + ")";
  const std::string hint =
      choices.empty() ? joint_kind + " has no coordinate that can be driven" : "the coordinates of " + joint_kind + " are " + JoinWords(choices);
  double scale = 1.0;
  int    index = -1;
  if (coordinate == "rotation") {
    if (joint.rotation != Joint::Rotation::OneAxis)
      FailAt(coordinate_node.Mark(), "'rotation' drives the single rotation of a one-axis joint, but " + joint_kind + " has none; " + hint);
    index = joint.num_translations;
  } else if (coordinate == "translation" || (!dependent_name.empty() && coordinate == dependent_name)) {
    if (joint.dependence != Joint::Dependence::Linear)
      FailAt(coordinate_node.Mark(),
             "'translation' drives the dependent translation of a screw or rack_pinion joint, but " + joint_kind + " is neither; " + hint);
    // The translation is coefficient * phi, so the rotation is driven with value / coefficient.
    index                        = joint.num_translations;
    scale                        = 1.0 / joint.coefficient;
    joint.drive_coordinate_scale = joint.coefficient;
    joint.drive_by_translation   = true;
  } else {
    for (size_t k = 0; k < names.size(); ++k)
      if (names[k] == coordinate) index = static_cast<int>(k);
    if (index < 0) {
      const bool rotation_name = coordinate == "rx" || coordinate == "ry" || coordinate == "rz";
      if (rotation_name && joint.rotation == Joint::Rotation::Free)
        FailAt(coordinate_node.Mark(),
               "the free rotation of " + joint_kind + " cannot be driven (" + Quote(coordinate) + "); drive a joint with one or two rotation axes instead");
      FailAt(coordinate_node.Mark(), "coordinate " + Quote(coordinate) + " in 'drive' is not released by " + joint_kind + "; " + hint);
    }
  }
  joint.driven_coordinate = index;
  // `value`: q(t) = value f(t); `rate`: q'(t) = rate f(t) from q(0) = 0.
  const bool has_value = entry.Has("value"), has_rate = entry.Has("rate");
  if (has_value == has_rate)
    FailAt(entry.Mark(), entry.Description() + " needs exactly one of 'value' (the coordinate is value f(t)) and 'rate' (its rate is rate f(t))" +
                             (has_value ? ", not both" : ""));
  joint.drive_by_rate  = has_rate;
  joint.drive_value    = entry.Number(has_rate ? "rate" : "value") * scale;
  joint.drive_function = context.OptionalFunctionIndex(entry, "function");
}

// The node named by `key` (`master` may also be the ground: -1).
int ReadJointNode(const MappingReader &entry, const std::string &key, const ReaderContext &context)
{
  const YAML::Node &value = entry.Required(key);
  const std::string name  = ReadString(value, key);
  if (name != kGround) return context.NodeIndex(entry, key);
  if (key != "master")
    FailAt(ValueMark(value), "the ground cannot be the " + key + " of " + entry.Description() + "; use 'master: ground' and make the node the slave");
  if (context.names.count(kGround) > 0)
    FailAt(ValueMark(value),
           "'master: ground' of " + entry.Description() + " means the fixed ground, but a node, beam or set is also called " + Quote(kGround) + "; rename it");
  return -1;
}

Joint ReadJoint(const YAML::Node &item, const ReaderContext &context)
{
  const MappingReader entry(item, "joint");
  Joint               joint;
  joint.name = entry.String("name");
  joint.mark = context.MarkOf(entry.Mark());
  if (const std::string problem = JointNameProblem(joint.name); !problem.empty()) FailAt(entry.Required("name").Mark(), problem);
  if (const auto other = context.joint_names.find(joint.name); other != context.joint_names.end())
    FailAt(entry.Required("name").Mark(),
           "duplicate joint name " + Quote(joint.name) + " (first defined at line " + std::to_string(context.model.joints[other->second].mark.line) + ")");
  ReadRelease(entry.String("type"), entry, joint);
  joint.master = ReadJointNode(entry, "master", context);
  joint.slave  = ReadJointNode(entry, "slave", context);
  if (joint.master == joint.slave)
    FailAt(entry.Required("slave").Mark(),
           "the slave of " + entry.Description() + " is its master " + Quote(context.model.nodes[joint.slave].name) + "; a joint needs two different nodes");
  bool at_slave = false;
  if (const std::string problem = JointTreeProblem(joint, context, &at_slave); !problem.empty())
    FailAt(at_slave ? entry.Required("slave").Mark() : entry.Mark(), problem);
  joint.axes = ReadJointAxes(entry);
  if (const YAML::Node *drive = entry.Find("drive")) ReadDrive(*drive, entry, context, joint);
  return joint;
}

} // namespace

std::string JointNameProblem(const std::string &name)
{
  const std::string problem = OutputNameProblem(name);
  if (problem.empty()) return "";
  return "joint name " + Quote(name) + " cannot begin the names of its history series <name>.tx, ... in the result file: " + problem;
}

std::string JointParameterProblem(JointKind kind, double parameter)
{
  if (!std::isfinite(parameter)) return "must be a finite number";
  if ((kind == JointKind::Screw || kind == JointKind::RackPinion) && parameter == 0.0) return "must not be zero";
  if (std::fpclassify(parameter) == FP_SUBNORMAL) return "is too close to zero to compute with (a subnormal number)";
  if (kind == JointKind::Cam && !(parameter > 0.0)) return "must be positive";
  return "";
}

void ApplyJointKind(const JointKindInfo &info, double parameter, Joint &joint)
{
  joint.kind = info.kind;
  std::vector<int> rotations;
  for (int k = 0; k < info.num_rotations; ++k) rotations.push_back(info.num_rotations == 3 ? k : info.rotation_axes[k]);
  SetRelease(joint, std::vector<int>(info.translation_axes, info.translation_axes + info.num_translations), rotations);
  joint.dependence     = info.dependence;
  joint.dependent_axis = info.dependent_axis;
  joint.coefficient    = info.dependence == JointDependence::None || info.dependence == JointDependence::Table ? 0.0 : parameter;
}

std::string JointAxisProblem(const Vec3 &axis) { return axis.stableNorm() == 0.0 ? "must not be the zero vector" : ""; }

std::string JointSecondAxisProblem(const Vec3 &axis, const Vec3 &second_axis)
{
  const double length = second_axis.stableNorm();
  if (length == 0.0) return "must not be the zero vector";
  const Vec3 a1 = axis / axis.stableNorm();
  if ((second_axis / length).cross(a1).norm() < kParallelTolerance) return "is parallel to its axis " + FormatVec3(a1) + "; it must point across it";
  return "";
}

Mat3 JointAxesFrom(const Vec3 &axis, const Vec3 *second_axis)
{
  const Vec3 a1 = axis / axis.stableNorm();
  Vec3       reference;
  if (second_axis != nullptr) {
    reference = *second_axis / second_axis->stableNorm();
  } else {
    // The global axis least aligned with a1 (the first of equals).
    int least = 0;
    for (int index = 1; index < 3; ++index)
      if (std::abs(a1(index)) < std::abs(a1(least))) least = index;
    reference = Vec3::Unit(least);
  }
  const Vec3 a2 = (reference - reference.dot(a1) * a1).normalized();
  Mat3       axes;
  axes.col(0) = a1;
  axes.col(1) = a2;
  axes.col(2) = a1.cross(a2);
  return axes;
}

// Every node is the slave of at most one joint, and following masters never leads back to the
// slave: the joints form a forest whose roots are the ground and nodes that are no slave. The new
// joint's slave is no slave yet, so it is the top of its own chain, and the joint closes a cycle
// exactly when its master's chain leads up to it: one ChainTop look-up, not a walk up the chain,
// so that reading a chain of N joints takes time linear in N.
std::string JointTreeProblem(const Joint &joint, const ReaderContext &context, bool *at_slave)
{
  const Model &model = context.model;
  *at_slave          = true;
  if (const int first = context.JointOfSlave(joint.slave); first >= 0) {
    // Joints of a mesh file share the mark of its key: no line of their own to name.
    const SourceMark &where = model.joints[first].mark;
    const bool        mesh  = where.line == joint.mark.line && where.column == joint.mark.column && where.file == joint.mark.file;
    return "node " + Quote(model.nodes[joint.slave].name) + " is already the slave of joint " + Quote(model.joints[first].name) +
           (mesh ? std::string(" of the mesh file") : " at line " + std::to_string(where.line)) + "; a node can be the slave of only one joint";
  }
  *at_slave = false;
  if (joint.master < 0 || context.ChainTop(joint.master) != joint.slave) return "";
  // A cycle: name its joints, from the slave's joint down to the new one (the walk happens once).
  std::vector<std::string> chain;
  for (int node = joint.master; node != joint.slave;) {
    const int parent = context.JointOfSlave(node);
    chain.push_back(Quote(model.joints[parent].name));
    node = model.joints[parent].master;
  }
  std::reverse(chain.begin(), chain.end());
  chain.push_back(Quote(joint.name));
  return "joint " + Quote(joint.name) + " closes a cycle of master-slave joints: " + JoinWords(chain) + " lead from node " +
         Quote(model.nodes[joint.slave].name) + " back to itself";
}

int NamedJointCoordinate(const Joint &joint, const YAML::Node &value, const std::string &where)
{
  const std::string              coordinate = ReadString(value, "coordinate");
  const std::vector<std::string> names      = DrivableCoordinates(joint);
  std::vector<std::string>       choices    = names;
  if (joint.rotation == Joint::Rotation::OneAxis) choices.push_back("rotation");
  const std::string joint_kind = "joint " + Quote(joint.name) + " (" + JointKindName(joint.kind) + ")";
  if (coordinate == "rotation" && joint.rotation == Joint::Rotation::OneAxis) return joint.num_translations;
  for (size_t k = 0; k < names.size(); ++k)
    if (names[k] == coordinate) return static_cast<int>(k);
  const bool rotation_name = coordinate == "rx" || coordinate == "ry" || coordinate == "rz";
  if (rotation_name && joint.rotation == Joint::Rotation::Free)
    FailAt(ValueMark(value), "the free rotation of " + joint_kind + " has no angle " + Quote(coordinate) + " for " + where +
                                 "; use a bushing between its master and slave, or a joint with one or two rotation axes");
  FailAt(ValueMark(value), "coordinate " + Quote(coordinate) + " of " + where + " is not released by " + joint_kind + "; " +
                               (choices.empty() ? "it has no coordinate with a name" : "its coordinates are " + JoinWords(choices)));
}

void AppendJoint(Joint joint, ReaderContext &context)
{
  Model    &model                     = context.model;
  const int index                     = static_cast<int>(model.joints.size());
  context.joint_of_slave[joint.slave] = index;
  context.joint_names.emplace(joint.name, index);
  context.LinkChain(joint.slave, joint.master);
  model.joints.push_back(std::move(joint));
}

void ReadJoints(const YAML::Node *list, ReaderContext &context)
{
  for (const YAML::Node &item : ReadOptionalList(list, "joints")) AppendJoint(ReadJoint(item, context), context);
}

} // namespace msflex::input_detail
