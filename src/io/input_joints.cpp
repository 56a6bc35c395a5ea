// Reading `joints`: master–slave joints between two nodes or between the ground and a node
// (docs/input.md, "joints"; the kinematics are in joints/joint_kinematics.hpp).
#include "io/input_reader_internal.hpp"

#include "joints/joint_kinematics.hpp"

#include <Eigen/Geometry>

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

const char *const kJointTypes = "rigid, spherical, revolute, universal, cylindrical, prismatic, planar, free, custom, screw, "
                                "rack_pinion, cam, cam_table";

std::string JoinWords(const std::vector<std::string> &words)
{
  std::string joined;
  for (const std::string &word : words) joined += (joined.empty() ? "" : ", ") + word;
  return joined;
}

// Axes a1 (`axis`), a2 (from `second_axis`) and a3 = a1 x a2 as the columns of a rotation matrix.
Mat3 ReadJointAxes(const MappingReader &entry)
{
  Vec3 a1 = Vec3::UnitX();
  if (const YAML::Node *value = entry.Find("axis")) {
    a1                  = ReadVec3(*value, "axis");
    const double length = a1.stableNorm();
    if (length == 0.0) FailAt(value->Mark(), "'axis' of " + entry.Description() + " must not be the zero vector");
    a1 /= length;
  }
  Vec3 reference;
  if (const YAML::Node *value = entry.Find("second_axis")) {
    const Vec3   given  = ReadVec3(*value, "second_axis");
    const double length = given.stableNorm();
    if (length == 0.0) FailAt(value->Mark(), "'second_axis' of " + entry.Description() + " must not be the zero vector");
    reference = given / length;
    if (reference.cross(a1).norm() < kParallelTolerance)
      FailAt(value->Mark(), "'second_axis' " + FormatVec3(given) + " of " + entry.Description() + " is parallel to its axis " +
                                FormatVec3(a1) + "; it must point across it");
  } else {
    // The global axis least aligned with a1 (the first of equals).
    int least = 0;
    for (int axis = 1; axis < 3; ++axis)
      if (std::abs(a1(axis)) < std::abs(a1(least))) least = axis;
    reference = Vec3::Unit(least);
  }
  const Vec3 a2 = (reference - reference.dot(a1) * a1).normalized();
  Mat3       axes;
  axes.col(0) = a1;
  axes.col(1) = a2;
  axes.col(2) = a1.cross(a2);
  return axes;
}

// Releases translations along the listed axes (in that order) and rotations about the listed axes:
// none, one (OneAxis), two (TwoAxes, in the order given) or three (Free).
void SetRelease(Joint &joint, const std::vector<int> &translations, const std::vector<int> &rotations)
{
  joint.num_translations = static_cast<int>(translations.size());
  for (size_t k = 0; k < translations.size(); ++k) joint.translation_axis[k] = translations[k];
  static const Joint::Rotation kinds[] = {Joint::Rotation::None, Joint::Rotation::OneAxis, Joint::Rotation::TwoAxes,
                                          Joint::Rotation::Free};
  joint.rotation = kinds[rotations.size()];
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
  return number;
}

// `profile` of a cam_table joint: a periodic cubic spline through [phi, lift] points.
void ReadProfile(const YAML::Node &value, const MappingReader &joint_entry, Joint &joint)
{
  const std::string   where = "the 'profile' of " + joint_entry.Description();
  const MappingReader entry(value, where, {"period", "points"});
  joint.profile_period    = entry.PositiveNumber("period", kTwoPi);
  const YAML::Node &points = entry.Required("points");
  const auto        items  = ReadNonEmptyList(points, "points");
  if (items.size() < 3)
    FailAt(points.Mark(), "'points' of " + where + " needs at least 3 [phi, lift] pairs, got " + std::to_string(items.size()));
  for (const YAML::Node &point : items) {
    if (!point.IsSequence() || point.size() != 2)
      FailAt(point.Mark(), "expected a [phi, lift] pair in 'points' of " + where + ", got " + DescribeValue(point));
    const double phi = ReadNumber(point[0], "points");
    if (!joint.profile_knots.empty() && !(phi > joint.profile_knots.back()))
      FailAt(point[0].Mark(), "angles in 'points' of " + where + " must be strictly increasing, got " + point[0].Scalar() + " after " +
                                  FormatNumber(joint.profile_knots.back()));
    joint.profile_knots.push_back(phi);
    joint.profile_values.push_back(ReadNumber(point[1], "points"));
  }
  const double first = joint.profile_knots.front(), last = joint.profile_knots.back();
  if (!(last < first + joint.profile_period))
    FailAt(items.back()[0].Mark(), "the last angle in 'points' of " + where + " (" + items.back()[0].Scalar() +
                                       ") must be less than the first (" + FormatNumber(first) + ") plus the period (" +
                                       FormatNumber(joint.profile_period) + ")");
  joint.profile_second.assign(joint.profile_knots.size(), 0.0);
  if (!PeriodicSplineSecondDerivatives(joint.profile_period, static_cast<int>(joint.profile_knots.size()), joint.profile_knots.data(),
                                       joint.profile_values.data(), joint.profile_second.data()))
    FailAt(value.Mark(), "cannot fit a periodic spline through the 'points' of " + where);
}

