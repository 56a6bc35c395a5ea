// State shared by the parts of the input reader (private to src/io/).
#pragma once

#include "io/input_yaml_util.hpp"
#include "model/model.hpp"

#include <string>
#include <unordered_map>
#include <vector>

namespace msflex::input_detail {

// Nodes, beams and sets share one namespace, so a name in `supports`, `loads` or `sets` is never
// ambiguous.
enum class NameKind { Node, Beam, Set };

// In a list of node, set or beam names (`nodes` of supports, loads and initial conditions) this
// word selects every node, so it cannot name a node, beam or set.
inline constexpr const char *kAllNodes = "all";

// In `master` of a joint this word means the fixed ground instead of a node.
inline constexpr const char *kGround = "ground";

struct NamedObject {
  NameKind kind  = NameKind::Node;
  int      index = -1; // into Model::nodes, Model::beams or Model::node_sets
  int      line  = 0;
};

struct ReaderContext {
  Model                                        model;
  std::unordered_map<std::string, NamedObject> names;
  // Per node: index into Model::joints of the joint whose slave it is, or -1 (filled by ReadJoints).
  std::vector<int> joint_of_slave;

  int JointOfSlave(int node) const
  {
    return node >= 0 && static_cast<size_t>(node) < joint_of_slave.size() ? joint_of_slave[node] : -1;
  }

  SourceMark MarkOf(const YAML::Mark &mark) const;
  // Adds a node, beam or set name; a name used twice, or the reserved word `all`, is an error at `mark`.
  void RegisterName(const std::string &name, NameKind kind, int index, const SourceMark &mark);
  // Index of the node / section / function named by `key` of `entry`; an unknown name is an error.
  int NodeIndex(const MappingReader &entry, const std::string &key) const;
  int SectionIndex(const MappingReader &entry, const std::string &key) const;
  // -1 (the default ramp f(t) = t) when `key` is absent.
  int OptionalFunctionIndex(const MappingReader &entry, const std::string &key) const;
  // The nodes of a node, set or beam name or of a list of such names (`all`: every node, in index
  // order): deduplicated, first seen first.
  std::vector<int> ResolveNodes(const YAML::Node &value, const std::string &key) const;
};

// Reads `beams` and expands every beam (line or arc) into nodes and elements (input_beams.cpp).
void ReadBeams(const YAML::Node &beams, ReaderContext &context);

// Reads the items of `rigid_bodies` into Model::rigid_bodies (input_dynamics.cpp). Needs the nodes,
// including those generated inside beams.
void ReadRigidBodies(const std::vector<YAML::Node> &items, ReaderContext &context);

// Reads `initial_conditions` into Model::initial_conditions; a node given an initial condition by
// two entries is an error (input_dynamics.cpp). Needs the nodes, beams and sets.
void ReadInitialConditions(const YAML::Node *list, ReaderContext &context);

// Reads `joints` into Model::joints and fills ReaderContext::joint_of_slave (input_joints.cpp).
// Needs the nodes (including generated ones) and the functions; checks names, axes, releases,
// drives, that every node is the slave of at most one joint and that the joints form no cycle.
void ReadJoints(const YAML::Node *list, ReaderContext &context);

// Fails when a connected group of beams, or of rigid bodies outside every beam, is not held against
// all six rigid-body motions by its supports and its joints to the ground, which would make the
// static stiffness matrix singular; elements and joints between nodes connect groups
// (input_mechanism_check.cpp). Called for static analyses only.
void CheckStaticMechanisms(const Model &model);

} // namespace msflex::input_detail
