// State shared by the parts of the input reader (private to src/io/).
#pragma once

#include <mpi.h>

#include "io/input_yaml_util.hpp"
#include "model/model.hpp"

#include <array>
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
  // Per node: itself when it is no slave, else a node higher up its chain of masters or -1 (the
  // ground); path halving shortens it (ChainTop). Sized with joint_of_slave on first use.
  mutable std::vector<int> chain_up;
  // Joint names, to index into Model::joints.
  std::unordered_map<std::string, int> joint_names;
  // Nodes read from the mesh file: indices [mesh_first_node, mesh_first_node + mesh_node_count).
  std::string mesh_label;
  int         mesh_first_node = 0, mesh_node_count = 0;
  // The ranks reading the model together (ReadModelFile).
  MPI_Comm comm = MPI_COMM_SELF;

  int JointOfSlave(int node) const { return node >= 0 && static_cast<size_t>(node) < joint_of_slave.size() ? joint_of_slave[node] : -1; }
  // The top of the chain of masters above `node`: the first node up the chain that is no joint's
  // slave, or -1 when the chain hangs from the ground. A union-find with path halving over
  // chain_up, so that N chained joints are checked in nearly O(N), not O(N^2).
  int ChainTop(int node) const;
  // Records that `slave` now hangs from `master` (-1: the ground).
  void LinkChain(int slave, int master);

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

// --- Straight beams, shared by YAML `beams` and the beams of a mesh file (input_beams.cpp) ---

// Keeps node and element indices (int) far from overflow.
inline constexpr int kMaxElementsPerBeam = 10000000;

struct BeamLayout {
  int    elements = 1;
  int    order    = 1;
  double roll     = 0.0; // rad, constant rotation of t2, t3 about t1
  double twist    = 0.0; // rad, extra rotation about t1 reached at `to`, linear in arc length
};

// The end positions are (numerically) the same.
bool BeamHasZeroLength(const Vec3 &start, const Vec3 &end);
// The default orientation vector of a straight beam: (0, 1, 0), or (-1, 0, 0) when the beam is
// nearly along y.
Vec3 DefaultBeamOrientation(const Vec3 &start, const Vec3 &end);
// A non-zero orientation vector nearly parallel to the axis, which cannot fix t2.
bool OrientationAlongAxis(const Vec3 &orientation, const Vec3 &start, const Vec3 &end);
// Expands a straight beam from node `from` to node `to` (different nodes at different positions,
// orientation checked) into generated nodes `<name>.<k>` and elements, and appends it to
// Model::beams. `beam` carries name, section and mark; its name is already registered.
void AppendStraightBeam(Beam beam, int from, int to, const Vec3 &orientation, const BeamLayout &layout, ReaderContext &context);

// Reads the items of `rigid_bodies` into Model::rigid_bodies (input_dynamics.cpp). Needs the nodes,
// including those generated inside beams.
void ReadRigidBodies(const std::vector<YAML::Node> &items, ReaderContext &context);

// Reads `initial_conditions` into Model::initial_conditions; a node given an initial condition by
// two entries is an error (input_dynamics.cpp). Needs the nodes, beams and sets.
void ReadInitialConditions(const YAML::Node *list, ReaderContext &context);

// Reads `joints` into Model::joints and fills ReaderContext::joint_of_slave (input_joints.cpp).
// Needs the nodes (including generated ones), the functions and joint_of_slave sized to the
// nodes; checks names, axes, releases, drives, that every node is the slave of at most one joint
// and that the joints form no cycle.
void ReadJoints(const YAML::Node *list, ReaderContext &context);

// --- Joints, shared by YAML `joints` and the joints of a mesh file (input_joints.cpp) ---

// "" when `parameter` suits a kind (pitch and rack_pinion radius: non-zero; cam radius: positive;
// ignored otherwise), else what is wrong with it, e.g. "must not be zero".
std::string JointParameterProblem(JointKind kind, double parameter);
// Sets joint.kind and the releases and dependence the registry (model/joint_kinds.hpp) gives the
// kind; `parameter` (checked with JointParameterProblem) is the pitch or radius. A custom kind's
// releases and a cam_table's profile are read separately.
void ApplyJointKind(const JointKindInfo &info, double parameter, Joint &joint);
// "" for a usable `axis` (non-zero), else the problem.
std::string JointAxisProblem(const Vec3 &axis);
// "" for a usable `second_axis` with the (non-zero) `axis`, else the problem.
std::string JointSecondAxisProblem(const Vec3 &axis, const Vec3 &second_axis);
// Axes a1 = axis / |axis|, a2 from `second_axis` (nullptr: the global axis least aligned with a1),
// a3 = a1 x a2 as the columns of a rotation matrix. The vectors are checked already.
Mat3 JointAxesFrom(const Vec3 &axis, const Vec3 *second_axis);
// "" when the joint (master, slave set, master != slave) keeps every node the slave of at most
// one joint and closes no cycle of joints, else the message. *at_slave tells whether the problem
// is with the slave (already a slave) rather than the joint as a whole (a cycle).
std::string JointTreeProblem(const Joint &joint, const ReaderContext &context, bool *at_slave);
// The index of the released coordinate named by `value` (tx .. rz, or `rotation` for the single
// rotation of a one-axis joint) of `joint`, for force elements and initial conditions (`where`
// names the entry in messages); a free rotation has no named coordinate.
int NamedJointCoordinate(const Joint &joint, const YAML::Node &value, const std::string &where);
// "" when `name` can name a joint (it begins HDF5 dataset names in the result file), else the message.
std::string JointNameProblem(const std::string &name);
// Appends a checked joint to Model::joints and records its slave in joint_of_slave and its name.
void AppendJoint(Joint joint, ReaderContext &context);