// Everything a joint type fixes: releases, dependent translation and the keys it allows.
void ReadRelease(const std::string &type, const MappingReader &entry, Joint &joint)
{
  // The keys every joint may have, plus the one of its type; keys of other types are errors.
  const auto allow_keys = [&entry](const char *type_key) {
    std::vector<const char *> keys{"name", "type", "master", "slave", "axis", "second_axis", "drive"};
    if (type_key != nullptr) keys.push_back(type_key);
    entry.RequireOnlyKeys(keys);
  };
  if (type == "rigid") {
    allow_keys(nullptr);
  } else if (type == "spherical") {
    allow_keys(nullptr);
    SetRelease(joint, {}, {0, 1, 2});
  } else if (type == "revolute") {
    allow_keys(nullptr);
    SetRelease(joint, {}, {0});
  } else if (type == "universal") {
    allow_keys(nullptr);
    SetRelease(joint, {}, {0, 1});
  } else if (type == "cylindrical") {
    allow_keys(nullptr);
    SetRelease(joint, {0}, {0});
  } else if (type == "prismatic") {
    allow_keys(nullptr);
    SetRelease(joint, {0}, {});
  } else if (type == "planar") {
    allow_keys(nullptr);
    SetRelease(joint, {1, 2}, {0});
  } else if (type == "free") {
    allow_keys(nullptr);
    SetRelease(joint, {0, 1, 2}, {0, 1, 2});
  } else if (type == "custom") {
    allow_keys("release");
    ReadCustomRelease(entry.Required("release"), entry, joint);
  } else if (type == "screw") {
    allow_keys("pitch");
    SetRelease(joint, {}, {0});
    joint.dependence     = Joint::Dependence::Linear;
    joint.dependent_axis = 0;
    joint.coefficient    = ReadNonZeroNumber(entry, "pitch");
  } else if (type == "rack_pinion") {
    allow_keys("radius");
    SetRelease(joint, {}, {0});
    joint.dependence     = Joint::Dependence::Linear;
    joint.dependent_axis = 1;
    joint.coefficient    = ReadNonZeroNumber(entry, "radius");
  } else if (type == "cam") {
    allow_keys("radius");
    SetRelease(joint, {}, {0});
    joint.dependence     = Joint::Dependence::EccentricCam;
    joint.dependent_axis = 1;
    joint.coefficient    = entry.PositiveNumber("radius");
  } else if (type == "cam_table") {
    allow_keys("profile");
    SetRelease(joint, {}, {0});
    joint.dependence     = Joint::Dependence::Table;
    joint.dependent_axis = 1;
    ReadProfile(entry.Required("profile"), entry, joint);
  } else {
    FailAt(entry.Required("type").Mark(), "unknown joint type " + Quote(type) + " in " + entry.Description() + "; expected one of " +
                                              kJointTypes);
  }
}

// Names of the coordinates a drive may prescribe, in coordinate order (a free rotation has none).
std::vector<std::string> DrivableCoordinates(const Joint &joint)
{
  std::vector<std::string> names;
  for (int k = 0; k < joint.num_translations; ++k) names.push_back(kCoordinateNames[joint.translation_axis[k]]);
  if (joint.rotation == Joint::Rotation::OneAxis || joint.rotation == Joint::Rotation::TwoAxes)
    for (int k = 0; k < (joint.rotation == Joint::Rotation::OneAxis ? 1 : 2); ++k)
      names.push_back(kCoordinateNames[3 + joint.rotation_axis[k]]);
  return names;
}

