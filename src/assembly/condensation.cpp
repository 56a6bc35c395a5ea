// Condensation of slave nodes at assembly (Muñoz, Jelenić & Crisfield 2003, eq. 5–8): a slave's
// spin residual g goes to its master and its joint's released coordinates through N^T, its
// stiffness through N^T K N, plus the joint's geometric stiffness d(N^T g)/d(theta_m, q). Chains
// compose: every local node carries an expansion (rows, columns) into the global unknowns it
// depends on (DofMap::node_unknowns):
//   independent node: rows = I on its free DOFs, columns = blockdiag(I, H(omega))
//   slave node:       rows = N_m rows_master (+) N_q,  columns = N_m columns_master (+) N_q
// where N_m (6x6) and N_q (6xk) are the master and released-coordinate parts of N, restricted to
// the coordinates that are not driven. The rows use the joints' rows map (the conserving map of
// the mid-point schemes), the columns N itself (state/state.hpp, StateUpdateSlaves).
// Relay nodes (DofMap) cut long chains: a relay expands like an independent node onto its own DOFs,
// in spins (columns = I), so the slaves below it depend on at most condensation_depth joints; its
// joint enters the linear solve through AddRelayCoupling, and its gathered force passes up in
// FinishRelayForces, so the residual stays the condensed one.
#include "assembly/assembler.hpp"

#include <algorithm>
#include <cstring>

