// Condensation of slave nodes at assembly (Muñoz, Jelenić & Crisfield 2003, eq. 5–8): a slave's
// spin residual g goes to its master and its joint's released coordinates through N^T, its
// stiffness through N^T K N, plus the joint's geometric stiffness d(N^T g)/d(theta_m, q). Chains
// compose: every local node carries an expansion (rows, columns) into the global unknowns it
// depends on (DofMap::node_unknowns):
//   independent node: rows = I on its free DOFs, columns = blockdiag(I, H(omega))
//   slave node:       rows = N_m rows_master (+) N_q,  columns = N_m columns_master (+) N_q
// where N_m (6x6) and N_q (6xk) are the master and released-coordinate parts of N, restricted to
// the coordinates that are not driven.
#include "assembly/assembler.hpp"
#include "joints/joint_model.hpp"

#include <algorithm>
#include <cstring>

namespace msflex {

void Assembler::IndependentExpansion(int l, double *rows, double *columns) const
{
  const NodeState               &s    = nodes_[l];
  const std::array<PetscInt, 6> &dofs = map_->node_dofs[map_->local_nodes[l]];
  // In the initial-acceleration problem the unknowns are the accelerations themselves: no H.
  const Mat3 H      = mode_ == Mode::InitialAcceleration ? Mat3::Identity() : s.rotation_tangent;
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
  if (node_local_joint_[l] >= 0) {
    *rows    = expansion_rows_[l].data();
    *columns = expansion_columns_[l].data();
    return;
  }
  IndependentExpansion(l, scratch_rows, scratch_columns);
  *rows    = scratch_rows;
  *columns = scratch_columns;
}

void Assembler::UpdateSlaves()
{
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  double        master_rows[6 * 6 * kJointMaxReleased], master_columns[6 * 6 * kJointMaxReleased];
  for (LocalJoint &J : joints_) {
    const Joint &joint = ModelJoint(J);
    NodeState   &slave = nodes_[J.local_slave];
    Vec3         x_m   = model.nodes[joint.slave].position; // the ground frame sits at the slave's reference position
    Mat3         R_m   = Mat3::Identity();
    if (J.local_master >= 0) {
      x_m = nodes_[J.local_master].position;
      R_m = nodes_[J.local_master].rotation;
    }
    // In the initial-acceleration problem the increments are accelerations: the map stays at the start.
    JointCoordinates q = J.start;
    if (mode_ != Mode::InitialAcceleration)
      for (int c = 0; c < kJointMaxReleased; ++c) q.q[c] += J.increment[c];
    JointMatrix N;
    JointMap(J.geometry, q, R_m, &N);
    const int k = JointNumCoordinates(J.geometry);
    if (mode_ == Mode::InitialAcceleration) {
      // Accelerations: (xddot_s, wdot_s) = N (xddot_m, wdot_m, qddot), velocity-product terms
      // neglected (exact for a mechanism starting from rest).
      Eigen::Matrix<double, 6 + kJointMaxReleased, 1> rates = Eigen::Matrix<double, 6 + kJointMaxReleased, 1>::Zero();
      if (J.local_master >= 0)
        rates << nodes_[J.local_master].displacement_increment, nodes_[J.local_master].rotation_increment, Eigen::Matrix<double, kJointMaxReleased, 1>::Zero();
      for (int c = 0; c < k; ++c) rates(6 + c) = J.increment[c];
      const Eigen::Matrix<double, 6, 1> accelerations = N * rates;
      slave.displacement_increment                    = accelerations.head<3>();
      slave.rotation_increment                        = accelerations.tail<3>();
    } else {
      Vec3 x_s;
      Mat3 R_s;
      JointSlaveConfiguration(J.geometry, q, x_m, R_m, &x_s, &R_s);
      slave.displacement_increment = x_s - slave.position_start;
      slave.rotation_increment     = LogSO3(R_s * QuaternionToMatrix(slave.rotation_start).transpose());
      UpdateDerivedState(&slave);
    }
    // Rows of the mid-point schemes: the conserving map of eq. (21–22), so that the slave's work
    // and momenta carry over exactly; columns (the tangent, a preconditioner there): N.
    JointMatrix N_rows = N;
    for (int c = 0; c < kJointMaxReleased; ++c) J.released_test[c] = J.increment[c];
    if (mode_ == Mode::Dynamic && scheme_.Midpoint()) {
      Vec3 x_m_start = model.nodes[joint.slave].position, alpha_m = Vec3::Zero();
      Mat3 R_m_start = Mat3::Identity();
      if (J.local_master >= 0) {
        const NodeState &master = nodes_[J.local_master];
        x_m_start               = master.position_start;
        R_m_start               = QuaternionToMatrix(master.rotation_start);
        alpha_m                 = master.tangent_scaled_increment;
      }
      JointConservingMap(J.geometry, J.start, J.increment, R_m_start, alpha_m, slave.position_start - x_m_start, slave.position - x_m, &N_rows,
                         J.released_test);
    }
    J.rows_map = N_rows;
    // Expansion: the master's (through N_m) followed by the free released coordinates (N_q).
    const int            m        = (int)map.node_unknowns[joint.slave].size();
    std::vector<double> &rows     = expansion_rows_[J.local_slave];
    std::vector<double> &columns  = expansion_columns_[J.local_slave];
    int                  m_master = 0;
    std::fill(rows.begin(), rows.end(), 0.0);
    std::fill(columns.begin(), columns.end(), 0.0);
    if (J.local_master >= 0) {
      const double *mr, *mc;
      NodeExpansion(J.local_master, &mr, &mc, master_rows, master_columns);
      m_master = (int)map.node_unknowns[joint.master].size();
      for (int i = 0; i < 6; ++i)
        for (int col = 0; col < m_master; ++col) {
          double r = 0.0, c = 0.0;
          for (int j = 0; j < 6; ++j) r += N_rows(i, j) * mr[j * m_master + col], c += N(i, j) * mc[j * m_master + col];
          rows[i * m + col]    = r;
          columns[i * m + col] = c;
        }
    }
    int column = m_master;
    for (int c = 0; c < k; ++c) {
      if (J.slot[c] < 0) continue;
      for (int i = 0; i < 6; ++i) rows[i * m + column] = N_rows(i, 6 + c), columns[i * m + column] = N(i, 6 + c);
      ++column;
    }
  }
}

PetscErrorCode Assembler::AddNodeVector(Vec residual, int l, const double *g)
{
  PetscFunctionBeginUser;
  const int node = map_->local_nodes[l];
  if (node_local_joint_[l] < 0) {
    PetscCall(VecSetValues(residual, 6, map_->node_dofs[node].data(), g, ADD_VALUES));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const std::vector<PetscInt> &unknowns = map_->node_unknowns[node];
  const int                    m        = (int)unknowns.size();
  const double                *rows     = expansion_rows_[l].data();
  double                      *values   = expansion_scratch_.data();
  for (int col = 0; col < m; ++col) {
    values[col] = 0.0;
    for (int i = 0; i < 6; ++i) values[col] += rows[i * m + col] * g[i];
  }
  PetscCall(VecSetValues(residual, m, unknowns.data(), values, ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddNodeBlock(Mat jacobian, int l, const Mat6 &block)
{
  PetscFunctionBeginUser;
  const int node = map_->local_nodes[l];
  if (node_local_joint_[l] < 0) {
    PetscCall(MatSetValues(jacobian, 6, map_->node_dofs[node].data(), 6, map_->node_dofs[node].data(), block.data(), ADD_VALUES));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  // The block is d/d(u_s, omega_s); spins: d omega_s = H(omega_s)^{-1} d theta_s (in the
  // initial-acceleration problem the unknowns are the accelerations themselves).
  Mat6 spin = block;
  if (mode_ != Mode::InitialAcceleration) spin.block<6, 3>(0, 3) = (block.block<6, 3>(0, 3) * TangentHInverse(nodes_[l].rotation_increment)).eval();
  const std::vector<PetscInt> &unknowns = map_->node_unknowns[node];
  const int                    m        = (int)unknowns.size();
  const double                *rows = expansion_rows_[l].data(), *columns = expansion_columns_[l].data();
  double                      *values = expansion_scratch_.data();
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) {
      double v = 0.0;
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) v += rows[i * m + a] * spin(i, j) * columns[j * m + b];
      values[a * m + b] = v;
    }
  PetscCall(MatSetValues(jacobian, m, unknowns.data(), m, unknowns.data(), values, ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddExpandedElementMatrix(Mat jacobian, const BeamElement &element, const double *K)
{
  const int              n  = element.order + 1;
  const int              nd = 6 * n;
  double                 scratch_rows[kBeamMaxNodes][36], scratch_columns[kBeamMaxNodes][36];
  const double          *rows[kBeamMaxNodes], *columns[kBeamMaxNodes];
  int                    offset[kBeamMaxNodes + 1] = {0};
  std::vector<PetscInt> &indices                   = expanded_indices_scratch_;
  PetscFunctionBeginUser;
  indices.clear();
  for (int a = 0; a < n; ++a) {
    const int l = map_->node_to_local[element.nodes[a]];
    NodeExpansion(l, &rows[a], &columns[a], scratch_rows[a], scratch_columns[a]);
    const std::vector<PetscInt> &unknowns = map_->node_unknowns[element.nodes[a]];
    indices.insert(indices.end(), unknowns.begin(), unknowns.end());
    offset[a + 1] = (int)indices.size();
  }
  const int M = (int)indices.size();
  if ((int)expansion_scratch_.size() < M * M) expansion_scratch_.resize(M * M);
  double *values = expansion_scratch_.data();
  for (int a = 0; a < n; ++a) {
    const int ma = offset[a + 1] - offset[a];
    for (int b = 0; b < n; ++b) {
      const int mb = offset[b + 1] - offset[b];
      for (int p = 0; p < ma; ++p)
        for (int r = 0; r < mb; ++r) {
          double v = 0.0;
          for (int i = 0; i < 6; ++i) {
            double Kc = 0.0;
            for (int j = 0; j < 6; ++j) Kc += K[(6 * a + i) * nd + 6 * b + j] * columns[b][j * mb + r];
            v += rows[a][i * ma + p] * Kc;
          }
          values[(offset[a] + p) * M + offset[b] + r] = v;
        }
    }
  }
  PetscCall(MatSetValues(jacobian, M, indices.data(), M, indices.data(), values, ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddJointGeometricStiffness(Mat jacobian)
{
  const DofMap &map = *map_;
  double        master_rows[6 * 6 * kJointMaxReleased], master_columns[6 * 6 * kJointMaxReleased];
  PetscFunctionBeginUser;
  // Slaves deepest first: each passes N_m^T g on to its master before the master is processed.
  for (auto it = joints_.rbegin(); it != joints_.rend(); ++it) {
    const LocalJoint &J     = *it;
    const Joint      &joint = ModelJoint(J);
    const Vec6        g     = slave_residual_[J.local_slave];
    if (g.isZero(0.0)) continue;
    Mat3 R_m = Mat3::Identity();
    if (J.local_master >= 0) R_m = nodes_[J.local_master].rotation;
    JointCoordinates q = J.start;
    for (int c = 0; c < kJointMaxReleased; ++c) q.q[c] += J.increment[c];
    JointSquare G;
    JointGeometricStiffness(J.geometry, q, R_m, g, &G);
    // Rows: the master's rows for (x_m, theta_m), identity for the free coordinates; columns alike.
    const int                    k        = JointNumCoordinates(J.geometry);
    const std::vector<PetscInt> &unknowns = map.node_unknowns[joint.slave];
    const int                    m        = (int)unknowns.size();
    const int                    m_master = J.local_master >= 0 ? (int)map.node_unknowns[joint.master].size() : 0;
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
      if (node_local_joint_[J.local_master] >= 0) {
        JointMatrix N;
        JointMap(J.geometry, q, R_m, &N);
        slave_residual_[J.local_master] += N.leftCols<6>().transpose() * g;
      }
    }
    int column = m_master;
    for (int c = 0; c < k; ++c) {
      if (J.slot[c] < 0) continue;
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
  for (auto it = joints_.rbegin(); it != joints_.rend(); ++it)
    if (it->local_master >= 0 && node_local_joint_[it->local_master] >= 0)
      slave_residual_[it->local_master] += it->rows_map.leftCols<6>().transpose() * slave_residual_[it->local_slave];
}

PetscErrorCode Assembler::EvaluateJointReactions(double dt)
{
  const DofMap &map = *map_;
  PetscBool     evaluable;
  PetscMPIInt   rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  PetscCall(AssembleResidual(scratch_residual_, &evaluable));
  PropagateSlaveResiduals();
  // Every rank adds the slave residual it assembled into the joint's slot; the owner adds the rates.
  PetscCall(VecZeroEntries(joint_output_));
  for (const LocalJoint &J : joints_) {
    const PetscInt first = 12 * (PetscInt)map.joint_slot[map.local_joints[J.local_index]];
    PetscInt       rows[12];
    double         values[12];
    for (int i = 0; i < 12; ++i) rows[i] = first + i;
    for (int i = 0; i < 6; ++i) values[i] = slave_residual_[J.local_slave](i);
    const bool owner = map.joint_rank[map.local_joints[J.local_index]] == rank;
    for (int c = 0; c < kJointMaxReleased; ++c) values[6 + c] = owner && dt > 0.0 ? J.increment[c] / dt : 0.0;
    PetscCall(VecSetValues(joint_output_, 12, rows, values, ADD_VALUES));
  }
  PetscCall(VecAssemblyBegin(joint_output_));
  PetscCall(VecAssemblyEnd(joint_output_));
  const PetscScalar *output;
  PetscCall(VecGetArrayRead(joint_output_, &output));
  for (LocalJoint &J : joints_) {
    if (map.joint_rank[map.local_joints[J.local_index]] != rank) continue;
    const PetscScalar *row = output + 12 * (map.joint_slot[map.local_joints[J.local_index]] - map.first_owned_joint_slot);
    for (int i = 0; i < 6; ++i) J.reaction(i) = row[i];
    for (int c = 0; c < kJointMaxReleased; ++c) J.rate[c] = row[6 + c];
  }
  PetscCall(VecRestoreArrayRead(joint_output_, &output));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::JointHistory(std::vector<std::string> *names, std::vector<double> *values)
{
  static const char *const translation_names[3] = {"tx", "ty", "tz"}, *rotation_names[3] = {"rx", "ry", "rz"};
  static const char *const reaction_names[6] = {"force_x", "force_y", "force_z", "moment_x", "moment_y", "moment_z"};
  const DofMap            &map               = *map_;
  PetscMPIInt              rank, size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  PetscCallMPI(MPI_Comm_size(comm_, &size));
  // Owned joints in slot order; the series names are only built (and gathered to rank 0) once.
  std::vector<const LocalJoint *> owned;
  for (const LocalJoint &J : joints_)
    if (map.joint_rank[map.local_joints[J.local_index]] == rank) owned.push_back(&J);
  std::sort(owned.begin(), owned.end(), [&](const LocalJoint *a, const LocalJoint *b) {
    return map.joint_slot[map.local_joints[a->local_index]] < map.joint_slot[map.local_joints[b->local_index]];
  });
  const bool          need_names = !joint_history_named_;
  std::vector<double> local;
  std::string         local_names; // '\0'-terminated series names
  for (const LocalJoint *J : owned) {
    const Joint            &joint = ModelJoint(*J);
    const JointCoordinates &q     = J->start;
    const int               nt    = joint.num_translations;
    auto                    add   = [&](const std::string &name, double value) {
      if (need_names) local_names += joint.name + "." + name + '\0';
      local.push_back(value);
    };
    for (int c = 0; c < nt; ++c) {
      add(translation_names[joint.translation_axis[c]], q.q[c]);
      add(std::string(translation_names[joint.translation_axis[c]]) + "_rate", J->rate[c]);
    }
    if (joint.rotation == Joint::Rotation::Free) {
      const Vec3 rotation = joint.axes.transpose() * LogSO3(q.free_rotation_start);
      for (int i = 0; i < 3; ++i) add(rotation_names[i], rotation(i));
    } else {
      const int nr = joint.rotation == Joint::Rotation::OneAxis ? 1 : joint.rotation == Joint::Rotation::TwoAxes ? 2 : 0;
      for (int c = 0; c < nr; ++c) {
        add(rotation_names[joint.rotation_axis[c]], q.q[nt + c]);
        add(std::string(rotation_names[joint.rotation_axis[c]]) + "_rate", J->rate[nt + c]);
      }
    }
    if (joint.dependence != Joint::Dependence::None) {
      double f, df, ddf, f0, df0, ddf0;
      JointDependentTranslation(J->geometry, q.q[nt], &f, &df, &ddf);
      JointDependentTranslation(J->geometry, 0.0, &f0, &df0, &ddf0);
      add(translation_names[joint.dependent_axis], f - f0);
    }
    for (int i = 0; i < 6; ++i) add(reaction_names[i], J->reaction(i));
  }
  // Gather to rank 0, which writes the history; the ranks' parts follow in slot order.
  auto gather = [&](const void *send, int count, MPI_Datatype type, std::vector<char> *received, size_t element_size) -> PetscErrorCode {
    std::vector<int> counts(rank == 0 ? size : 0), offsets(rank == 0 ? size : 0);
    PetscFunctionBeginUser;
    PetscCallMPI(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm_));
    int total = 0;
    for (int r = 0; r < (int)counts.size(); ++r) offsets[r] = total, total += counts[r];
    received->resize(element_size * (size_t)total);
    PetscCallMPI(MPI_Gatherv(send, count, type, received->data(), counts.data(), offsets.data(), type, 0, comm_));
    PetscFunctionReturn(PETSC_SUCCESS);
  };
  if (need_names) {
    std::vector<char> gathered;
    PetscCall(gather(local_names.data(), (int)local_names.size(), MPI_CHAR, &gathered, 1));
    for (size_t start = 0; start < gathered.size();) {
      const size_t end = std::find(gathered.begin() + (std::ptrdiff_t)start, gathered.end(), '\0') - gathered.begin();
      joint_history_names_.emplace_back(gathered.data() + start, end - start);
      start = end + 1;
    }
    joint_history_named_ = true;
  }
  std::vector<char> gathered_values;
  PetscCall(gather(local.data(), (int)local.size(), MPI_DOUBLE, &gathered_values, sizeof(double)));
  names->clear();
  values->clear();
  if (rank == 0) {
    *names = joint_history_names_;
    values->resize(names->size());
    PetscCheck(gathered_values.size() == sizeof(double) * names->size(), PETSC_COMM_SELF, PETSC_ERR_PLIB, "joint history: %zu values for %zu series",
               gathered_values.size() / sizeof(double), names->size());
    std::memcpy(values->data(), gathered_values.data(), gathered_values.size());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