void ReadDrive(const YAML::Node &value, const MappingReader &joint_entry, const ReaderContext &context, Joint &joint)
{
  const MappingReader entry(value, "the 'drive' of " + joint_entry.Description(), {"coordinate", "value", "function"});
  const YAML::Node   &coordinate_node = entry.Required("coordinate");
  const std::string   coordinate      = ReadString(coordinate_node, "coordinate");
  const std::vector<std::string> names = DrivableCoordinates(joint);
  std::vector<std::string>       choices = names;
  if (joint.rotation == Joint::Rotation::OneAxis) choices.push_back("rotation");
  if (joint.dependence == Joint::Dependence::Linear) choices.push_back("translation");
  const std::string joint_kind = joint_entry.Description() + " (" + joint.type + ")";
  const std::string hint       = choices.empty() ? joint_kind + " has no coordinate that can be driven"
                                                  : "the coordinates of " + joint_kind + " are " + JoinWords(choices);
  double scale = 1.0;
  int    index = -1;
  if (coordinate == "rotation") {
    if (joint.rotation != Joint::Rotation::OneAxis)
      FailAt(coordinate_node.Mark(), "'rotation' drives the single rotation of a one-axis joint, but " + joint_kind +
                                         " has none; " + hint);
    index = joint.num_translations;
  } else if (coordinate == "translation") {
    if (joint.dependence != Joint::Dependence::Linear)
      FailAt(coordinate_node.Mark(), "'translation' drives the dependent translation of a screw or rack_pinion joint, but " + joint_kind +
                                         " is neither; " + hint);
    // The translation is coefficient * phi, so the rotation is driven with value / coefficient.
    index = joint.num_translations;
    scale = 1.0 / joint.coefficient;
  } else {
    for (size_t k = 0; k < names.size(); ++k)
      if (names[k] == coordinate) index = static_cast<int>(k);
    if (index < 0) {
      const bool rotation_name = coordinate == "rx" || coordinate == "ry" || coordinate == "rz";
      if (rotation_name && joint.rotation == Joint::Rotation::Free)
        FailAt(coordinate_node.Mark(), "the free rotation of " + joint_kind + " cannot be driven (" + Quote(coordinate) +
                                           "); drive a joint with one or two rotation axes instead");
      FailAt(coordinate_node.Mark(), "coordinate " + Quote(coordinate) + " in 'drive' is not released by " + joint_kind + "; " + hint);
    }
  }
  joint.driven_coordinate = index;
  joint.drive_value       = entry.Number("value") * scale;
  joint.drive_function    = context.OptionalFunctionIndex(entry, "function");
}

// The node named by `key` (`master` may also be the ground: -1).
int ReadJointNode(const MappingReader &entry, const std::string &key, const ReaderContext &context)
{
  const YAML::Node &value = entry.Required(key);
  const std::string name  = ReadString(value, key);
  if (name != kGround) return context.NodeIndex(entry, key);
  if (key != "master")
    FailAt(value.Mark(),
           "the ground cannot be the " + key + " of " + entry.Description() + "; use 'master: ground' and make the node the slave");
  if (context.names.count(kGround) > 0)
    FailAt(value.Mark(), "'master: ground' of " + entry.Description() + " means the fixed ground, but a node, beam or set is also called " +
                             Quote(kGround) + "; rename it");
  return -1;
}

// Every node is the slave of at most one joint, and following masters never leads back to the
// slave: the joints form a forest whose roots are the ground and nodes that are no slave.
void CheckJointTree(const MappingReader &entry, const Joint &joint, const ReaderContext &context)
{
  const Model &model = context.model;
  if (const int first = context.JointOfSlave(joint.slave); first >= 0)
    FailAt(entry.Required("slave").Mark(), "node " + Quote(model.nodes[joint.slave].name) + " is already the slave of joint " +
                                               Quote(model.joints[first].name) + " at line " +
                                               std::to_string(model.joints[first].mark.line) + "; a node can be the slave of only one joint");
  std::vector<std::string> chain;
  for (int node = joint.master; node >= 0;) {
    const int parent = context.JointOfSlave(node);
    if (parent < 0) break;
    chain.insert(chain.begin(), Quote(model.joints[parent].name));
    node = model.joints[parent].master;
    if (node == joint.slave) {
      chain.push_back(Quote(joint.name));
      FailAt(entry.Mark(), "joint " + Quote(joint.name) + " closes a cycle of master-slave joints: " + JoinWords(chain) +
                               " lead from node " + Quote(model.nodes[joint.slave].name) + " back to itself");
    }
  }
}

Joint ReadJoint(const YAML::Node &item, const ReaderContext &context)
{
  const MappingReader entry(item, "joint");
  Joint               joint;
  joint.name = entry.String("name");
  joint.mark = context.MarkOf(entry.Mark());
  for (const Joint &other : context.model.joints)
    if (other.name == joint.name)
      FailAt(entry.Required("name").Mark(),
             "duplicate joint name " + Quote(joint.name) + " (first defined at line " + std::to_string(other.mark.line) + ")");
  joint.type = entry.String("type");
  ReadRelease(joint.type, entry, joint);
  joint.master = ReadJointNode(entry, "master", context);
  joint.slave  = ReadJointNode(entry, "slave", context);
  if (joint.master == joint.slave)
    FailAt(entry.Required("slave").Mark(), "the slave of " + entry.Description() + " is its master " +
                                               Quote(context.model.nodes[joint.slave].name) + "; a joint needs two different nodes");
  CheckJointTree(entry, joint, context);
  joint.axes = ReadJointAxes(entry);
  if (const YAML::Node *drive = entry.Find("drive")) ReadDrive(*drive, entry, context, joint);
  return joint;
}

} // namespace

void ReadJoints(const YAML::Node *list, ReaderContext &context)
{
  Model &model = context.model;
  context.joint_of_slave.assign(model.nodes.size(), -1);
  for (const YAML::Node &item : ReadOptionalList(list, "joints")) {
    Joint joint = ReadJoint(item, context);
    context.joint_of_slave[joint.slave] = static_cast<int>(model.joints.size());
    model.joints.push_back(std::move(joint));
  }
}

} // namespace msflex::input_detail
