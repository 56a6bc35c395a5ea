// The YAML model reader: top-level structure, functions, sections, nodes, sets, supports, loads,
// probes, analysis and output settings. Beams are expanded in input_beams.cpp, rigid bodies and
// initial conditions are read in input_dynamics.cpp, joints in input_joints.cpp and static
// mechanisms are detected in input_mechanism_check.cpp. The schema is documented in docs/input.md.
#include "io/input_reader.hpp"

#include "core/file_safety.hpp"
#include "core/mpi_util.hpp"

#include "io/input_reader_internal.hpp"
#include "io/input_yaml_util.hpp"
#include "schemes/time_scheme.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <new>
#include <utility>

namespace msflex {

namespace input_detail {

int ReaderContext::ChainTop(int node) const
{
  if (chain_up.size() != joint_of_slave.size()) {
    chain_up.resize(joint_of_slave.size());
    for (size_t n = 0; n < chain_up.size(); ++n) chain_up[n] = static_cast<int>(n);
  }
  while (node >= 0 && chain_up[static_cast<size_t>(node)] != node) {
    int &up = chain_up[static_cast<size_t>(node)];
    if (up >= 0) up = chain_up[static_cast<size_t>(up)]; // path halving
    node = up;
  }
  return node;
}

void ReaderContext::LinkChain(int slave, int master)
{
  ChainTop(slave); // sizes chain_up
  chain_up[static_cast<size_t>(slave)] = master;
}

SourceMark ReaderContext::MarkOf(const YAML::Mark &mark) const
{
  if (mark.is_null()) return SourceMark{model.input_file, 0, 0};
  return SourceMark{model.input_file, mark.line + 1, mark.column + 1};
}

namespace {

const char *KindName(NameKind kind)
{
  switch (kind) {
  case NameKind::Node:
    return "node";
  case NameKind::Beam:
    return "beam";
  case NameKind::Set:
    return "set";
  }
  return "name";
}

// Index of the object called `name` in `objects`, or -1.
template <class NamedType> int IndexByName(const std::vector<NamedType> &objects, const std::string &name)
{
  for (size_t index = 0; index < objects.size(); ++index)
    if (objects[index].name == name) return static_cast<int>(index);
  return -1;
}

template <class NamedType>
void RequireUniqueName(const std::vector<NamedType> &objects, const std::string &name, const std::string &kind, const MappingReader &entry)
{
  const int existing = IndexByName(objects, name);
  if (existing >= 0)
    FailAt(entry.Required("name").Mark(),
           "duplicate " + kind + " name " + Quote(name) + " (first defined at line " + std::to_string(objects[existing].mark.line) + ")");
}

// Joints, force elements and probes name the history series they add after themselves, one column
// each in one table. Joints, bushings and reaction probes all add <name>.force_x ... <name>.moment_z,
// so a joint and a reaction probe called alike would write the same columns; their names must
// differ (each kind's names are unique already). The other series' suffixes never meet (a node
// probe's <name>.position.x, a joint's <name>.rx, a spring's <name>.tension, ...).
void CheckHistoryNamesDistinct(const Model &model)
{
  struct Named {
    const char       *kind;
    const SourceMark *mark;
  };
  std::map<std::string, Named> first;
  const auto                   add = [&](const char *kind, const std::string &name, const SourceMark &mark) {
    const auto [existing, inserted] = first.emplace(name, Named{kind, &mark});
    if (!inserted)
      FailAt(mark, std::string(kind) + " name " + Quote(name) + " is also the name of the " + existing->second.kind + " at line " +
                                         std::to_string(existing->second.mark->line) + ": both would write the history series " + name + ".force_x ... " + name +
                                         ".moment_z; joints, bushings and reaction probes need names of their own");
  };
  for (const Joint &joint : model.joints) add("joint", joint.name, joint.mark);
  for (const ForceElement &element : model.force_elements)
    if (element.kind == ForceElement::Kind::Bushing) add("bushing", element.name, element.mark);
  for (const Probe &probe : model.probes)
    if (probe.kind == Probe::Kind::Reaction) add("reaction probe", probe.name, probe.mark);
}

} // namespace

void ReaderContext::RegisterName(const std::string &name, NameKind kind, int index, const SourceMark &mark)
{
  if (name == kAllNodes)
    FailAt(mark, std::string("a ") + KindName(kind) + " cannot be called " + Quote(kAllNodes) + ": in 'nodes' lists " + Quote(kAllNodes) + " means every node");
  const auto [existing, inserted] = names.emplace(name, NamedObject{kind, index, mark.line});
  if (!inserted) {
    const int         mesh_row = existing->second.kind == NameKind::Node ? MeshNodeRow(*this, existing->second.index) : -1;
    const std::string user     = mesh_row < 0 ? "the " + std::string(KindName(existing->second.kind)) + " at line " + std::to_string(existing->second.line)
                                              : "node row " + std::to_string(mesh_row) + " of the mesh file " + Quote(mesh_label);
    FailAt(mark, "name " + Quote(name) + " of this " + KindName(kind) + " is already used by " + user + " (nodes, beams and sets share one namespace)");
  }
}

int ReaderContext::NodeIndex(const MappingReader &entry, const std::string &key) const
{
  const YAML::Node &value = entry.Required(key);
  const std::string name  = ReadString(value, key);
  const auto        found = names.find(name);
  if (found == names.end()) FailAt(ValueMark(value), "unknown node " + Quote(name) + " for " + Quote(key) + " in " + entry.Description());
  if (found->second.kind != NameKind::Node)
    FailAt(ValueMark(value), Quote(key) + " must name a node, but " + Quote(name) + " is a " + KindName(found->second.kind));
  return found->second.index;
}

int ReaderContext::SectionIndex(const MappingReader &entry, const std::string &key) const
{
  const YAML::Node &value = entry.Required(key);
  const std::string name  = ReadString(value, key);
  const int         index = IndexByName(model.sections, name);
  if (index < 0) FailAt(ValueMark(value), "unknown section " + Quote(name) + " for " + Quote(key) + " in " + entry.Description());
  return index;
}

int ReaderContext::OptionalFunctionIndex(const MappingReader &entry, const std::string &key) const
{
  const YAML::Node *value = entry.Find(key);
  if (value == nullptr) return -1;
  const std::string name  = ReadString(*value, key);
  const int         index = IndexByName(model.functions, name);
  if (index < 0) FailAt(value->Mark(), "unknown function " + Quote(name) + " for " + Quote(key) + " in " + entry.Description());
  return index;
}

std::vector<int> ReaderContext::ResolveNodes(const YAML::Node &value, const std::string &key) const
{
  std::vector<int>  nodes;
  std::vector<bool> already_listed(model.nodes.size(), false);
  const auto        add = [&](int node) {
    if (!already_listed[node]) nodes.push_back(node);
    already_listed[node] = true;
  };
  for (const NameReference &reference : ReadNameList(value, key)) {
    if (reference.name == kAllNodes) {
      for (size_t node = 0; node < model.nodes.size(); ++node) add(static_cast<int>(node));
      continue;
    }
    const auto found = names.find(reference.name);
    if (found == names.end()) FailAt(reference.mark, "unknown node, set or beam " + Quote(reference.name) + " in " + Quote(key));
    const NamedObject &object = found->second;
    if (object.kind == NameKind::Node) add(object.index);
    if (object.kind == NameKind::Beam)
      for (int node : model.beams[object.index].nodes) add(node);
    if (object.kind == NameKind::Set)
      for (int node : model.node_sets[object.index].nodes) add(node);
  }
  return nodes;
}

namespace {

void ReadTablePoints(const YAML::Node &points, TimeFunction &function)
{
  for (const YAML::Node &point : ReadNonEmptyList(points, "points")) {
    if (!point.IsSequence() || point.size() != 2)
      FailAt(point.Mark(), "expected a [t, value] pair in 'points' of function " + Quote(function.name) + ", got " + DescribeValue(point));
    const double time = ReadNumber(point[0], "points");
    if (!function.times.empty() && !(time > function.times.back()))
      FailAt(point[0].Mark(), "times in 'points' of function " + Quote(function.name) + " must be strictly increasing, got " + point[0].Scalar() + " after " +
                                  FormatNumber(function.times.back()));
    function.times.push_back(time);
    function.values.push_back(ReadNumber(point[1], "points"));
  }
}

TimeFunction ReadFunction(const YAML::Node &item, const ReaderContext &context)
{
  const MappingReader entry(item, "function");
  TimeFunction        function;
  function.name = entry.String("name");
  function.mark = context.MarkOf(entry.Mark());
  RequireUniqueName(context.model.functions, function.name, "function", entry);
  const std::string type = entry.String("type");
  if (type == "constant") {
    entry.RequireOnlyKeys({"name", "type", "value"});
    function.kind   = TimeFunction::Kind::Constant;
    function.offset = entry.Number("value");
  } else if (type == "linear") {
    entry.RequireOnlyKeys({"name", "type", "slope", "offset"});
    function.kind   = TimeFunction::Kind::Linear;
    function.slope  = entry.Number("slope", 1.0);
    function.offset = entry.Number("offset", 0.0);
  } else if (type == "table") {
    entry.RequireOnlyKeys({"name", "type", "points"});
    function.kind = TimeFunction::Kind::Table;
    ReadTablePoints(entry.Required("points"), function);
  } else if (type == "harmonic") {
    entry.RequireOnlyKeys({"name", "type", "amplitude", "frequency", "phase", "offset"});
    function.kind      = TimeFunction::Kind::Harmonic;
    function.amplitude = entry.Number("amplitude");
    function.frequency = entry.Number("frequency");
    function.phase     = entry.Number("phase", 0.0);
    function.offset    = entry.Number("offset", 0.0);
  } else if (type == "cosine_ramp") {
    entry.RequireOnlyKeys({"name", "type", "duration", "amplitude", "start"});
    function.kind      = TimeFunction::Kind::CosineRamp;
    function.duration  = entry.PositiveNumber("duration");
    function.amplitude = entry.Number("amplitude", 1.0);
    function.start     = entry.Number("start", 0.0);
  } else if (type == "sum") {
    entry.RequireOnlyKeys({"name", "type", "terms"});
    function.kind = TimeFunction::Kind::Sum;
    // Only functions defined before: a sum can then never contain itself.
    for (const YAML::Node &term : ReadNonEmptyList(entry.Required("terms"), "terms")) {
      const std::string name  = ReadString(term, "terms");
      const int         index = IndexByName(context.model.functions, name);
      if (index < 0)
        FailAt(term.Mark(), "unknown function " + Quote(name) + " in 'terms' of function " + Quote(function.name) +
                                "; a sum adds functions defined before it in 'functions'");
      function.terms.push_back(index);
    }
  } else if (type == "polynomial") {
    entry.RequireOnlyKeys({"name", "type", "coefficients"});
    function.kind = TimeFunction::Kind::Polynomial;
    for (const YAML::Node &coefficient : ReadNonEmptyList(entry.Required("coefficients"), "coefficients"))
      function.values.push_back(ReadNumber(coefficient, "coefficients"));
  } else {
    FailAt(entry.Required("type").Mark(), "unknown function type " + Quote(type) + " in " + entry.Description() +
                                              "; expected constant, linear, table, harmonic, cosine_ramp, polynomial or sum");
  }
  return function;
}

// Mass per length and rotational inertia per length: given directly (rhoA, rhoJ) or from the
// density and the geometry of the section (density, area, I2, I3), never both.
void ReadSectionInertia(const MappingReader &entry, Section &section)
{
  if (entry.Has("density")) {
    for (const char *direct : {"rhoA", "rhoJ"})
      if (const YAML::Node *value = entry.Find(direct))
        FailAt(value->Mark(), "give either 'density' (with 'area', 'I2' and 'I3') or " + Quote(direct) + " in " + entry.Description() + ", not both");
    const double density = entry.PositiveNumber("density");
    const double area    = entry.PositiveNumber("area");
    const double I2      = entry.PositiveNumber("I2");
    const double I3      = entry.PositiveNumber("I3");
    section.rhoA         = density * area;
    section.rhoJ         = density * Vec3(I2 + I3, I2, I3); // the polar moment about t1 is I2 + I3
    return;
  }
  for (const char *geometric : {"area", "I2", "I3"})
    if (const YAML::Node *value = entry.Find(geometric))
      FailAt(value->Mark(),
             Quote(geometric) + " in " + entry.Description() + " needs 'density' (kg/m^3); to give the mass per length directly use 'rhoA' and 'rhoJ'");
  section.rhoA = entry.NonNegativeNumber("rhoA", 0.0);
  if (const YAML::Node *rhoJ = entry.Find("rhoJ")) section.rhoJ = ReadNonNegativeVec3(*rhoJ, "rhoJ");
}

// Structural damping: proportional to the stiffness (`damping_time` tau, s: C_d = tau C) or given
// (`damping`: six numbers >= 0, in the order EA GA2 GA3 GJ EI2 EI3), never both.
void ReadSectionDamping(const MappingReader &entry, Section &section)
{
  if (entry.Has("damping_time") && entry.Has("damping"))
    FailAt(entry.Required("damping").Mark(), "give either 'damping_time' or 'damping' in " + entry.Description() + ", not both");
  if (entry.Has("damping_time")) {
    const double tau                = entry.NonNegativeNumber("damping_time", 0.0);
    section.damping_axial_shear     = tau * Vec3(section.EA, section.GA2, section.GA3);
    section.damping_torsion_bending = tau * Vec3(section.GJ, section.EI2, section.EI3);
  } else if (const YAML::Node *value = entry.Find("damping")) {
    if (!value->IsSequence() || value->size() != 6)
      FailAt(value->Mark(), "expected 6 numbers (for EA GA2 GA3 GJ EI2 EI3) for 'damping' of " + entry.Description() + ", got " + DescribeValue(*value));
    for (int k = 0; k < 3; ++k) {
      section.damping_axial_shear(k)     = ReadNonNegativeNumber((*value)[k], "damping");
      section.damping_torsion_bending(k) = ReadNonNegativeNumber((*value)[3 + k], "damping");
    }
  }
}

Section ReadSection(const YAML::Node &item, const ReaderContext &context)
{
  const MappingReader entry(item, "section",
                            {"name", "EA", "GA2", "GA3", "GJ", "EI2", "EI3", "rhoA", "rhoJ", "density", "area", "I2", "I3", "damping_time", "damping"});
  Section             section;
  section.name = entry.String("name");
  section.mark = context.MarkOf(entry.Mark());
  RequireUniqueName(context.model.sections, section.name, "section", entry);
  section.EA  = entry.PositiveNumber("EA");
  section.GA2 = entry.PositiveNumber("GA2");
  section.GA3 = entry.PositiveNumber("GA3");
  section.GJ  = entry.PositiveNumber("GJ");
  section.EI2 = entry.PositiveNumber("EI2");
  section.EI3 = entry.PositiveNumber("EI3");
  ReadSectionInertia(entry, section);
  ReadSectionDamping(entry, section);
  return section;
}

void ReadNodes(const YAML::Node &mapping, ReaderContext &context)
{
  const MappingReader entries(mapping, "'nodes'");
  if (entries.Entries().empty()) FailAt(entries.Mark(), "'nodes' must map at least one node name to its position");
  for (const MappingReader::Entry &entry : entries.Entries()) {
    if (entry.key.empty()) FailAt(entry.key_node.Mark(), "node names must not be empty");
    const int index = static_cast<int>(context.model.nodes.size());
    Node      node{entry.key, ReadPosition(entry.value, entry.key), context.MarkOf(entry.key_node.Mark())};
    context.RegisterName(node.name, NameKind::Node, index, node.mark);
    context.model.nodes.push_back(std::move(node));
  }
}

// Every node named under `nodes:` must belong to a beam or a joint or carry a rigid body; a stray
// node would have neither stiffness nor mass and be attached to nothing.
void CheckEveryNodeConnected(const ReaderContext &context, size_t user_node_count)
{
  const Model      &model = context.model;
  std::vector<bool> connected(model.nodes.size(), false);
  for (const BeamElement &element : model.elements)
    for (int node : element.nodes)
      if (node >= 0) connected[node] = true;
  for (const RigidBody &body : model.rigid_bodies) connected[body.node] = true;
  for (const Joint &joint : model.joints) {
    if (joint.master >= 0) connected[joint.master] = true;
    connected[joint.slave] = true;
  }
  for (const ForceElement &element : model.force_elements)
    if (element.kind != ForceElement::Kind::Coordinate) connected[element.nodes[0]] = connected[element.nodes[1]] = true;
  for (size_t node = 0; node < user_node_count; ++node)
    if (!connected[node])
      FailAt(model.nodes[node].mark, MeshNodePrefix(context, static_cast<int>(node)) + "node " + Quote(model.nodes[node].name) +
                                         " is not connected to any beam, joint or force element and carries no rigid body");
}

void ReadSets(const YAML::Node *mapping, ReaderContext &context)
{
  if (mapping == nullptr || mapping->IsNull()) return;
  const MappingReader entries(*mapping, "'sets'");
  for (const MappingReader::Entry &entry : entries.Entries()) {
    NodeSet set;
    set.name = entry.key;
    set.mark = context.MarkOf(entry.key_node.Mark());
    for (const NameReference &reference : ReadNameList(entry.value, entry.key)) {
      const auto found = context.names.find(reference.name);
      if (found == context.names.end() || found->second.kind == NameKind::Set)
        FailAt(reference.mark, "set " + Quote(set.name) + " lists " + Quote(reference.name) + ", which is not a node or a beam");
    }
    set.nodes = context.ResolveNodes(entry.value, entry.key);
    context.RegisterName(set.name, NameKind::Set, static_cast<int>(context.model.node_sets.size()), set.mark);
    context.model.node_sets.push_back(std::move(set));
  }
}

void ReadFixedDofs(const YAML::Node &fix, Support &support)
{
  if (fix.IsScalar() && fix.Scalar() == "all") {
    support.kind.fill(Support::Kind::Fixed);
    return;
  }
  if (!fix.IsSequence()) FailAt(fix.Mark(), "expected 'all' or a list of DOF names for 'fix', got " + DescribeValue(fix));
  for (const YAML::Node &dof : fix) support.kind[ReadDofName(dof, "fix")] = Support::Kind::Fixed;
}

// `prescribe` (the DOF is value f(t)) or `prescribe_rate` (its rate is value f(t), from the
// reference at t = 0).
void ReadPrescribedDofs(const YAML::Node &prescribe, const char *key, bool by_rate, Support &support)
{
  const MappingReader entries(prescribe, std::string("'") + key + "'");
  for (const MappingReader::Entry &entry : entries.Entries()) {
    const int dof = ReadDofName(entry.key_node, key);
    if (support.kind[dof] == Support::Kind::Fixed)
      FailAt(entry.key_node.Mark(), "DOF " + Quote(entry.key) + " is both fixed and prescribed in the same support");
    if (support.kind[dof] == Support::Kind::Prescribed)
      FailAt(entry.key_node.Mark(), "DOF " + Quote(entry.key) + " is in both 'prescribe' and 'prescribe_rate' of the same support");
    support.kind[dof]    = Support::Kind::Prescribed;
    support.values[dof]  = ReadNumber(entry.value, entry.key);
    support.by_rate[dof] = by_rate;
  }
}

// The slave of a joint moves with its master and the joint's coordinates, so no support may fix or
// prescribe its DOFs; the error points at the name in `nodes` that brings in the slave.
void CheckNoJointSlaves(const YAML::Node &nodes_value, const std::vector<int> &nodes, const ReaderContext &context)
{
  for (int node : nodes) {
    const int joint = context.JointOfSlave(node);
    if (joint < 0) continue;
    YAML::Mark mark = nodes_value.Mark();
    if (nodes_value.IsSequence())
      for (const YAML::Node &item : nodes_value) {
        const std::vector<int> listed = context.ResolveNodes(item, "nodes");
        if (std::find(listed.begin(), listed.end(), node) != listed.end()) {
          mark = item.Mark();
          break;
        }
      }
    const Joint &slave_joint = context.model.joints[joint];
    FailAt(mark, "node " + Quote(context.model.nodes[node].name) + " is the slave of joint " + Quote(slave_joint.name) + " (line " +
                     std::to_string(slave_joint.mark.line) + ") and cannot carry a support; support its master or prescribe the joint's motion with 'drive'");
  }
}

Support ReadSupport(const YAML::Node &item, const ReaderContext &context)
{
  const MappingReader entry(item, "support", {"nodes", "fix", "prescribe", "prescribe_rate", "function"});
  Support             support;
  support.mark  = context.MarkOf(entry.Mark());
  support.nodes = context.ResolveNodes(entry.Required("nodes"), "nodes");
  CheckNoJointSlaves(entry.Required("nodes"), support.nodes, context);
  if (const YAML::Node *fix = entry.Find("fix")) ReadFixedDofs(*fix, support);
  if (const YAML::Node *prescribe = entry.Find("prescribe")) ReadPrescribedDofs(*prescribe, "prescribe", false, support);
  if (const YAML::Node *prescribe = entry.Find("prescribe_rate")) ReadPrescribedDofs(*prescribe, "prescribe_rate", true, support);
  support.function          = context.OptionalFunctionIndex(entry, "function");
  bool constrains_something = false;
  for (Support::Kind kind : support.kind) constrains_something = constrains_something || kind != Support::Kind::Free;
  if (!constrains_something) FailAt(entry.Mark(), "a support must fix or prescribe at least one DOF (use 'fix', 'prescribe' or 'prescribe_rate')");
  return support;
}

// A DOF may be fixed by several supports, but a prescribed DOF must have exactly one support:
// two prescriptions (or a prescription and a fixation) contradict each other.
void CheckSupportConflicts(const Model &model)
{
  struct Constraint {
    int           support = -1;
    Support::Kind kind    = Support::Kind::Free;
  };
  std::vector<std::array<Constraint, 6>> constraints(model.nodes.size());
  for (size_t support_index = 0; support_index < model.supports.size(); ++support_index) {
    const Support &support = model.supports[support_index];
    for (int node : support.nodes)
      for (int dof = 0; dof < 6; ++dof) {
        if (support.kind[dof] == Support::Kind::Free) continue;
        Constraint &previous   = constraints[node][dof];
        const bool  both_fixed = previous.kind == Support::Kind::Fixed && support.kind[dof] == Support::Kind::Fixed;
        if (previous.support >= 0 && !both_fixed)
          FailAt(support.mark, "DOF " + Quote(DofName(dof)) + " of node " + Quote(model.nodes[node].name) + " is already constrained by the support at line " +
                                   std::to_string(model.supports[previous.support].mark.line) + "; a prescribed DOF must belong to exactly one support");
        previous = Constraint{static_cast<int>(support_index), support.kind[dof]};
      }
  }
}

std::vector<int> AllElements(const Model &model)
{
  std::vector<int> elements(model.elements.size());
  for (size_t element = 0; element < elements.size(); ++element) elements[element] = static_cast<int>(element);
  return elements;
}

std::vector<int> ElementsOfBeams(const YAML::Node &beams, const ReaderContext &context)
{
  std::vector<int>  elements;
  std::vector<bool> listed_beams(context.model.beams.size(), false);
  for (const NameReference &reference : ReadNameList(beams, "beams")) {
    const auto found = context.names.find(reference.name);
    if (found == context.names.end() || found->second.kind != NameKind::Beam) FailAt(reference.mark, "unknown beam " + Quote(reference.name) + " in 'beams'");
    if (listed_beams[found->second.index]) continue;
    listed_beams[found->second.index]     = true;
    const std::vector<int> &beam_elements = context.model.beams[found->second.index].elements;
    elements.insert(elements.end(), beam_elements.begin(), beam_elements.end());
  }
  return elements;
}

// A load entry is a nodal load (`nodes`), gravity (`gravity`) or a distributed load (`beams`).
void ReadLoad(const YAML::Node &item, ReaderContext &context)
{
  const MappingReader entry(item, "load");
  const int           kinds = int(entry.Has("nodes")) + int(entry.Has("gravity")) + int(entry.Has("beams"));
  if (kinds != 1)
    FailAt(entry.Mark(), "a load needs exactly one of 'nodes' (nodal load), 'gravity' or 'beams' (distributed load), got " + std::to_string(kinds));
  Model &model = context.model;
  if (entry.Has("nodes")) {
    entry.RequireOnlyKeys({"nodes", "force", "moment", "follower", "function"});
    if (!entry.Has("force") && !entry.Has("moment")) FailAt(entry.Mark(), "a nodal load needs 'force' or 'moment'");
    NodalLoad load;
    load.nodes    = context.ResolveNodes(entry.Required("nodes"), "nodes");
    load.force    = entry.Vector("force", Vec3::Zero());
    load.moment   = entry.Vector("moment", Vec3::Zero());
    load.follower = entry.Bool("follower", false);
    load.function = context.OptionalFunctionIndex(entry, "function");
    load.mark     = context.MarkOf(entry.Mark());
    model.nodal_loads.push_back(std::move(load));
    return;
  }
  DistributedLoad load;
  if (entry.Has("gravity")) {
    entry.RequireOnlyKeys({"gravity", "function"});
    load.gravity          = true;
    load.elements         = AllElements(model);
    load.force_per_length = entry.Vector("gravity");
  } else {
    entry.RequireOnlyKeys({"beams", "distributed", "function"});
    load.elements         = ElementsOfBeams(entry.Required("beams"), context);
    load.force_per_length = entry.Vector("distributed");
  }
  load.function = context.OptionalFunctionIndex(entry, "function");
  load.mark     = context.MarkOf(entry.Mark());
  model.distributed_loads.push_back(std::move(load));
}

// A probe is one of: a point moving with a node's frame (`node`, optional `offset`), a rigid
// body's centre of mass (`rigid_body`), the support reaction at a node (`reaction`) or the section
// forces of an element (`beam`, optional `element`).
Probe ReadProbe(const YAML::Node &item, const ReaderContext &context)
{
  const MappingReader entry(item, "probe", {"name", "node", "offset", "rigid_body", "reaction", "beam", "element"});
  const Model        &model = context.model;
  Probe               probe;
  probe.name = entry.String("name");
  probe.mark = context.MarkOf(entry.Mark());
  if (const std::string problem = OutputNameProblem(probe.name); !problem.empty())
    FailAt(entry.Required("name").Mark(),
           "probe name " + Quote(probe.name) + " cannot begin the names of its history columns <name>.position.x, ... in the result file: " + problem);
  RequireUniqueName(model.probes, probe.name, "probe", entry);
  const int kinds = int(entry.Has("node")) + int(entry.Has("rigid_body")) + int(entry.Has("reaction")) + int(entry.Has("beam"));
  if (kinds != 1)
    FailAt(entry.Mark(), "a probe needs exactly one of 'node' (a point), 'rigid_body' (its centre of mass), 'reaction' (a supported node) and 'beam' (an "
                         "element's section forces), got " +
                             std::to_string(kinds));
  if (const YAML::Node *offset = entry.Find("offset"); offset && !entry.Has("node"))
    FailAt(offset->Mark(), "'offset' of " + entry.Description() + " goes with 'node'");
  if (const YAML::Node *element = entry.Find("element"); element && !entry.Has("beam"))
    FailAt(element->Mark(), "'element' of " + entry.Description() + " goes with 'beam'");
  if (entry.Has("node")) {
    probe.node   = context.NodeIndex(entry, "node");
    probe.offset = entry.Has("offset") ? ReadPosition(entry.Required("offset"), "offset") : Vec3::Zero();
  } else if (entry.Has("rigid_body")) {
    const YAML::Node &value = entry.Required("rigid_body");
    const std::string name  = ReadString(value, "rigid_body");
    const int         body  = IndexByName(model.rigid_bodies, name);
    if (body < 0) FailAt(ValueMark(value), "unknown rigid body " + Quote(name) + " in " + entry.Description() + " (a rigid body is named by its 'name')");
    probe.node   = model.rigid_bodies[body].node;
    probe.offset = model.rigid_bodies[body].offset;
  } else if (entry.Has("reaction")) {
    probe.kind     = Probe::Kind::Reaction;
    probe.node     = context.NodeIndex(entry, "reaction");
    bool supported = false;
    for (const Support &support : model.supports)
      for (int node : support.nodes)
        if (node == probe.node)
          for (Support::Kind kind : support.kind) supported = supported || kind != Support::Kind::Free;
    if (!supported)
      FailAt(entry.Required("reaction").Mark(), "node " + Quote(model.nodes[probe.node].name) + " of " + entry.Description() +
                                                    " has no support, so no reaction; name a node that a support fixes or prescribes");
  } else {
    probe.kind              = Probe::Kind::Element;
    const YAML::Node &value = entry.Required("beam");
    const std::string name  = ReadString(value, "beam");
    const auto        found = context.names.find(name);
    if (found == context.names.end() || found->second.kind != NameKind::Beam)
      FailAt(ValueMark(value), "unknown beam " + Quote(name) + " in " + entry.Description());
    const Beam &beam  = model.beams[found->second.index];
    const int   count = static_cast<int>(beam.elements.size());
    const int   index = entry.Integer("element", 0, 0);
    if (index >= count)
      FailAt(entry.Required("element").Mark(), "beam " + Quote(name) + " has " + std::to_string(count) + " element(s), numbered 0 to " +
                                                   std::to_string(count - 1) + "; got 'element: " + std::to_string(index) + "'");
    probe.element = beam.elements[index];
  }
  return probe;
}

void ReadOutputTimes(const YAML::Node &value, AnalysisSettings &analysis)
{
  for (const YAML::Node &item : ReadOptionalList(&value, "output_times")) {
    const double time = ReadNumber(item, "output_times");
    if (!(time > 0.0 && time <= analysis.end_time))
      FailAt(item.Mark(), "'output_times' must lie in (0, end_time = " + FormatNumber(analysis.end_time) + "], got " + item.Scalar());
    if (!analysis.output_times.empty() && !(time > analysis.output_times.back()))
      FailAt(item.Mark(), "'output_times' must be strictly increasing, got " + item.Scalar() + " after " + FormatNumber(analysis.output_times.back()));
    analysis.output_times.push_back(time);
  }
}

// Path following and stability in statics, eigenanalyses (docs/input.md, docs/stability.md).
void ReadPathFollowing(const MappingReader &entry, const ReaderContext &context, AnalysisSettings &analysis)
{
  if (const YAML::Node *value = entry.Find("control")) {
    const std::string control = ReadString(*value, "control");
    if (!PathControlFromName(control, &analysis.control))
      FailAt(value->Mark(), "unknown control " + Quote(control) + " in 'analysis'; expected one of " + PathControlNameList());
  }
  analysis.arc_length_psi     = entry.NonNegativeNumber("arc_length_psi", analysis.arc_length_psi);
  analysis.desired_iterations = entry.Integer("desired_iterations", 1, analysis.desired_iterations);
  analysis.max_steps          = entry.Integer("max_steps", 1, analysis.max_steps);
  analysis.control_node       = entry.String("control_node", analysis.control_node);
  analysis.control_joint      = entry.String("control_joint", analysis.control_joint);
  if (const YAML::Node *value = entry.Find("control_dof")) {
    const std::string name = ReadString(*value, "control_dof");
    analysis.control_dof   = PathControlDofFromName(name);
    if (analysis.control_dof < 0)
      FailAt(value->Mark(), "unknown 'control_dof' " + Quote(name) + "; expected ux, uy, uz, rx, ry, rz (a node) or tx, ty, tz, rx, ry, rz (a joint)");
    if (const std::string mismatch = PathControlDofMismatch(name, !analysis.control_joint.empty());
        !mismatch.empty() && entry.Has("control_joint") != entry.Has("control_node"))
      FailAt(value->Mark(), mismatch);
  }
  analysis.control_value = entry.Number("control_value", analysis.control_value);
  if (analysis.control_value == 0.0) FailAt(entry.Required("control_value").Mark(), "'control_value' must not be zero");
  analysis.stability   = entry.Bool("stability", analysis.stability);
  analysis.eigenvalues = entry.Integer("eigenvalues", 1, analysis.eigenvalues);
  analysis.shift       = entry.Has("shift") ? entry.Number("shift") : analysis.shift;
  analysis.preload     = entry.Bool("preload", analysis.preload);
  // Keys of displacement control without it, output times with arc length: not what was meant.
  if (analysis.control != PathControl::Displacement)
    for (const char *key : {"control_node", "control_joint", "control_dof", "control_value"})
      if (entry.Has(key))
        FailAt(entry.Required(key).Mark(), Quote(key) + " applies to 'control: displacement', but the control is " + PathControlName(analysis.control));
  if (analysis.control == PathControl::ArcLength && !analysis.output_times.empty())
    FailAt(entry.Required("output_times").Mark(), "'output_times' do not apply to 'control: arc_length', whose steps are lengths along the path");
  const AnalysisProblem problem = PathControlProblem(context.model);
  if (!problem.message.empty()) FailAt(entry.Has(problem.key) ? entry.Required(problem.key).Mark() : entry.Mark(), problem.message);
}

void ReadAnalysis(const YAML::Node *mapping, const ReaderContext &context, AnalysisSettings &analysis)
{
  if (mapping == nullptr || mapping->IsNull()) return;
  const MappingReader entry(*mapping, "'analysis'",
                            {"type",
                             "integrator",
                             "spectral_radius",
                             "em_correction",
                             "reactions",
                             "end_time",
                             "initial_step",
                             "min_step",
                             "max_step",
                             "step_tolerance",
                             "growth_factor",
                             "easy_iterations",
                             "easy_steps_to_grow",
                             "max_rotation_increment",
                             "max_newton_iterations",
                             "newton_rtol",
                             "newton_atol",
                             "jacobian_reuse",
                             "condensation_depth",
                             "linear_solver",
                             "direct_solver",
                             "output_times",
                             "control",
                             "arc_length_psi",
                             "desired_iterations",
                             "max_steps",
                             "control_node",
                             "control_joint",
                             "control_dof",
                             "control_value",
                             "stability",
                             "eigenvalues",
                             "shift",
                             "preload",
                             "static_stage",
                             "static_stage_steps",
                             "initial_velocities"});
  analysis.mark = context.MarkOf(entry.Mark());
  if (const YAML::Node *value = entry.Find("type")) {
    const std::string type = ReadString(*value, "type");
    if (!AnalysisTypeFromName(type, &analysis.type))
      FailAt(value->Mark(), "unknown analysis type " + Quote(type) + "; expected one of " + AnalysisTypeNameList());
  }
  // Accepted (and ignored) in static analyses too, so one file can switch by `type` alone.
  if (const YAML::Node *value = entry.Find("integrator")) {
    const std::string integrator = ReadString(*value, "integrator");
    if (!TimeSchemeKindFromName(integrator, &analysis.integrator))
      FailAt(value->Mark(), "unknown integrator " + Quote(integrator) + " in 'analysis'; expected one of " + IntegratorNameList());
  }
  if (const YAML::Node *value = entry.Find("em_correction")) {
    const std::string correction = ReadString(*value, "em_correction");
    if (!EnergyCorrectionFromName(correction, &analysis.em_correction))
      FailAt(value->Mark(), "unknown em_correction " + Quote(correction) + " in 'analysis'; expected resultants or forces");
  }
  if (const YAML::Node *value = entry.Find("reactions")) {
    const std::string reactions = ReadString(*value, "reactions");
    if (!ReactionPointFromName(reactions, &analysis.reactions))
      FailAt(value->Mark(), "unknown reactions " + Quote(reactions) + " in 'analysis'; expected consistent or scheme");
  }
  analysis.spectral_radius = entry.Number("spectral_radius", analysis.spectral_radius);
  if (analysis.spectral_radius < 0.0 || analysis.spectral_radius > 1.0)
    FailAt(entry.Required("spectral_radius").Mark(), "'spectral_radius' must lie in [0, 1], got " + entry.Required("spectral_radius").Scalar());
  analysis.end_time     = entry.PositiveNumber("end_time", analysis.end_time);
  analysis.initial_step = entry.PositiveNumber("initial_step", analysis.initial_step);
  analysis.min_step     = entry.PositiveNumber("min_step", analysis.min_step);
  if (analysis.min_step > analysis.initial_step)
    FailAt(entry.Has("min_step") ? entry.Required("min_step").Mark() : entry.Required("initial_step").Mark(),
           "'min_step' (" + FormatNumber(analysis.min_step) + ") must not exceed 'initial_step' (" + FormatNumber(analysis.initial_step) + ")");
  analysis.step_tolerance = entry.Number("step_tolerance", analysis.step_tolerance);
  if (!(analysis.step_tolerance >= 0.0 && analysis.step_tolerance < 1.0))
    FailAt(entry.Required("step_tolerance").Mark(), "'step_tolerance' must lie in [0, 1), got " + entry.Required("step_tolerance").Scalar());
  analysis.max_step_given = entry.Has("max_step");
  if (!analysis.max_step_given) analysis.max_step = DefaultMaxStep(analysis);
  analysis.max_step = entry.PositiveNumber("max_step", analysis.max_step);
  if (analysis.max_step < analysis.initial_step)
    FailAt(entry.Has("max_step") ? entry.Required("max_step").Mark() : entry.Required("initial_step").Mark(),
           "'max_step' (" + FormatNumber(analysis.max_step) + ") must not be less than 'initial_step' (" + FormatNumber(analysis.initial_step) + ")");
  analysis.growth_factor = entry.Number("growth_factor", analysis.growth_factor);
  if (analysis.growth_factor < 1.0)
    FailAt(entry.Required("growth_factor").Mark(), "'growth_factor' must be at least 1, got " + entry.Required("growth_factor").Scalar());
  analysis.easy_iterations        = entry.Integer("easy_iterations", 1, analysis.easy_iterations);
  analysis.easy_steps_to_grow     = entry.Integer("easy_steps_to_grow", 1, analysis.easy_steps_to_grow);
  analysis.max_rotation_increment = entry.PositiveNumber("max_rotation_increment", analysis.max_rotation_increment);
  // A rotation increment of pi or more cannot be told apart from a smaller one in the other sense.
  if (analysis.max_rotation_increment >= M_PI)
    FailAt(entry.Required("max_rotation_increment").Mark(),
           "'max_rotation_increment' must be less than pi, got " + entry.Required("max_rotation_increment").Scalar());
  analysis.max_newton_iterations = entry.Integer("max_newton_iterations", 1, analysis.max_newton_iterations);
  analysis.newton_rtol           = entry.PositiveNumber("newton_rtol", analysis.newton_rtol);
  analysis.newton_atol           = entry.NonNegativeNumber("newton_atol", analysis.newton_atol);
  analysis.jacobian_reuse        = entry.NonNegativeNumber("jacobian_reuse", analysis.jacobian_reuse);
  if (analysis.jacobian_reuse >= 1.0)
    FailAt(entry.Required("jacobian_reuse").Mark(),
           "'jacobian_reuse' must be less than 1 (a contraction factor), got " + entry.Required("jacobian_reuse").Scalar());
  analysis.condensation_depth = entry.Integer("condensation_depth", 0, analysis.condensation_depth);
  if (analysis.condensation_depth > 1000000)
    FailAt(entry.Required("condensation_depth").Mark(),
           "'condensation_depth' must lie in [0, 1000000] (0: condense whole chains), got " + entry.Required("condensation_depth").Scalar());
  if (const YAML::Node *output_times = entry.Find("output_times")) ReadOutputTimes(*output_times, analysis);
  analysis.static_stage       = entry.Bool("static_stage", analysis.static_stage);
  analysis.static_stage_steps = entry.Integer("static_stage_steps", 1, analysis.static_stage_steps);
  if (const YAML::Node *value = entry.Find("initial_velocities")) {
    const std::string choice = ReadString(*value, "initial_velocities");
    if (choice != "projected" && choice != "given")
      FailAt(value->Mark(), "unknown choice " + Quote(choice) + " for 'initial_velocities'; expected projected or given");
    analysis.project_initial_velocities = choice == "projected";
  }
  if (const YAML::Node *value = entry.Find("linear_solver")) {
    const std::string name = ReadString(*value, "linear_solver");
    if (!LinearSolverKindFromName(name, &analysis.linear_solver))
      FailAt(value->Mark(), "unknown linear_solver " + Quote(name) + " in 'analysis'; expected direct or multigrid");
  }
  if (const YAML::Node *value = entry.Find("direct_solver")) {
    const std::string name = ReadString(*value, "direct_solver");
    if (!DirectSolverChoiceFromName(name, &analysis.direct_solver))
      FailAt(value->Mark(), "unknown direct_solver " + Quote(name) + " in 'analysis'; expected auto or mumps");
  }
  ReadPathFollowing(entry, context, analysis);
}

// "input/rollup.yaml" -> "rollup.h5": results go to the working directory, named after the input.
std::string DefaultOutputFile(const std::string &input_file)
{
  const std::filesystem::path name = std::filesystem::path(input_file).filename();
  if (name.empty()) return "msflex.h5";
  return std::filesystem::path(name).replace_extension(".h5").string();
}

void ReadOutput(const YAML::Node *mapping, const ReaderContext &context, OutputSettings &output)
{
  output.file = DefaultOutputFile(context.model.input_file);
  if (mapping == nullptr || mapping->IsNull()) return;
  const MappingReader entry(*mapping, "'output'", {"file", "every", "progress_every", "progress_interval", "flush_interval", "xdmf", "checkpoint"});
  output.mark              = context.MarkOf(entry.Mark());
  output.file              = entry.String("file", output.file);
  output.every             = entry.Integer("every", 1, output.every);
  output.progress_every    = entry.Integer("progress_every", 1, output.progress_every);
  output.progress_interval = entry.NonNegativeNumber("progress_interval", output.progress_interval);
  output.flush_interval    = entry.NonNegativeNumber("flush_interval", output.flush_interval);
  if (const YAML::Node *value = entry.Find("xdmf")) {
    const std::string choice = ReadString(*value, "xdmf");
    if (choice != "xdmf3" && choice != "xdmf2") FailAt(value->Mark(), "unknown choice " + Quote(choice) + " for 'xdmf'; expected xdmf3 or xdmf2");
    output.xdmf = choice;
  }
  if (const YAML::Node *checkpoint = entry.Find("checkpoint")) {
    const MappingReader settings(*checkpoint, "'output: checkpoint'", {"every", "wall_time", "file"});
    output.checkpoint_every     = settings.Integer("every", 0, output.checkpoint_every);
    output.checkpoint_wall_time = settings.NonNegativeNumber("wall_time", output.checkpoint_wall_time);
    output.checkpoint_file      = settings.String("file", output.checkpoint_file);
  }
}

YAML::Node LoadSingleDocument(const std::string &text)
{
  const YamlStream stream = LoadYamlStream(text); // not YAML::LoadAll, which can loop forever
  // Located at 1:1 like every other message, so that a message always names file:line.
  if (stream.roots.empty() || stream.first.IsNull()) FailAt(YAML::Mark(), "the input is empty; expected a mapping of top-level keys");
  if (stream.roots.size() > 1) FailAt(stream.roots[1], "the input holds " + std::to_string(stream.roots.size()) + " YAML documents; expected one");
  if (!stream.first.IsMap())
    FailAt(stream.first.Mark(), "the top level must be a mapping of keys such as 'sections', 'nodes' and 'beams', got " + DescribeValue(stream.first));
  return stream.first;
}

// Where a top-level key is written, for messages about its (possibly empty) value.
YAML::Mark KeyMark(const MappingReader &top, const std::string &key)
{
  for (const MappingReader::Entry &entry : top.Entries())
    if (entry.key == key) return entry.key_node.Mark();
  return top.Mark();
}

Model ParseModel(const std::string &text, const std::string &file_label, MPI_Comm comm)
{
  ReaderContext context;
  context.comm             = comm;
  context.model.input_file = file_label;
  context.model.input_text = text;
  const MappingReader top(LoadSingleDocument(text), "the top-level mapping",
                          {"title", "mesh", "functions", "sections", "nodes", "beams", "rigid_bodies", "sets", "supports", "loads", "joints", "force_elements",
                           "initial_conditions", "probes", "analysis", "output", "expected"});
  // The model has no place for the title; it is validated here and kept in input_text.
  if (top.Has("title")) top.String("title");
  Model &model = context.model;
  // The bulk of a large model may come from an HDF5 mesh file: nodes, straight beams, joints.
  std::unique_ptr<MeshData> mesh;
  if (const YAML::Node *value = top.Find("mesh")) mesh = std::make_unique<MeshData>(ReadMeshFile(*value, KeyMark(top, "mesh"), context));
  if (mesh != nullptr) model.mesh_file = mesh->path;
  const bool mesh_beams = mesh != nullptr && !mesh->beam_nodes.empty();
  // A model needs something with stiffness or mass: beams, rigid bodies or both. Without beams
  // nothing refers to a section, so `sections` is optional too.
  const std::vector<YAML::Node> beam_items       = ReadOptionalList(top.Find("beams"), "beams");
  const std::vector<YAML::Node> rigid_body_items = ReadOptionalList(top.Find("rigid_bodies"), "rigid_bodies");
  if (beam_items.empty() && rigid_body_items.empty() && !mesh_beams)
    FailAt(KeyMark(top, "beams"), mesh == nullptr
                                      ? "the model has no beams and no rigid bodies; give 'beams', 'rigid_bodies' or both"
                                      : "the model has no beams (neither in 'beams' nor in the mesh file " + Quote(mesh->label) + ") and no rigid bodies");
  for (const YAML::Node &item : ReadOptionalList(top.Find("functions"), "functions")) model.functions.push_back(ReadFunction(item, context));
  const bool                    has_beams = !beam_items.empty() || mesh_beams;
  const std::vector<YAML::Node> section_items =
      has_beams ? ReadNonEmptyList(top.Required("sections"), "sections") : ReadOptionalList(top.Find("sections"), "sections");
  for (const YAML::Node &item : section_items) model.sections.push_back(ReadSection(item, context));
  // Mesh nodes first, so that mesh node i is model node i when `nodes` is left out.
  if (mesh != nullptr) AddMeshNodes(*mesh, context);
  // With a mesh, `nodes` may be left out or left empty.
  if (mesh == nullptr || (top.Has("nodes") && !top.Required("nodes").IsNull())) ReadNodes(top.Required("nodes"), context);
  const size_t user_node_count = model.nodes.size();
  if (mesh != nullptr) AddMeshBeams(*mesh, context);
  if (!beam_items.empty()) ReadBeams(top.Required("beams"), context);
  ReadRigidBodies(rigid_body_items, context);
  // Sets before joints, so no set can take the name `ground` from under a joint's master.
  ReadSets(top.Find("sets"), context);
  context.joint_of_slave.assign(model.nodes.size(), -1);
  if (mesh != nullptr) AddMeshJoints(*mesh, context);
  ReadJoints(top.Find("joints"), context);
  mesh.reset();
  ReadForceElements(top.Find("force_elements"), context);
  CheckEveryNodeConnected(context, user_node_count);
  for (const YAML::Node &item : ReadOptionalList(top.Find("supports"), "supports")) model.supports.push_back(ReadSupport(item, context));
  CheckSupportConflicts(model);
  for (const YAML::Node &item : ReadOptionalList(top.Find("loads"), "loads")) ReadLoad(item, context);
  ReadInitialConditions(top.Find("initial_conditions"), context);
  for (const YAML::Node &item : ReadOptionalList(top.Find("probes"), "probes")) model.probes.push_back(ReadProbe(item, context));
  CheckHistoryNamesDistinct(model);
  ReadAnalysis(top.Find("analysis"), context, model.analysis);
  ReadOutput(top.Find("output"), context, model.output);
  ReadExpected(top.Find("expected"), context);
  CheckModelForAnalysis(model, model.analysis.type, model.analysis.preload);
  return std::move(context.model);
}

InputError MakeError(const std::string &file, const YAML::Mark &mark, const std::string &message)
{
  // yaml-cpp's messages may quote the input (keys), so they are made one line too.
  if (mark.is_null()) return InputError{file, 0, 0, OneLine(message)};
  return InputError{file, mark.line + 1, mark.column + 1, OneLine(message)};
}

} // namespace

} // namespace input_detail

std::string InputError::Format() const
{
  std::string location = file;
  if (line > 0) location += ":" + std::to_string(line) + ":" + std::to_string(column);
  return location + ": error: " + message;
}

bool CheckModelForAnalysisType(const Model &model, AnalysisType type, bool preload, InputError *error)
{
  using namespace input_detail;
  try {
    CheckModelForAnalysis(model, type, preload);
    return true;
  } catch (const InputFailure &failure) {
    *error = InputError{model.input_file, failure.line, failure.column, failure.message};
  } catch (const std::exception &exception) {
    *error = InputError{model.input_file, 0, 0, std::string("internal error while checking the model: ") + exception.what()};
  }
  return false;
}

bool ReadModelString(const std::string &text, const std::string &file_label, Model *model, InputError *error, MPI_Comm comm)
{
  using namespace input_detail;
  if (model == nullptr || error == nullptr) return false;
  // Everything that can throw (yaml-cpp, our own InputFailure, allocation) stops here.
  try {
    *model = ParseModel(text, file_label, comm);
    return true;
  } catch (const InputFailure &failure) {
    *error = InputError{file_label, failure.line, failure.column, failure.message};
  } catch (const YAML::ParserException &exception) {
    *error = MakeError(file_label, exception.mark, "YAML syntax error: " + exception.msg + SyntaxErrorContext(text, exception.mark));
  } catch (const YAML::Exception &exception) {
    *error = MakeError(file_label, exception.mark, "YAML error: " + exception.msg);
  } catch (const std::bad_alloc &) {
    *error = InputError{file_label, 0, 0, "not enough memory to read the model: it is too large for this machine"};
  } catch (const std::exception &exception) {
    *error = InputError{file_label, 0, 0, std::string("internal error while reading the input: ") + exception.what()};
  } catch (...) {
    *error = InputError{file_label, 0, 0, "internal error while reading the input"};
  }
  return false;
}

// Reads the whole file into *text, or says why not.
static bool ReadTextFile(const std::string &path, std::string *text, InputError *error)
{
  try {
    // Only a regular file (or a link to one) is read: a directory opens as a stream on Linux but
    // cannot be read, a FIFO without a writer blocked the open for good (deaf to SIGTERM), and
    // /dev/zero was read until the machine's memory ran out (19 GB in 2.5 min; a user trial).
    if (const std::string problem = NotRegularFileProblem(path); !problem.empty()) {
      *error = InputError{path, 0, 0, "cannot read input file " + input_detail::Quote(path) + ": " + problem};
      return false;
    }
    std::ifstream stream(path, std::ios::binary);
    if (!stream) {
      *error = InputError{path, 0, 0, "cannot open input file " + input_detail::Quote(path)};
      return false;
    }
    text->assign(std::istreambuf_iterator<char>(stream), std::istreambuf_iterator<char>());
    if (stream.bad()) {
      *error = InputError{path, 0, 0, "cannot read input file " + input_detail::Quote(path)};
      return false;
    }
    // An HDF5 file (a result file, a checkpoint) given where the YAML input belongs.
    static const char kHdf5Signature[] = "\x89HDF\r\n\x1a\n";
    if (text->compare(0, 8, kHdf5Signature, 8) == 0) {
      *error = InputError{
          path, 0, 0, input_detail::Quote(path) + " is an HDF5 file, not a YAML input (to continue a run from its checkpoint: msflex --restart CHECKPOINT.h5)"};
      return false;
    }
    return true;
  } catch (const std::exception &exception) {
    *error = InputError{path, 0, 0, "cannot read input file " + input_detail::Quote(path) + ": " + exception.what()};
  }
  return false;
}

bool ReadModelFile(const std::string &path, Model *model, InputError *error, MPI_Comm comm)
{
  if (model == nullptr || error == nullptr) return false;
  int size, rank;
  CommSizeRank(comm, &size, &rank);
  std::string text;
  if (size == 1) return ReadTextFile(path, &text, error) && ReadModelString(text, path, model, error, comm);
  // Rank 0 reads the file; the others get its text (or its failure), so every rank parses the
  // same input and takes the same (collective) path through the mesh reader.
  int read = rank == 0 && ReadTextFile(path, &text, error) ? 1 : 0;
  MPI_Bcast(&read, 1, MPI_INT, 0, comm);
  if (!read) {
    std::string message = rank == 0 ? error->message : std::string();
    BroadcastString(comm, &message);
    *error = InputError{path, 0, 0, message};
    return false;
  }
  BroadcastString(comm, &text);
  return ReadModelString(text, path, model, error, comm);
}

} // namespace msflex