namespace msflex {

// values (m) = map^T g, map 6 x m row-major: a node's spin vector g through its expansion.
static void TransposedTimes(const double *map, int m, const double *g, double *values)
{
  for (int col = 0; col < m; ++col) {
    values[col] = 0.0;
    for (int i = 0; i < 6; ++i) values[col] += map[i * m + col] * g[i];
  }
}

void Assembler::IndependentExpansion(int l, double *rows, double *columns) const
{
  const NodeState               &s    = state_->nodes[l];
  const std::array<PetscInt, 6> &dofs = map_->node_dofs[map_->local_nodes[l]];
  // In the initial-acceleration problem the unknowns are the accelerations themselves, and a
  // relay's own unknowns are spin increments: no H.
  const Mat3 H      = state_->equations.InitialAcceleration() || map_->IsRelay(l) ? Mat3::Identity() : s.rotation_tangent;
  const int  m      = (int)map_->node_unknowns[map_->local_nodes[l]].size();
  int        column = 0;
  for (int i = 0; i < 6 * m; ++i) rows[i] = columns[i] = 0.0;
  for (int d = 0; d < 6; ++d) {
    if (dofs[d] < 0) continue;
    rows[d * m + column] = 1.0;
    if (d < 3) columns[d * m + column] = 1.0;
    else
      for (int i = 0; i < 3; ++i) columns[(3 + i) * m + column] = H(i, d - 3);
    ++column;
  }
}

void Assembler::NodeExpansion(int l, const double **rows, const double **columns, double *scratch_rows, double *scratch_columns) const
{
  if (IsCondensed(l)) {
    *rows    = expansion_rows_[l].data();
    *columns = expansion_columns_[l].data();
    return;
  }
  IndependentExpansion(l, scratch_rows, scratch_columns);
  *rows    = scratch_rows;
  *columns = scratch_columns;
}

void Assembler::UpdateExpansions()
{
  double master_rows[6 * 6 * kJointMaxReleased], master_columns[6 * 6 * kJointMaxReleased];
  for (size_t j = 0; j < state_->joints.size(); ++j) {
    const JointState  &J      = state_->joints[j];
    const Joint       &joint  = model_->joints[J.joint];
    const JointMatrix &N      = J.map;
    const JointMatrix &N_rows = J.rows_map;
    // Expansion: the master's (through N_m) followed by the free released coordinates (N_q); a
    // relay's is its joint's map from relay_unknowns.
    const int            m        = (int)map_->JointMapUnknowns(joint.slave).size();
    std::vector<double> &rows     = expansion_rows_[J.local_slave];
    std::vector<double> &columns  = expansion_columns_[J.local_slave];
    int                  m_master = 0;
    std::fill(rows.begin(), rows.end(), 0.0);
    std::fill(columns.begin(), columns.end(), 0.0);
    if (J.local_master >= 0) {
      const double *mr, *mc;
      NodeExpansion(J.local_master, &mr, &mc, master_rows, master_columns);
      m_master = (int)map_->node_unknowns[joint.master].size();
      for (int i = 0; i < 6; ++i)
        for (int col = 0; col < m_master; ++col) {
          double r = 0.0, c = 0.0;
          for (int k = 0; k < 6; ++k) r += N_rows(i, k) * mr[k * m_master + col], c += N(i, k) * mc[k * m_master + col];
          rows[i * m + col]    = r;
          columns[i * m + col] = c;
        }
    }
    int column = m_master;
    for (int c = 0; c < JointNumCoordinates(J.geometry); ++c) {
      if (joint_slots_[j][c] < 0) continue;
      for (int i = 0; i < 6; ++i) rows[i * m + column] = N_rows(i, 6 + c), columns[i * m + column] = N(i, 6 + c);
      ++column;
    }
  }
}

PetscErrorCode Assembler::AddNodeResidual(Vec residual, int l, const double *g)
{
  PetscFunctionBeginUser;
  const int node = map_->local_nodes[l];
  if (collect_reactions_ && reaction_slot_[l] >= 0) reaction_sums_[reaction_slot_[l]] += Eigen::Map<const Vec6>(g);
  for (int d = 0; d < 6; ++d) {
    local_force_squares_ += g[d] * g[d];
    if (map_->constraints[node][d].kind == Support::Kind::Prescribed) prescribed_residual_[l](d) += g[d];
  }
  if (!IsSlave(l)) {
    PetscCall(VecSetValues(residual, 6, map_->node_dofs[node].data(), g, ADD_VALUES));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  slave_residual_[l] += Eigen::Map<const Vec6>(g);
  // The masters along the chain receive what the slave's residual passes to them through the
  // joints, N_m^T g (the master block of each joint's rows map), on their supported DOFs too,
  // which the condensation adds to no unknown: a reaction probe there (a body welded to a clamped
  // base was left out of the base's reaction) and a prescribed DOF's reaction, whose work is
  // external work (a pendulum hinged to a shaken base: em's energy balance grew by 0.46 J).
  if (passes_to_master_[l]) {
    Vec6 passed = Eigen::Map<const Vec6>(g);
    for (int node = l; IsSlave(node) && passes_to_master_[node];) {
      const JointState &J = state_->joints[state_->node_joint[node]];
      passed              = (J.rows_map.block<6, 6>(0, 0).transpose() * passed).eval();
      node                = J.local_master;
      if (collect_reactions_ && reaction_slot_[node] >= 0) reaction_sums_[reaction_slot_[node]] += passed;
      const int global = map_->local_nodes[node];
      for (int d = 0; d < 6; ++d)
        if (map_->constraints[global][d].kind == Support::Kind::Prescribed) prescribed_residual_[node](d) += passed(d);
    }
  }
  if (map_->IsRelay(l)) {
    relay_force_[l] += Eigen::Map<const Vec6>(g); // passed up by FinishRelayForces
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const std::vector<PetscInt> &unknowns = map_->node_unknowns[node];
  const int                    m        = (int)unknowns.size();
  double                      *values   = expansion_scratch_.data();
  TransposedTimes(expansion_rows_[l].data(), m, g, values);
  // The force level counts the terms as they enter the residual: through a joint a force becomes a
  // moment about the master, its lever arm as long as the chain, and the rounding of those terms
  // is the residual's floor there.
  for (int i = 0; i < m; ++i) local_force_squares_ += values[i] * values[i];
  PetscCall(AddThroughAnchor(residual, relay_anchor_[l], m, unknowns.data(), values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddThroughAnchor(Vec v, int anchor, PetscInt m, const PetscInt *unknowns, const double *values)
{
  PetscFunctionBeginUser;
  if (anchor >= 0) {
    // The anchor relay's own DOFs come first in the unknowns: its share is gathered on it.
    relay_force_[anchor] += Eigen::Map<const Vec6>(values);
    unknowns += 6, values += 6, m -= 6;
  }
  PetscCall(VecSetValues(v, m, unknowns, values, ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::FinishRelayForces(Vec residual)
{
  PetscFunctionBeginUser;
  // Deepest relays first: each passes R^T (its gathered force) to its anchor's unknowns, a relay
  // anchor gathering its share for its own turn.
  for (size_t k = relay_joints_.size(); k-- > 0;) {
    const JointState            &J        = state_->joints[relay_joints_[k]];
    const int                    s        = J.local_slave;
    const std::vector<PetscInt> &unknowns = map_->relay_unknowns[s];
    const int                    m        = (int)unknowns.size();
    double                      *values   = expansion_scratch_.data();
    const Vec6                   g        = relay_force_[s];
    relay_force_[s].setZero();
    TransposedTimes(expansion_rows_[s].data(), m, g.data(), values);
    for (int i = 0; i < m; ++i) local_force_squares_ += values[i] * values[i]; // as in AddNodeResidual
    PetscCall(AddThroughAnchor(residual, relay_anchor_[s], m, unknowns.data(), values));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddRelayCoupling(Mat matrix)
{
  PetscFunctionBeginUser;
  for (const int j : relay_joints_) {
    const JointState &J = state_->joints[j];
    const int         s = J.local_slave;
    if (s >= map_->num_owned_nodes) continue; // the owner adds it
    const std::vector<PetscInt>   &unknowns = map_->relay_unknowns[s];
    const std::array<PetscInt, 6> &own = map_->node_dofs[s], &force = map_->relay_forces[s];
    const int                      m    = (int)unknowns.size();
    const double                  *rows = expansion_rows_[s].data(), *columns = expansion_columns_[s].data();
    double                        *values = expansion_scratch_.data();
    // [s, lambda] = [lambda, s] = -I, [lambda, U] = C, [U, lambda] = R^T.
    for (int i = 0; i < 6; ++i) PetscCall(MatSetValue(matrix, own[i], force[i], -1.0, ADD_VALUES));
    for (int i = 0; i < 6; ++i) PetscCall(MatSetValue(matrix, force[i], own[i], -1.0, ADD_VALUES));
    PetscCall(MatSetValues(matrix, 6, force.data(), m, unknowns.data(), columns, ADD_VALUES));
    for (int a = 0; a < m; ++a)
      for (int i = 0; i < 6; ++i) values[a * 6 + i] = rows[i * m + a];
    PetscCall(MatSetValues(matrix, m, unknowns.data(), 6, force.data(), values, ADD_VALUES));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::CopyRelayEntries(Vec from, Vec to) const
{
  const PetscScalar *source;
  PetscScalar       *target;
  PetscFunctionBeginUser;
  if (relay_rows_.empty()) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArrayRead(from, &source));
  PetscCall(VecGetArray(to, &target));
  for (const PetscInt row : relay_rows_) target[row] = source[row];
  PetscCall(VecRestoreArray(to, &target));
  PetscCall(VecRestoreArrayRead(from, &source));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::ZeroRelayEntries(Vec v) const
{
  PetscScalar *values;
  PetscFunctionBeginUser;
  if (relay_rows_.empty()) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArray(v, &values));
  for (const PetscInt row : relay_rows_) values[row] = 0.0;
  PetscCall(VecRestoreArray(v, &values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::DropRelayReachedRows(std::vector<PetscInt> *empty_rows) const
{
  const DofMap &map = *map_;
  Vec           reached;
  PetscFunctionBeginUser;
  // reached = 1 on the rows some term reaches; then, deepest relays first and in rounds until the
  // count stops growing (a chain may cross ranks), a relay whose own rows are reached reaches what
  // its joint maps it from. A relay's own and force rows are never empty: the coupling holds them.
  const auto owned = [&](PetscInt row) { return row >= map.first_owned && row < map.first_owned + map.num_owned; };
  PetscCall(VecDuplicate(solution_template_, &reached));
  PetscCall(VecSet(reached, 1.0));
  for (PetscInt row : *empty_rows) PetscCall(VecSetValue(reached, row, 0.0, INSERT_VALUES));
  PetscCall(VecAssemblyBegin(reached));
  PetscCall(VecAssemblyEnd(reached));
  for (PetscReal count = -1.0;;) {
    PetscReal             new_count;
    std::vector<PetscInt> elsewhere;
    PetscScalar          *values;
    PetscCall(VecGetArray(reached, &values));
    for (size_t k = relay_joints_.size(); k-- > 0;) {
      const int s = state_->joints[relay_joints_[k]].local_slave;
      if (s >= map.num_owned_nodes) continue;
      bool own_reached = false;
      for (int i = 0; i < 6; ++i) own_reached |= PetscRealPart(values[map.node_dofs[s][i] - map.first_owned]) > 0.0;
      if (!own_reached) continue;
      // The unknowns of U its joint's map moves the relay by.
      const std::vector<PetscInt> &unknowns = map.relay_unknowns[s];
      const int                    m        = (int)unknowns.size();
      for (int a = 0; a < m; ++a) {
        bool moves = false;
        for (int i = 0; i < 6; ++i) moves |= expansion_columns_[s][i * m + a] != 0.0 || expansion_rows_[s][i * m + a] != 0.0;
        if (!moves) continue;
        if (owned(unknowns[a])) values[unknowns[a] - map.first_owned] = 1.0;
        else elsewhere.push_back(unknowns[a]);
      }
    }
    PetscCall(VecRestoreArray(reached, &values));
    for (PetscInt row : elsewhere) PetscCall(VecSetValue(reached, row, 1.0, INSERT_VALUES));
    PetscCall(VecAssemblyBegin(reached));
    PetscCall(VecAssemblyEnd(reached));
    PetscCall(VecSum(reached, &new_count));
    if (new_count == count) break;
    count = new_count;
  }
  std::vector<char> relay_row(map.num_owned, 0);
  for (const PetscInt row : relay_rows_) relay_row[row] = 1;
  const PetscScalar *values;
  PetscCall(VecGetArrayRead(reached, &values));
  std::vector<PetscInt> still_empty;
  for (PetscInt row : *empty_rows)
    if (!relay_row[row - map.first_owned] && PetscRealPart(values[row - map.first_owned]) == 0.0) still_empty.push_back(row);
  PetscCall(VecRestoreArrayRead(reached, &values));
  PetscCall(VecDestroy(&reached));
  empty_rows->swap(still_empty);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddNodeVector(Vec v, int l, const double *g, Through through)
{
  PetscFunctionBeginUser;
  const int node = map_->local_nodes[l];
  if (!IsCondensed(l)) {
    double values[6];
    for (int i = 0; i < 6; ++i) values[i] = g[i];
    // Columns: d theta = H(omega) d omega, so the gradient in omega is H^T times the spin gradient
    // (a relay's own unknowns are spins, and the coupling carries the vector on through the solve).
    if (through == Through::Columns && !state_->equations.InitialAcceleration() && !map_->IsRelay(l)) {
      const Vec3 rotated = state_->nodes[l].rotation_tangent.transpose() * Vec3(g[3], g[4], g[5]);
      for (int i = 0; i < 3; ++i) values[3 + i] = rotated(i);
    }
    PetscCall(VecSetValues(v, 6, map_->node_dofs[node].data(), values, ADD_VALUES));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const std::vector<PetscInt> &unknowns = map_->node_unknowns[node];
  const int                    m        = (int)unknowns.size();
  const double                *map      = through == Through::Rows ? expansion_rows_[l].data() : expansion_columns_[l].data();
  double                      *values   = expansion_scratch_.data();
  TransposedTimes(map, m, g, values);
  PetscCall(VecSetValues(v, m, unknowns.data(), values, ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

Mat6 Assembler::NodeBlockInUnknowns(int l, const Mat6 &block) const
{
  // Columns from spins to the node's unknowns: d theta = H(omega) d omega (accelerations and
  // relays: I).
  Mat6 columns = block;
  if (!state_->equations.InitialAcceleration() && !map_->IsRelay(l)) columns.rightCols<3>() = (block.rightCols<3>() * state_->nodes[l].rotation_tangent).eval();
  return columns;
}

PetscErrorCode Assembler::AddNodeBlock(Mat jacobian, int l, const Mat6 &block)
{
  PetscFunctionBeginUser;
  const int node = map_->local_nodes[l];
  if (!IsCondensed(l)) {
    const Mat6 columns = NodeBlockInUnknowns(l, block);
    PetscInt   block_index;
    if (NodeBlockIndices(1, map_->node_dofs[node].data(), &block_index))
      PetscCall(MatSetValuesBlocked(jacobian, 1, &block_index, 1, &block_index, columns.data(), ADD_VALUES));
    else PetscCall(MatSetValues(jacobian, 6, map_->node_dofs[node].data(), 6, map_->node_dofs[node].data(), columns.data(), ADD_VALUES));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const std::vector<PetscInt> &unknowns = map_->node_unknowns[node];
  const int                    m        = (int)unknowns.size();
  const double                *rows = expansion_rows_[l].data(), *columns = expansion_columns_[l].data();
  double                      *values = expansion_scratch_.data(), *block_columns = expansion_product_scratch_.data();
  // R^T (block C) with block C (6 x m) formed once: 36 m + 6 m^2 products rather than 36 m^2 (a
  // slave deep in a chain of joints depends on many unknowns).
  for (int i = 0; i < 6; ++i)
    for (int b = 0; b < m; ++b) {
      double v = 0.0;
      for (int j = 0; j < 6; ++j) v += block(i, j) * columns[j * m + b];
      block_columns[i * m + b] = v;
    }
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) {
      double v = 0.0;
      for (int i = 0; i < 6; ++i) v += rows[i * m + a] * block_columns[i * m + b];
      values[a * m + b] = v;
    }
  PetscCall(MatSetValues(jacobian, m, unknowns.data(), m, unknowns.data(), values, ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddDirectNodeBlock(Mat jacobian, int l, const Mat6 &block, PetscScalar *diagonal_values)
{
  PetscFunctionBeginUser;
  const PetscInt *destination =
      node_csr_destinations_.empty() || !diagonal_values ? nullptr : node_csr_destinations_.data() + NodeDestinationCount() * (size_t)l;
  if (!destination || destination[0] == kCsrOtherRank) {
    PetscCall(AddNodeBlock(jacobian, l, block));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const Mat6 columns = NodeBlockInUnknowns(l, block);
  if (node_blocks_) {
    if (destination[0] != kCsrSkip) AddToStoredBlock(columns.data(), 6, diagonal_values + destination[0]);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  for (int e = 0; e < 36; ++e)
    if (destination[e] >= 0) diagonal_values[destination[e]] += columns.data()[e];
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddExpandedMatrix(Mat jacobian, int num_nodes, const int *local_nodes, const double *K)
{
  const int              nd = 6 * num_nodes;
  double                 scratch_rows[kBeamMaxNodes][36], scratch_columns[kBeamMaxNodes][36];
  const double          *rows[kBeamMaxNodes], *columns[kBeamMaxNodes];
  int                    offset[kBeamMaxNodes + 1] = {0};
  std::vector<PetscInt> &indices                   = expanded_indices_scratch_;
  PetscFunctionBeginUser;
  indices.clear();
  for (int a = 0; a < num_nodes; ++a) {
    const int l = local_nodes[a];
    NodeExpansion(l, &rows[a], &columns[a], scratch_rows[a], scratch_columns[a]);
    const std::vector<PetscInt> &unknowns = map_->node_unknowns[map_->local_nodes[l]];
    indices.insert(indices.end(), unknowns.begin(), unknowns.end());
    offset[a + 1] = (int)indices.size();
  }
  const int M = (int)indices.size();
  if ((int)expansion_scratch_.size() < M * M) expansion_scratch_.resize(M * M);
  double *values = expansion_scratch_.data();
  if ((int)expansion_product_scratch_.size() < 6 * M) expansion_product_scratch_.resize(6 * M);
  double *block_columns = expansion_product_scratch_.data();
  for (int a = 0; a < num_nodes; ++a) {
    const int ma = offset[a + 1] - offset[a];
    for (int b = 0; b < num_nodes; ++b) {
      const int mb = offset[b + 1] - offset[b];
      // K_ab C_b (6 x mb) once, then R_a^T times it.
      for (int i = 0; i < 6; ++i)
        for (int r = 0; r < mb; ++r) {
          double Kc = 0.0;
          for (int j = 0; j < 6; ++j) Kc += K[(6 * a + i) * nd + 6 * b + j] * columns[b][j * mb + r];
          block_columns[i * mb + r] = Kc;
        }
      for (int p = 0; p < ma; ++p)
        for (int r = 0; r < mb; ++r) {
          double v = 0.0;
          for (int i = 0; i < 6; ++i) v += rows[a][i * ma + p] * block_columns[i * mb + r];
          values[(offset[a] + p) * M + offset[b] + r] = v;
        }
    }
  }
  PetscCall(MatSetValues(jacobian, M, indices.data(), M, indices.data(), values, ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddJointGeometricStiffness(Mat jacobian)
{
  double     master_rows[6 * 6 * kJointMaxReleased], master_columns[6 * 6 * kJointMaxReleased];
  const bool midpoint = state_->equations.Midpoint();
  PetscFunctionBeginUser;
  // Slaves deepest first: each passes its rows' map's master part times g on to its master before
  // the master is processed: N_m^T g, or the conserving map's in the mid-point family.
  for (size_t j = state_->joints.size(); j-- > 0;) {
    const JointState &J     = state_->joints[j];
    const Joint      &joint = model_->joints[J.joint];
    const Vec6        g     = slave_residual_[J.local_slave];
    if (g.isZero(0.0)) continue;
    JointSquare G;
    if (midpoint) {
      // d(Ntilde^T g)/d(x_m, theta_m, q) at fixed g, from the start state and the increments.
      Mat3 R_m_start = Mat3::Identity();
      Vec3 alpha_m   = Vec3::Zero();
      if (J.local_master >= 0) {
        R_m_start = QuaternionToMatrix(state_->nodes[J.local_master].rotation_start);
        alpha_m   = state_->nodes[J.local_master].tangent_scaled_increment;
      }
      JointConservingGeometricStiffness(J.geometry, J.start, J.increment, R_m_start, alpha_m, g, &G);
    } else {
      Mat3 R_m = Mat3::Identity();
      if (J.local_master >= 0) R_m = state_->nodes[J.local_master].rotation;
      JointCoordinates q = J.start;
      for (int c = 0; c < kJointMaxReleased; ++c) q.q[c] += J.increment[c];
      JointGeometricStiffness(J.geometry, q, R_m, g, &G);
    }
    // Rows: the master's rows for (x_m, theta_m), identity for the free coordinates; columns alike.
    const int                    k        = JointNumCoordinates(J.geometry);
    const std::vector<PetscInt> &unknowns = map_->JointMapUnknowns(joint.slave);
    const int                    m        = (int)unknowns.size();
    const int                    m_master = J.local_master >= 0 ? (int)map_->node_unknowns[joint.master].size() : 0;
    // R, C ((6 + k) x m), G C and the block (m x m) live in preallocated scratch: no allocation per joint.
    using RowMajorMap   = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;
    double     *scratch = joint_geometric_scratch_.data();
    RowMajorMap R(scratch, 6 + k, m), C(scratch + (6 + k) * m, 6 + k, m), GC(scratch + 2 * (6 + k) * m, 6 + k, m), block(scratch + 3 * (6 + k) * m, m, m);
    R.setZero();
    C.setZero();
    if (J.local_master >= 0) {
      const double *mr, *mc;
      NodeExpansion(J.local_master, &mr, &mc, master_rows, master_columns);
      for (int i = 0; i < 6; ++i)
        for (int col = 0; col < m_master; ++col) R(i, col) = mr[i * m_master + col], C(i, col) = mc[i * m_master + col];
      if (IsSlave(J.local_master)) slave_residual_[J.local_master] += J.rows_map.leftCols<6>().transpose() * g;
    }
    int column = m_master;
    for (int c = 0; c < k; ++c) {
      if (joint_slots_[j][c] < 0) continue;
      R(6 + c, column) = C(6 + c, column) = 1.0;
      ++column;
    }
    GC.noalias()    = G.topLeftCorner(6 + k, 6 + k) * C;
    block.noalias() = R.transpose() * GC;
    PetscCall(MatSetValues(jacobian, m, unknowns.data(), m, unknowns.data(), block.data(), ADD_VALUES));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

void Assembler::PropagateSlaveResiduals()
{
  for (size_t j = state_->joints.size(); j-- > 0;) {
    const JointState &J = state_->joints[j];
    if (J.local_master >= 0 && IsSlave(J.local_master))
      slave_residual_[J.local_master] += J.rows_map.leftCols<6>().transpose() * slave_residual_[J.local_slave];
  }
}

} // namespace msflex