// --- The HDF5 mesh file of the top-level key `mesh` (input_mesh.cpp, format in docs/input.md) ---

// The datasets of a mesh file, checked for presence, type and shape; indices still unchecked.
struct MeshData {
  std::string label; // the file as written after `mesh:`, for messages
  std::string path;  // the file as opened (relative to the input's directory)
  SourceMark  mark;  // the `mesh:` key
  // nodes
  std::vector<Vec3>        coordinates;
  std::vector<std::string> node_names; // empty: default names n<i>
  // beams
  std::vector<std::array<long long, 2>> beam_nodes;
  std::vector<long long>                beam_section, beam_elements, beam_order;
  std::vector<Vec3>                     beam_orientation; // empty: default orientation for every beam
  std::vector<std::string>              beam_names;       // empty: default names b<i>
  // joints
  std::vector<std::string> joint_type;
  std::vector<long long>   joint_master, joint_slave;
  std::vector<Vec3>        joint_axis, joint_second_axis; // second axis empty: default for every joint
  std::vector<double>      joint_parameter;
  std::vector<std::string> joint_names; // empty: default names j<i>
};

// Reads the mesh file named by the value of `mesh:` (relative to the directory of the input file);
// `key_mark` is where the `mesh` key is written. Every rank reads the whole file.
MeshData ReadMeshFile(const YAML::Node &value, const YAML::Mark &key_mark, const ReaderContext &context);
// Appends the mesh's nodes to Model::nodes (first mesh node at index context.mesh_first_node).
void AddMeshNodes(const MeshData &mesh, ReaderContext &context);
// Expands the mesh's beams like YAML straight beams. Needs the sections and the mesh's nodes.
void AddMeshBeams(const MeshData &mesh, ReaderContext &context);
// Appends the mesh's joints. Needs joint_of_slave sized to the nodes.
void AddMeshJoints(const MeshData &mesh, ReaderContext &context);
// The row in /nodes of a node that came from the mesh file, else -1.
int MeshNodeRow(const ReaderContext &context, int node);
// "lattice.h5: /nodes row 3: " for a node that came from the mesh file, else "".
std::string MeshNodePrefix(const ReaderContext &context, int node);

// Reads `force_elements` into Model::force_elements (input_force_elements.cpp). Needs the nodes,
// the joints and the functions.
void ReadForceElements(const YAML::Node *list, ReaderContext &context);

// Reads `expected` into Model::expected (input_expected.cpp): results an example must reproduce,
// which the test suite checks against the result file and the solver ignores.
void ReadExpected(const YAML::Node *list, ReaderContext &context);

// Fails when a connected group of beams, or of rigid bodies outside every beam, is not held against
// all six rigid-body motions by its supports and its joints to the ground, which would make the
// static stiffness matrix singular; elements and joints between nodes connect groups
// (input_mechanism_check.cpp). Called for static analyses only.
void CheckStaticMechanisms(const Model &model, AnalysisType type);
// What an analysis type needs of the model: no mechanism where it needs the static stiffness
// (CheckStaticMechanisms), no follower load where it solves a symmetric eigenproblem (buckling,
// preloaded modes).
void CheckModelForAnalysis(const Model &model, AnalysisType type, bool preload);

// What is wrong with the analysis settings that refer to the rest of the model (the target of
// displacement control), and the analysis key to blame; an empty message when nothing is
// (input_path_control.cpp).
struct AnalysisProblem {
  std::string key, message;
};
AnalysisProblem PathControlProblem(const Model &model);
// ux uy uz rx ry rz (a node's DOF) or tx ty tz rx ry rz (a joint's coordinate) -> 0..5; else -1.
int PathControlDofFromName(const std::string &name);

} // namespace msflex::input_detail
