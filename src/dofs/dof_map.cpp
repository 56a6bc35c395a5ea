#include "dofs/dof_map.hpp"

#include "core/errors.hpp"
#include "model/joint_geometry.hpp"

#include <algorithm>

namespace msflex {

static const char *const kDofNames[6] = {"ux", "uy", "uz", "rx", "ry", "rz"};

static PetscErrorCode CollectConstraints(const Model &model, DofMap *map)
{
  PetscFunctionBeginUser;
  map->constraints.assign(model.nodes.size(), {});
  for (size_t s = 0; s < model.supports.size(); ++s) {
    const Support &support = model.supports[s];
    for (int node : support.nodes) {
      for (int d = 0; d < 6; ++d) {
        if (support.kind[d] == Support::Kind::Free) continue;
        DofConstraint &slot = map->constraints[node][d];
        if (slot.kind != Support::Kind::Free) {
          // Fixed twice is fixed (a support of all nodes making a model planar may cover a clamped
          // node); a prescribed DOF belongs to exactly one support (docs/input.md).
          if (slot.kind == Support::Kind::Fixed && support.kind[d] == Support::Kind::Fixed) continue;
          const Support &first = model.supports[slot.support];
          MSFLEX_INPUT_CHECK(false, support.mark,
                             "DOF '%s' of node '%s' is already constrained by the support at line %d (a prescribed DOF belongs to one support alone)",
                             kDofNames[d], model.nodes[node].name.c_str(), first.mark.line);
        }
        slot = {support.kind[d], support.values[d], support.function, (int)s, support.by_rate[d]};
      }
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Joints in an order where the joint of a master comes before the joints of its slaves: by depth
// in their chain, found without recursion (a chain may be deeper than the stack) in O(joints).
// depth[j]: the joints above joint j (0: its master is independent or the ground).
static std::vector<int> JointChainOrder(const Model &model, const std::vector<int> &node_joint, std::vector<int> *depth_out)
{
  const size_t      num_joints = model.joints.size();
  std::vector<int> &depth      = *depth_out;
  std::vector<int>  order(num_joints), path;
  depth.assign(num_joints, -1);
  for (size_t start = 0; start < num_joints; ++start) {
    // Up the chain to a joint whose depth is known (or the top), then down again.
    int j = (int)start;
    while (depth[j] < 0) {
      path.push_back(j);
      const int master = model.joints[j].master;
      const int parent = master >= 0 ? node_joint[master] : -1;
      if (parent < 0) break;
      j = parent;
    }
    int known = depth[j] >= 0 ? depth[j] : -1;
    for (auto at = path.rbegin(); at != path.rend(); ++at) depth[*at] = ++known;
    path.clear();
  }
  for (size_t j = 0; j < num_joints; ++j) order[j] = (int)j;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return depth[a] < depth[b]; });
  return order;
}

PetscErrorCode DofMapCreate(MPI_Comm comm, const Model &model, const std::vector<int> &node_rank, DofMap *map)
{
  PetscMPIInt rank, size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(CollectConstraints(model, map));
  const size_t num_nodes  = model.nodes.size();
  const size_t num_joints = model.joints.size();
  map->node_rank          = node_rank;
  map->node_joint.assign(num_nodes, -1);
  for (size_t j = 0; j < num_joints; ++j) map->node_joint[model.joints[j].slave] = (int)j;
  map->joint_rank.assign(num_joints, 0);
  for (size_t j = 0; j < num_joints; ++j) map->joint_rank[j] = node_rank[model.joints[j].slave];

  // Relay nodes: every slave at a depth that is a multiple of the condensation depth (counted in
  // joints from the top of its chain) that is a master itself; in dynamics, and in statics without
  // the stability account (the negative pivots of the condensed tangent: a relay's rows are not
  // symmetric where its joint carries a force, so the tangent with them could only be factored by
  // LU, which gives no inertia); never in eigenanalyses (the condensed symmetric pencil).
  std::vector<int>       joint_depth;
  const std::vector<int> chain_order = JointChainOrder(model, map->node_joint, &joint_depth);
  const AnalysisType     type        = model.analysis.type;
  const bool             relays      = type == AnalysisType::Dynamic || (type == AnalysisType::Static && !model.analysis.stability);
  const int              relay_depth = relays ? model.analysis.condensation_depth : 0;
  std::vector<char>      is_relay(num_nodes, 0), is_master(num_nodes, 0);
  map->num_relays = 0;
  for (const Joint &joint : model.joints)
    if (joint.master >= 0) is_master[joint.master] = 1;
  if (relay_depth > 0)
    for (size_t j = 0; j < num_joints; ++j) {
      const int slave = model.joints[j].slave;
      if (is_master[slave] && (joint_depth[j] + 1) % relay_depth == 0) is_relay[slave] = 1, ++map->num_relays;
    }

  // Number rank by rank: the free DOFs of its independent nodes, then its joints' free
  // coordinates, then its relays' DOFs and forces.
  map->node_dofs.assign(num_nodes, {{-1, -1, -1, -1, -1, -1}});
  map->joint_dofs.assign(num_joints, {{-1, -1, -1, -1, -1, -1}});
  map->relay_forces.assign(map->num_relays > 0 ? num_nodes : 0, {{-1, -1, -1, -1, -1, -1}});
  map->relay_unknowns.assign(map->num_relays > 0 ? num_nodes : 0, {});
  PetscInt next = 0;
  for (int r = 0; r < size; ++r) {
    if (r == rank) map->first_owned = next;
    for (size_t i = 0; i < num_nodes; ++i) {
      if (node_rank[i] != r || map->node_joint[i] >= 0) continue;
      for (int d = 0; d < 6; ++d)
        if (map->constraints[i][d].kind == Support::Kind::Free) map->node_dofs[i][d] = next++;
    }
    for (size_t j = 0; j < num_joints; ++j) {
      if (map->joint_rank[j] != r) continue;
      const Joint &joint = model.joints[j];
      const int    k     = JointNumCoordinates(JointGeometryOf(joint));
      for (int c = 0; c < k; ++c)
        if (c != joint.driven_coordinate) map->joint_dofs[j][c] = next++;
    }
    for (size_t i = 0; i < num_nodes; ++i) {
      if (node_rank[i] != r || !is_relay[i]) continue;
      for (int d = 0; d < 6; ++d) map->node_dofs[i][d] = next++;
      for (int d = 0; d < 6; ++d) map->relay_forces[i][d] = next++;
    }
    if (r == rank) map->num_owned = next - map->first_owned;
  }
  map->num_global = next;

  // Joint slots, rank by rank like the unknowns.
  map->joint_slot.assign(num_joints, -1);
  int next_slot = 0;
  for (int r = 0; r < size; ++r) {
    if (r == rank) map->first_owned_joint_slot = next_slot;
    for (size_t j = 0; j < num_joints; ++j)
      if (map->joint_rank[j] == r) map->joint_slot[j] = next_slot++;
    if (r == rank) map->num_owned_joints = next_slot - map->first_owned_joint_slot;
  }
  map->global_nodes.resize(num_nodes);
  for (size_t i = 0; i < num_nodes; ++i) map->global_nodes[i] = (int)i;
  map->global_elements.resize(model.elements.size());
  for (size_t e = 0; e < model.elements.size(); ++e) map->global_elements[e] = (int)e;
  map->global_joints.resize(num_joints);
  for (size_t j = 0; j < num_joints; ++j) map->global_joints[j] = (int)j;
  map->global_rigid_bodies.resize(model.rigid_bodies.size());
  for (size_t b = 0; b < model.rigid_bodies.size(); ++b) map->global_rigid_bodies[b] = (int)b;
  map->element_first_segment.resize(model.elements.size());
  for (size_t e = 0, segment = 0; e < model.elements.size(); segment += model.elements[e].order, ++e) map->element_first_segment[e] = (int)segment;
  map->global_count = {(PetscInt)num_nodes, (PetscInt)model.elements.size(), (PetscInt)num_joints, (PetscInt)model.rigid_bodies.size()};
  map->restricted   = false;

  // The unknowns each node depends on, masters first along every chain (a relay: its own DOFs,
  // and what its joint maps it from in relay_unknowns).
  map->node_unknowns.assign(num_nodes, {});
  for (size_t i = 0; i < num_nodes; ++i)
    for (PetscInt dof : map->node_dofs[i])
      if (dof >= 0) map->node_unknowns[i].push_back(dof);
  for (int j : chain_order) {
    const Joint           &joint    = model.joints[j];
    std::vector<PetscInt> &unknowns = is_relay[joint.slave] ? map->relay_unknowns[joint.slave] : map->node_unknowns[joint.slave];
    if (joint.master >= 0) unknowns = map->node_unknowns[joint.master];
    for (PetscInt dof : map->joint_dofs[j])
      if (dof >= 0) unknowns.push_back(dof);
  }

  // Local nodes: owned ones, then the ghosts reached by the elements this rank assembles, then
  // the masters of local slaves (recursively).
  map->node_to_local.assign(num_nodes, -1);
  map->local_nodes.clear();
  auto add_local = [map](int node) {
    if (map->node_to_local[node] >= 0) return;
    map->node_to_local[node] = (int)map->local_nodes.size();
    map->local_nodes.push_back(node);
  };
  for (size_t i = 0; i < num_nodes; ++i)
    if (node_rank[i] == rank) add_local((int)i);
  map->num_owned_nodes = (PetscInt)map->local_nodes.size();
  map->local_elements.clear();
  map->element_to_local.assign(model.elements.size(), -1);
  for (size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement &element = model.elements[e];
    if (node_rank[element.nodes[0]] != rank) continue;
    map->element_to_local[e] = (int)map->local_elements.size();
    map->local_elements.push_back((int)e);
    for (int a = 0; a < element.order + 1; ++a) add_local(element.nodes[a]);
  }
  // A force element between two nodes is evaluated by the owner of its first node, which holds the
  // second as a ghost.
  for (const ForceElement &element : model.force_elements)
    if (element.kind != ForceElement::Kind::Coordinate && node_rank[element.nodes[0]] == rank) add_local(element.nodes[1]);
  for (size_t scanned = 0; scanned < map->local_nodes.size(); ++scanned) {
    const int j = map->node_joint[map->local_nodes[scanned]];
    if (j >= 0 && model.joints[j].master >= 0) add_local(model.joints[j].master);
  }
  map->local_joints.clear();
  map->joint_to_local.assign(num_joints, -1);
  for (int j : chain_order)
    if (map->node_to_local[model.joints[j].slave] >= 0) {
      map->joint_to_local[j] = (int)map->local_joints.size();
      map->local_joints.push_back(j);
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The entries of `list` (model indices) that `to_local` maps to a local index, renumbered.
static std::vector<int> RestrictList(const std::vector<int> &to_local, const std::vector<int> &list)
{
  std::vector<int> kept;
  for (int index : list)
    if (to_local[index] >= 0) kept.push_back(to_local[index]);
  return kept;
}

// out[k] = in[local[k]]: a per-model-entry array cut down to the local entries, in local order.
template <class T> static std::vector<T> RestrictArray(const std::vector<int> &local, const std::vector<T> &array)
{
  std::vector<T> restricted;
  restricted.reserve(local.size());
  for (int index : local) restricted.push_back(array[index]);
  return restricted;
}

static std::vector<int> Identity(size_t n)
{
  std::vector<int> identity(n);
  for (size_t i = 0; i < n; ++i) identity[i] = (int)i;
  return identity;
}

PetscErrorCode DofMapRestrictToLocal(const Model &model, const DofMap &map, Model *local_model, DofMap *local_map)
{
  PetscFunctionBeginUser;
  PetscCheck(!map.restricted, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONGSTATE, "the model is already restricted to the local part");
  const std::vector<int> &node_to_local = map.node_to_local;
  const auto              local_node    = [&](int node) { return node >= 0 ? node_to_local[node] : -1; };
  Model                  &local         = *local_model;

  // The model: local entities in local order, node and element references renumbered.
  local            = Model{};
  local.input_file = model.input_file;
  local.functions  = model.functions;
  local.sections   = model.sections;
  local.analysis   = model.analysis;
  local.output     = model.output;
  local.nodes      = RestrictArray(map.local_nodes, model.nodes);
  for (const Beam &beam : model.beams) { // names and places for messages only
    Beam named;
    named.name    = beam.name;
    named.section = beam.section;
    named.order   = beam.order;
    named.mark    = beam.mark;
    local.beams.push_back(std::move(named));
  }
  local.elements = RestrictArray(map.local_elements, model.elements);
  for (BeamElement &element : local.elements)
    for (int a = 0; a <= element.order; ++a) element.nodes[a] = local_node(element.nodes[a]);
  local.joints = RestrictArray(map.local_joints, model.joints);
  for (Joint &joint : local.joints) joint.master = local_node(joint.master), joint.slave = local_node(joint.slave);
  local.supports = model.supports;
  for (Support &support : local.supports) support.nodes = RestrictList(node_to_local, support.nodes);
  local.nodal_loads = model.nodal_loads;
  for (NodalLoad &load : local.nodal_loads) load.nodes = RestrictList(node_to_local, load.nodes);
  local.distributed_loads = model.distributed_loads;
  for (DistributedLoad &load : local.distributed_loads) load.elements = RestrictList(map.element_to_local, load.elements);
  local.initial_conditions = model.initial_conditions;
  for (InitialCondition &condition : local.initial_conditions) condition.nodes = RestrictList(node_to_local, condition.nodes);
  local.probes = model.probes;
  for (Probe &probe : local.probes) {
    probe.node    = local_node(probe.node);
    probe.element = probe.element >= 0 ? map.element_to_local[probe.element] : -1;
  }
  // Force elements: those on a local joint's coordinate, and those between two local nodes.
  for (const ForceElement &element : model.force_elements) {
    ForceElement kept = element;
    if (element.kind == ForceElement::Kind::Coordinate) {
      kept.joint = map.joint_to_local[element.joint];
      if (kept.joint < 0) continue;
    } else {
      kept.nodes = {{local_node(element.nodes[0]), local_node(element.nodes[1])}};
      if (kept.nodes[0] < 0 || kept.nodes[1] < 0) continue;
    }
    local.force_elements.push_back(std::move(kept));
  }
  for (const CoordinateInitialCondition &condition : model.coordinate_initial_conditions)
    if (map.joint_to_local[condition.joint] >= 0) {
      local.coordinate_initial_conditions.push_back(condition);
      local.coordinate_initial_conditions.back().joint = map.joint_to_local[condition.joint];
    }
  local.expected = model.expected;
  std::vector<int> body_numbers;
  for (size_t b = 0; b < model.rigid_bodies.size(); ++b) {
    const RigidBody &body = model.rigid_bodies[b];
    if (local_node(body.node) < 0) continue;
    local.rigid_bodies.push_back(body);
    local.rigid_bodies.back().node = local_node(body.node);
    body_numbers.push_back(map.global_rigid_bodies[b]);
  }

  // The map: per-node and per-joint arrays in local order, indices renumbered.
  DofMap &out         = *local_map;
  out                 = DofMap{};
  out.num_global      = map.num_global;
  out.num_owned       = map.num_owned;
  out.first_owned     = map.first_owned;
  out.num_owned_nodes = map.num_owned_nodes;
  out.node_rank       = RestrictArray(map.local_nodes, map.node_rank);
  out.node_dofs       = RestrictArray(map.local_nodes, map.node_dofs);
  out.constraints     = RestrictArray(map.local_nodes, map.constraints);
  out.node_unknowns   = RestrictArray(map.local_nodes, map.node_unknowns);
  out.num_relays      = map.num_relays;
  if (map.num_relays > 0) {
    out.relay_forces   = RestrictArray(map.local_nodes, map.relay_forces);
    out.relay_unknowns = RestrictArray(map.local_nodes, map.relay_unknowns);
  }
  out.global_nodes = RestrictArray(map.local_nodes, map.global_nodes);
  out.node_joint   = RestrictArray(map.local_nodes, map.node_joint);
  for (int &joint : out.node_joint) joint = joint >= 0 ? map.joint_to_local[joint] : -1;
  out.global_elements        = RestrictArray(map.local_elements, map.global_elements);
  out.element_first_segment  = RestrictArray(map.local_elements, map.element_first_segment);
  out.joint_rank             = RestrictArray(map.local_joints, map.joint_rank);
  out.joint_dofs             = RestrictArray(map.local_joints, map.joint_dofs);
  out.joint_slot             = RestrictArray(map.local_joints, map.joint_slot);
  out.global_joints          = RestrictArray(map.local_joints, map.global_joints);
  out.global_rigid_bodies    = std::move(body_numbers);
  out.first_owned_joint_slot = map.first_owned_joint_slot;
  out.num_owned_joints       = map.num_owned_joints;
  out.global_count           = map.global_count;
  out.local_nodes            = Identity(map.local_nodes.size());
  out.node_to_local          = out.local_nodes;
  out.local_elements         = Identity(map.local_elements.size());
  out.element_to_local       = out.local_elements;
  out.local_joints           = Identity(map.local_joints.size());
  out.joint_to_local         = out.local_joints;
  out.restricted             = true;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode DofMapPreallocation(const DofMap &map, const Model &model, std::vector<PetscInt> *diagonal_nonzeros,
                                   std::vector<PetscInt> *off_diagonal_nonzeros, std::vector<PetscInt> *row_start, std::vector<PetscInt> *pattern_columns)
{
  PetscFunctionBeginUser;
  // A row r couples with every unknown of every group that contains it: an element's group is the
  // unknowns of all its nodes, a node's group its own unknowns. r is in the groups of its holders,
  // the nodes whose unknowns include r, so columns(r) = union over holders h of C(h), with C(h) =
  // the unknowns of h and of every node sharing an element or a two-node force element with h. A slave's unknowns are its
  // master's followed by its joint's, so the holders of r are the node o(r) that r belongs to (its
  // own DOF, or its joint's coordinate) and every node hanging from o(r) through joints: its
  // subtree in the joint forest. Hence columns(r) = D(o(r)) with D(n) = C(n) united with D(c) over
  // the slaves c of n, built once per node from its slaves' sets. The cost is that of the result
  // (times a logarithm): a chain of N joints, whose last slave depends on every coordinate, has N^2
  // nonzeros and takes O(N^2 log N), not the O(N^3) of uniting the holders' sets row by row.
  const PetscInt   first = map.first_owned, last = map.first_owned + map.num_owned;
  const size_t     num_nodes = map.node_unknowns.size();
  constexpr int    kRelayRow = -2;                                 // row_node of the rows no node holds: a relay's forces and its joint's coordinates
  std::vector<int> element_start(num_nodes + 1, 0), node_elements; // node -> elements touching it
  for (const BeamElement &element : model.elements)
    for (int a = 0; a <= element.order; ++a) ++element_start[element.nodes[a] + 1];
  for (size_t n = 0; n < num_nodes; ++n) element_start[n + 1] += element_start[n];
  node_elements.resize((size_t)element_start[num_nodes]);
  {
    std::vector<int> next(element_start.begin(), element_start.end() - 1);
    for (size_t e = 0; e < model.elements.size(); ++e)
      for (int a = 0; a <= model.elements[e].order; ++a) node_elements[(size_t)next[model.elements[e].nodes[a]]++] = (int)e;
  }
  // Force elements between two nodes couple them like a 2-node element: node -> partners.
  std::vector<int> partner_start(num_nodes + 1, 0), partners;
  for (const ForceElement &element : model.force_elements)
    if (element.kind != ForceElement::Kind::Coordinate) ++partner_start[element.nodes[0] + 1], ++partner_start[element.nodes[1] + 1];
  for (size_t n = 0; n < num_nodes; ++n) partner_start[n + 1] += partner_start[n];
  partners.resize((size_t)partner_start[num_nodes]);
  {
    std::vector<int> next(partner_start.begin(), partner_start.end() - 1);
    for (const ForceElement &element : model.force_elements)
      if (element.kind != ForceElement::Kind::Coordinate) {
        partners[(size_t)next[element.nodes[0]]++] = element.nodes[1];
        partners[(size_t)next[element.nodes[1]]++] = element.nodes[0];
      }
  }
  // C(h), unsorted, appended to `columns`.
  const auto add_node_columns = [&](int h, std::vector<PetscInt> *columns) {
    columns->insert(columns->end(), map.node_unknowns[h].begin(), map.node_unknowns[h].end());
    for (int k = partner_start[h]; k < partner_start[h + 1]; ++k)
      columns->insert(columns->end(), map.node_unknowns[partners[(size_t)k]].begin(), map.node_unknowns[partners[(size_t)k]].end());
    for (int k = element_start[h]; k < element_start[h + 1]; ++k) {
      const BeamElement &element = model.elements[(size_t)node_elements[(size_t)k]];
      for (int a = 0; a <= element.order; ++a)
        columns->insert(columns->end(), map.node_unknowns[element.nodes[a]].begin(), map.node_unknowns[element.nodes[a]].end());
    }
  };
  const auto sort_unique = [](std::vector<PetscInt> *columns) {
    std::sort(columns->begin(), columns->end());
    columns->erase(std::unique(columns->begin(), columns->end()), columns->end());
  };

  // o(r) for the owned rows.
  std::vector<int> row_node(map.num_owned, -1);
  for (size_t n = 0; n < num_nodes && n < map.node_dofs.size(); ++n)
    for (PetscInt row : map.node_dofs[n])
      if (row >= first && row < last) row_node[row - first] = (int)n;
  for (size_t j = 0; j < map.joint_dofs.size(); ++j)
    for (PetscInt row : map.joint_dofs[j])
      if (row >= first && row < last) row_node[row - first] = map.IsRelay(model.joints[j].slave) ? kRelayRow : model.joints[j].slave;

  // Relay nodes (DofMap::relay_forces): their coupling and their joint's geometric stiffness. With U
  // a relay's relay_unknowns, s its own DOFs and f its force unknowns: rows U couple with U, s and
  // f; rows s with f and U (and, as holders, through their elements); rows f with s, U and f (the
  // diagonal entry a shift of the diagonal needs, MatDiagonalSet). Its joint's coordinates are in
  // U and have no holder.
  std::vector<std::vector<PetscInt>> relay_columns(map.num_relays > 0 ? map.num_owned : 0);
  if (map.num_relays > 0) {
    for (size_t n = 0; n < num_nodes; ++n)
      if (map.IsRelay((int)n))
        for (PetscInt row : map.relay_forces[n])
          if (row >= first && row < last) row_node[row - first] = kRelayRow;
    const auto add = [&](PetscInt row, const PetscInt *columns, size_t count) {
      if (row >= first && row < last) relay_columns[row - first].insert(relay_columns[row - first].end(), columns, columns + count);
    };
    for (size_t n = 0; n < num_nodes; ++n) {
      if (!map.IsRelay((int)n)) continue;
      const std::vector<PetscInt> &U = map.relay_unknowns[n];
      const PetscInt              *s = map.node_dofs[n].data(), *f = map.relay_forces[n].data();
      for (PetscInt row : U) add(row, U.data(), U.size()), add(row, s, 6), add(row, f, 6);
      for (int i = 0; i < 6; ++i) add(s[i], f, 6), add(s[i], U.data(), U.size());
      for (int i = 0; i < 6; ++i) add(f[i], s, 6), add(f[i], U.data(), U.size()), add(f[i], f, 6);
    }
  }

  // The joint forest: the slaves of each node; D is needed apart from C only for nodes with slaves.
  std::vector<int> slave_start(num_nodes + 1, 0), slaves, master_of(num_nodes, -1);
  for (size_t n = 0; n < num_nodes; ++n)
    if (const int j = map.node_joint[n]; j >= 0 && model.joints[j].master >= 0) {
      master_of[n] = model.joints[j].master;
      ++slave_start[master_of[n] + 1];
    }
  for (size_t n = 0; n < num_nodes; ++n) slave_start[n + 1] += slave_start[n];
  slaves.resize((size_t)slave_start[num_nodes]);
  {
    std::vector<int> next(slave_start.begin(), slave_start.end() - 1);
    for (size_t n = 0; n < num_nodes; ++n)
      if (master_of[n] >= 0) slaves[(size_t)next[master_of[n]]++] = (int)n;
  }
  const auto has_slaves = [&](int n) { return slave_start[n + 1] > slave_start[n]; };
  // Nodes with slaves, slaves' subtrees first: masters by decreasing depth in their tree.
  std::vector<int> tree_nodes, depth(num_nodes, -1), path;
  for (size_t start = 0; start < num_nodes; ++start) {
    if (!has_slaves((int)start)) continue;
    tree_nodes.push_back((int)start);
    for (int n = (int)start; depth[n] < 0;) {
      path.push_back(n);
      if (master_of[n] < 0) break;
      n = master_of[n];
    }
    if (path.empty()) continue; // its depth was set on the walk up from one of its slaves
    // The depth above the walked path: that of the node the walk stopped at, or -1 above a root.
    int known = master_of[path.back()] >= 0 ? depth[master_of[path.back()]] : -1;
    for (auto at = path.rbegin(); at != path.rend(); ++at) depth[*at] = ++known;
    path.clear();
  }
  std::stable_sort(tree_nodes.begin(), tree_nodes.end(), [&](int a, int b) { return depth[a] > depth[b]; });
  // D of each node with slaves, and the columns of its owned rows, recorded when D is made; a
  // slave's D is dropped once its master's is made.
  std::vector<std::vector<PetscInt>> tree_columns(num_nodes), row_columns(map.num_owned);
  std::vector<char>                  from_tree(map.num_owned, 0);
  std::vector<int>                   node_first_row(num_nodes, -1);
  for (PetscInt r = map.num_owned - 1; r >= 0; --r)
    if (row_node[r] >= 0) node_first_row[row_node[r]] = (int)r;
  for (const int n : tree_nodes) {
    std::vector<PetscInt> &columns = tree_columns[n];
    add_node_columns(n, &columns);
    for (int k = slave_start[n]; k < slave_start[n + 1]; ++k) {
      const int c = slaves[(size_t)k];
      if (map.IsRelay(c)) continue; // its holders are its own (the coupling is in relay_columns)
      if (has_slaves(c)) {
        columns.insert(columns.end(), tree_columns[c].begin(), tree_columns[c].end());
        std::vector<PetscInt>().swap(tree_columns[c]);
      } else add_node_columns(c, &columns);
    }
    sort_unique(&columns);
    if (node_first_row[n] >= 0)
      for (PetscInt r = node_first_row[n]; r < map.num_owned && row_node[r] == n; ++r) {
        row_columns[r] = columns;
        from_tree[r]   = 1;
      }
  }
  std::vector<std::vector<PetscInt>>().swap(tree_columns);

  diagonal_nonzeros->assign(map.num_owned, 0);
  off_diagonal_nonzeros->assign(map.num_owned, 0);
  const bool want_pattern = row_start && pattern_columns;
  if (want_pattern) {
    row_start->assign(map.num_owned + 1, 0);
    pattern_columns->clear();
  }
  std::vector<PetscInt> node_columns;
  int                   cached_node = -1; // node_columns holds C(cached_node) when >= 0
  std::vector<PetscInt> merged;
  for (PetscInt r = 0; r < map.num_owned; ++r) {
    const std::vector<PetscInt> *columns = &row_columns[r];
    if (row_node[r] == kRelayRow) {
      columns = &merged;
      merged.clear();
    } else if (!from_tree[r]) {
      const int n = row_node[r];
      PetscCheck(n >= 0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "unknown %" PetscInt_FMT " belongs to no node", first + r);
      if (n != cached_node) {
        node_columns.clear();
        add_node_columns(n, &node_columns);
        sort_unique(&node_columns);
        cached_node = n;
      }
      columns = &node_columns;
    }
    if (!relay_columns.empty() && !relay_columns[r].empty()) {
      if (columns != &merged) merged = *columns;
      merged.insert(merged.end(), relay_columns[r].begin(), relay_columns[r].end());
      sort_unique(&merged);
      columns = &merged;
      std::vector<PetscInt>().swap(relay_columns[r]);
    }
    for (PetscInt column : *columns) ++(column >= first && column < last ? (*diagonal_nonzeros)[r] : (*off_diagonal_nonzeros)[r]);
    if (want_pattern) {
      pattern_columns->insert(pattern_columns->end(), columns->begin(), columns->end());
      (*row_start)[r + 1] = (PetscInt)pattern_columns->size();
    }
    std::vector<PetscInt>().swap(row_columns[r]);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
