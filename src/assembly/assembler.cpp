#include "assembly/assembler.hpp"

#include "core/errors.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace msflex {

namespace {
PetscLogEvent event_residual = 0, event_jacobian = 0;

// Global row/column indices of an element's DOFs (-1 for constrained DOFs: PETSc ignores them).
int ElementIndices(const BeamElement &element, const DofMap &map, PetscInt *indices)
{
  const int num_nodes = element.order + 1;
  for (int a = 0; a < num_nodes; ++a)
    for (int d = 0; d < 6; ++d) indices[6 * a + d] = map.node_dofs[element.nodes[a]][d];
  return 6 * num_nodes;
}
} // namespace

Assembler::~Assembler()
{
  MatDestroy(&jacobian_);
  VecDestroy(&solution_template_);
  VecDestroy(&ghosted_increments_);
  VecScatterDestroy(&to_ghosted_);
}

void Assembler::ElementConfiguration(const BeamElement &element, Vec3 *positions, Mat3 *triads, const Mat3 **rotation_tangents) const
{
  for (int a = 0; a <= element.order; ++a) {
    const NodeState &s = nodes_[map_->node_to_local[element.nodes[a]]];
    positions[a]       = s.position;
    triads[a]          = s.rotation * element.reference_triads[a];
    if (rotation_tangents) rotation_tangents[a] = &s.rotation_tangent;
  }
}

double Assembler::FunctionValue(int function, double t) const { return function < 0 ? t : model_->functions[function].Evaluate(t); }

PetscErrorCode Assembler::Setup(MPI_Comm comm, const Model &model, const DofMap &map)
{
  PetscFunctionBeginUser;
  if (!event_residual) {
    PetscCall(PetscLogEventRegister("AssembleResidual", MAT_CLASSID, &event_residual));
    PetscCall(PetscLogEventRegister("AssembleJacobian", MAT_CLASSID, &event_jacobian));
  }
  comm_  = comm;
  model_ = &model;
  map_   = &map;

  for (const Section &s : model.sections) section_stiffness_.push_back({Vec3(s.EA, s.GA2, s.GA3), Vec3(s.GJ, s.EI2, s.EI3)});

  element_references_.resize(map.local_elements.size());
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    const int          n       = element.order + 1;
    Vec3               positions[kBeamMaxNodes];
    for (int a = 0; a < n; ++a) positions[a] = model.nodes[element.nodes[a]].position;
    const BeamKernelStatus status = BeamElementSetup(n, positions, element.reference_triads.data(), &element_references_[k]);
    const Beam            &beam   = model.beams[element.beam];
    MSFLEX_INPUT_CHECK(status == BeamKernelStatus::Ok, beam.mark, "beam '%s': element %d is degenerate (zero length or reference triads turning by pi or more)",
                       beam.name.c_str(), (int)k);
  }

  nodes_.resize(map.local_nodes.size());
  for (size_t l = 0; l < nodes_.size(); ++l) {
    nodes_[l].position_start = model.nodes[map.local_nodes[l]].position;
    NodeStateUpdateCurrent(&nodes_[l]);
  }
  element_line_load_.assign(map.local_elements.size(), Vec3::Zero());
  dead_force_.assign(map.num_owned_nodes, Vec3::Zero());
  dead_moment_      = dead_force_;
  follower_force_   = dead_force_;
  follower_moment_  = dead_force_;

  // Matrix with exact preallocation; a missed preallocation is a bug, so make it an error.
  std::vector<PetscInt> diagonal_nonzeros, off_diagonal_nonzeros;
  PetscCall(DofMapPreallocation(map, model, &diagonal_nonzeros, &off_diagonal_nonzeros));
  PetscCall(MatCreate(comm, &jacobian_));
  PetscCall(MatSetSizes(jacobian_, map.num_owned, map.num_owned, map.num_global, map.num_global));
  PetscCall(MatSetType(jacobian_, MATAIJ));
  PetscCall(MatSetOptionsPrefix(jacobian_, "jacobian_"));
  PetscCall(MatSetFromOptions(jacobian_));
  PetscCall(MatSeqAIJSetPreallocation(jacobian_, 0, diagonal_nonzeros.data()));
  PetscCall(MatMPIAIJSetPreallocation(jacobian_, 0, diagonal_nonzeros.data(), 0, off_diagonal_nonzeros.data()));
  PetscCall(MatSetOption(jacobian_, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscCall(MatCreateVecs(jacobian_, &solution_template_, nullptr));
  PetscCall(CreateCsrDestinations());

  // Scatter from the distributed unknowns to the free DOFs of every local node (owned and ghost).
  std::vector<PetscInt> from;
  ghosted_slot_.assign(6 * nodes_.size(), -1);
  for (size_t l = 0; l < nodes_.size(); ++l)
    for (int d = 0; d < 6; ++d) {
      const PetscInt global = map.node_dofs[map.local_nodes[l]][d];
      if (global < 0) continue;
      ghosted_slot_[6 * l + d] = (PetscInt)from.size();
      from.push_back(global);
    }
  IS from_is;
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, (PetscInt)from.size(), from.data(), PETSC_COPY_VALUES, &from_is));
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, (PetscInt)from.size(), &ghosted_increments_));
  PetscCall(VecScatterCreate(solution_template_, from_is, ghosted_increments_, nullptr, &to_ghosted_));
  PetscCall(ISDestroy(&from_is));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Fixes the pattern with one assembly of zeros, then records where each element-matrix entry
// lands in the CSR arrays of the owned rows.
PetscErrorCode Assembler::CreateCsrDestinations()
{
  const DofMap &map = *map_;
  PetscBool     is_seq, is_mpi;
  PetscFunctionBeginUser;
  const std::vector<double> zeros(kBeamMaxDofs * kBeamMaxDofs, 0.0);
  for (int e : map.local_elements) {
    PetscInt  indices[kBeamMaxDofs];
    const int nd = ElementIndices(model_->elements[e], map, indices);
    PetscCall(MatSetValues(jacobian_, nd, indices, nd, indices, zeros.data(), ADD_VALUES));
  }
  PetscCall(MatAssemblyBegin(jacobian_, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(jacobian_, MAT_FINAL_ASSEMBLY));
  PetscCall(PetscObjectTypeCompare((PetscObject)jacobian_, MATSEQAIJ, &is_seq));
  PetscCall(PetscObjectTypeCompare((PetscObject)jacobian_, MATMPIAIJ, &is_mpi));
  csr_destinations_.clear();
  if (!is_seq && !is_mpi) PetscFunctionReturn(PETSC_SUCCESS);

  const PetscInt *off_diagonal_columns = nullptr; // global column of each off-diagonal block column, ascending
  PetscInt        num_off_diagonal_columns = 0;
  diagonal_block_ = jacobian_;
  off_diagonal_block_ = nullptr;
  if (is_mpi) {
    PetscCall(MatMPIAIJGetSeqAIJ(jacobian_, &diagonal_block_, &off_diagonal_block_, &off_diagonal_columns));
    PetscCall(MatGetSize(off_diagonal_block_, nullptr, &num_off_diagonal_columns));
  }
  const PetscInt *ia, *ja, *ib = nullptr, *jb = nullptr;
  PetscInt        num_rows;
  PetscBool       done;
  PetscCall(MatGetRowIJ(diagonal_block_, 0, PETSC_FALSE, PETSC_FALSE, &num_rows, &ia, &ja, &done));
  PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_PLIB, "no CSR access to the diagonal block");
  if (off_diagonal_block_) {
    PetscCall(MatGetRowIJ(off_diagonal_block_, 0, PETSC_FALSE, PETSC_FALSE, &num_rows, &ib, &jb, &done));
    PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_PLIB, "no CSR access to the off-diagonal block");
  }
  // Position of column `column` in CSR row `row`, or -1.
  auto find = [](const PetscInt *row_start, const PetscInt *columns, PetscInt row, PetscInt column) -> PetscInt {
    const PetscInt *begin = columns + row_start[row], *end = columns + row_start[row + 1];
    const PetscInt *it    = std::lower_bound(begin, end, column);
    return (it != end && *it == column) ? (PetscInt)(it - columns) : -1;
  };
  const PetscInt first = map.first_owned, last = map.first_owned + map.num_owned;
  csr_destinations_.resize(map.local_elements.size());
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    PetscInt  indices[kBeamMaxDofs];
    const int nd = ElementIndices(model_->elements[map.local_elements[k]], map, indices);
    std::vector<PetscInt> &destination = csr_destinations_[k];
    destination.assign(nd * nd, kCsrSkip);
    for (int i = 0; i < nd; ++i) {
      const PetscInt row = indices[i];
      if (row < 0) continue;
      if (row < first || row >= last) {
        for (int j = 0; j < nd; ++j) destination[i * nd + j] = kCsrOtherRank;
        continue;
      }
      for (int j = 0; j < nd; ++j) {
        const PetscInt column = indices[j];
        if (column < 0) continue;
        PetscInt slot;
        if (column >= first && column < last) {
          slot = find(ia, ja, row - first, column - first);
        } else {
          const PetscInt *it = std::lower_bound(off_diagonal_columns, off_diagonal_columns + num_off_diagonal_columns, column);
          const PetscInt  local_column = (PetscInt)(it - off_diagonal_columns);
          slot = (it != off_diagonal_columns + num_off_diagonal_columns && *it == column) ? find(ib, jb, row - first, local_column) : -1;
          if (slot >= 0) slot = kCsrOffDiagonal - slot;
        }
        PetscCheck(slot != -1, PETSC_COMM_SELF, PETSC_ERR_PLIB, "entry (%" PetscInt_FMT ", %" PetscInt_FMT ") missing from the preallocated pattern", row, column);
        destination[i * nd + j] = slot;
      }
    }
  }
  PetscCall(MatRestoreRowIJ(diagonal_block_, 0, PETSC_FALSE, PETSC_FALSE, &num_rows, &ia, &ja, &done));
  if (off_diagonal_block_) PetscCall(MatRestoreRowIJ(off_diagonal_block_, 0, PETSC_FALSE, PETSC_FALSE, &num_rows, &ib, &jb, &done));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Adds one element matrix (row-major, num_dofs^2): owned rows straight into the CSR values,
// rows of other ranks through MatSetValues (PETSc's stash).
PetscErrorCode Assembler::AddElementMatrix(size_t local_element, const PetscInt *indices, int num_dofs, const double *values, PetscScalar *diagonal_values,
                                           PetscScalar *off_diagonal_values)
{
  PetscFunctionBeginUser;
  if (csr_destinations_.empty()) {
    PetscCall(MatSetValues(jacobian_, num_dofs, indices, num_dofs, indices, values, ADD_VALUES));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const PetscInt *destination = csr_destinations_[local_element].data();
  for (int i = 0; i < num_dofs; ++i) {
    const PetscInt *row_destination = destination + i * num_dofs;
    const double   *row_values      = values + i * num_dofs;
    if (row_destination[0] == kCsrOtherRank) {
      PetscCall(MatSetValues(jacobian_, 1, &indices[i], num_dofs, indices, row_values, ADD_VALUES));
      continue;
    }
    for (int j = 0; j < num_dofs; ++j) {
      const PetscInt slot = row_destination[j];
      if (slot >= 0) diagonal_values[slot] += row_values[j];
      else if (slot <= kCsrOffDiagonal) off_diagonal_values[kCsrOffDiagonal - slot] += row_values[j];
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::BeginStep(double t_start, double t_end)
{
  PetscFunctionBeginUser;
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  // Distributed loads on the local elements.
  std::fill(element_line_load_.begin(), element_line_load_.end(), Vec3::Zero());
  std::vector<int> element_to_local(model.elements.size(), -1);
  for (size_t k = 0; k < map.local_elements.size(); ++k) element_to_local[map.local_elements[k]] = (int)k;
  for (const DistributedLoad &load : model.distributed_loads) {
    const double factor = FunctionValue(load.function, t_end);
    for (int e : load.elements) {
      const int k = element_to_local[e];
      if (k < 0) continue;
      const double scale = load.gravity ? model.sections[model.elements[e].section].rhoA : 1.0;
      element_line_load_[k] += factor * scale * load.force_per_length;
    }
  }
  // Concentrated loads on owned nodes.
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    dead_force_[l].setZero();
    dead_moment_[l].setZero();
    follower_force_[l].setZero();
    follower_moment_[l].setZero();
  }
  for (const NodalLoad &load : model.nodal_loads) {
    const double factor = FunctionValue(load.function, t_end);
    for (int node : load.nodes) {
      const int l = map.node_to_local[node];
      if (l < 0 || l >= map.num_owned_nodes) continue;
      (load.follower ? follower_force_ : dead_force_)[l] += factor * load.force;
      (load.follower ? follower_moment_ : dead_moment_)[l] += factor * load.moment;
    }
  }
  PetscCall(ApplyPrescribedIncrements(t_start, t_end));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Fixed DOFs keep a zero increment. A prescribed displacement reaches its absolute target
// X + value f(t_end); a prescribed rotation component turns by value (f(t_end) - f(t_start)) about
// its global axis.
PetscErrorCode Assembler::ApplyPrescribedIncrements(double t_start, double t_end)
{
  PetscFunctionBeginUser;
  const DofMap &map = *map_;
  for (size_t l = 0; l < nodes_.size(); ++l) {
    const int  node = map.local_nodes[l];
    NodeState &s    = nodes_[l];
    for (int d = 0; d < 6; ++d) {
      const DofConstraint &c = map.constraints[node][d];
      if (c.kind == Support::Kind::Free) continue;
      double increment = 0.0;
      if (c.kind == Support::Kind::Prescribed) {
        if (d < 3) increment = model_->nodes[node].position(d) + c.value * FunctionValue(c.function, t_end) - s.position_start(d);
        else increment = c.value * (FunctionValue(c.function, t_end) - FunctionValue(c.function, t_start));
      }
      if (d < 3) s.displacement_increment(d) = increment;
      else s.rotation_increment(d - 3) = increment;
    }
    NodeStateUpdateCurrent(&s);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::SetIncrements(Vec increments)
{
  const PetscScalar *values;
  PetscFunctionBeginUser;
  PetscCall(VecScatterBegin(to_ghosted_, increments, ghosted_increments_, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(to_ghosted_, increments, ghosted_increments_, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(ghosted_increments_, &values));
  for (size_t l = 0; l < nodes_.size(); ++l) {
    NodeState &s = nodes_[l];
    for (int d = 0; d < 6; ++d) {
      const PetscInt slot = ghosted_slot_[6 * l + d];
      if (slot < 0) continue;
      if (d < 3) s.displacement_increment(d) = PetscRealPart(values[slot]);
      else s.rotation_increment(d - 3) = PetscRealPart(values[slot]);
    }
    NodeStateUpdateCurrent(&s);
  }
  PetscCall(VecRestoreArrayRead(ghosted_increments_, &values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AssembleResidual(Vec residual, PetscBool *geometry_ok)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_residual, 0, 0, 0, 0));
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  *geometry_ok        = PETSC_TRUE;
  // Constrained DOFs have index -1; Vecs (unlike Mats) must be told to skip them.
  PetscCall(VecSetOption(residual, VEC_IGNORE_NEGATIVE_INDICES, PETSC_TRUE));
  PetscCall(VecZeroEntries(residual));
  local_force_squares_ = 0.0;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    const int          n       = element.order + 1;
    Vec3               positions[kBeamMaxNodes];
    Mat3               triads[kBeamMaxNodes];
    ElementConfiguration(element, positions, triads, nullptr);
    double                 r[kBeamMaxDofs];
    PetscInt               indices[kBeamMaxDofs];
    const BeamKernelStatus status = BeamInternalForces(element_references_[k], section_stiffness_[element.section], positions, triads, r, nullptr, nullptr, nullptr);
    if (status != BeamKernelStatus::Ok) {
      *geometry_ok = PETSC_FALSE;
      continue;
    }
    // Consistent dead line load: f_a = integral of I_a q ds.
    for (int a = 0; a < n; ++a)
      for (int i = 0; i < 3; ++i) r[6 * a + i] -= element_references_[k].nodal_length[a] * element_line_load_[k](i);
    const int num_dofs = ElementIndices(element, map, indices);
    for (int i = 0; i < num_dofs; ++i) local_force_squares_ += r[i] * r[i];
    PetscCall(VecSetValues(residual, num_dofs, indices, r, ADD_VALUES));
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const NodeState &s = nodes_[l];
    const Vec3       f = dead_force_[l] + s.rotation * follower_force_[l];
    const Vec3       m = dead_moment_[l] + s.rotation * follower_moment_[l];
    double           r[6];
    for (int i = 0; i < 3; ++i) {
      r[i]     = -f(i);
      r[i + 3] = -m(i);
    }
    for (int i = 0; i < 6; ++i) local_force_squares_ += r[i] * r[i];
    PetscCall(VecSetValues(residual, 6, map.node_dofs[map.local_nodes[l]].data(), r, ADD_VALUES));
  }
  PetscCall(VecAssemblyBegin(residual));
  PetscCall(VecAssemblyEnd(residual));
  PetscCall(PetscLogEventEnd(event_residual, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AssembleJacobian(Mat jacobian, PetscBool *geometry_ok)
{
  PetscFunctionBeginUser;
  PetscCheck(jacobian == jacobian_, PETSC_COMM_SELF, PETSC_ERR_SUP, "the assembler assembles into its own matrix only");
  PetscCall(PetscLogEventBegin(event_jacobian, 0, 0, 0, 0));
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  *geometry_ok        = PETSC_TRUE;
  PetscCall(MatZeroEntries(jacobian));
  PetscScalar *diagonal_values = nullptr, *off_diagonal_values = nullptr;
  if (!csr_destinations_.empty()) {
    PetscCall(MatSeqAIJGetArray(diagonal_block_, &diagonal_values));
    if (off_diagonal_block_) PetscCall(MatSeqAIJGetArray(off_diagonal_block_, &off_diagonal_values));
  }
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    const int          n       = element.order + 1;
    const int          nd      = 6 * n;
    Vec3               positions[kBeamMaxNodes];
    Mat3               triads[kBeamMaxNodes];
    const Mat3        *tangents[kBeamMaxNodes];
    ElementConfiguration(element, positions, triads, tangents);
    double                 r[kBeamMaxDofs], K[kBeamMaxDofs * kBeamMaxDofs];
    PetscInt               indices[kBeamMaxDofs];
    const BeamKernelStatus status = BeamInternalForces(element_references_[k], section_stiffness_[element.section], positions, triads, r, K, nullptr, nullptr);
    if (status != BeamKernelStatus::Ok) {
      *geometry_ok = PETSC_FALSE;
      continue;
    }
    // Column scaling from spins to incremental rotation vectors: d theta_b = H(omega_b) d omega_b.
    for (int b = 0; b < n; ++b) {
      const Mat3 &H = *tangents[b];
      for (int i = 0; i < nd; ++i) {
        double *row = &K[i * nd + 6 * b + 3];
        const double k0 = row[0], k1 = row[1], k2 = row[2];
        for (int j = 0; j < 3; ++j) row[j] = k0 * H(0, j) + k1 * H(1, j) + k2 * H(2, j);
      }
    }
    ElementIndices(element, map, indices);
    PetscCall(AddElementMatrix(k, indices, nd, K, diagonal_values, off_diagonal_values));
  }
  if (!csr_destinations_.empty()) {
    PetscCall(MatSeqAIJRestoreArray(diagonal_block_, &diagonal_values));
    if (off_diagonal_block_) PetscCall(MatSeqAIJRestoreArray(off_diagonal_block_, &off_diagonal_values));
  }
  // Follower loads: d(-Lambda f0) = hat(f) d theta.
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (follower_force_[l].isZero(0.0) && follower_moment_[l].isZero(0.0)) continue;
    const NodeState &s = nodes_[l];
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> block = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>::Zero();
    block.block<3, 3>(0, 3) = Skew(s.rotation * follower_force_[l]) * s.rotation_tangent;
    block.block<3, 3>(3, 3) = Skew(s.rotation * follower_moment_[l]) * s.rotation_tangent;
    const PetscInt *indices = map.node_dofs[map.local_nodes[l]].data();
    PetscCall(MatSetValues(jacobian, 6, indices, 6, indices, block.data(), ADD_VALUES));
  }
  PetscCall(MatAssemblyBegin(jacobian, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(jacobian, MAT_FINAL_ASSEMBLY));
  PetscCall(PetscLogEventEnd(event_jacobian, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::CommitStep()
{
  PetscFunctionBeginUser;
  for (NodeState &s : nodes_) NodeStateCommit(&s);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::DiscardStep()
{
  PetscFunctionBeginUser;
  for (NodeState &s : nodes_) {
    s.displacement_increment.setZero();
    s.rotation_increment.setZero();
    NodeStateUpdateCurrent(&s);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::ForceScale(double *scale)
{
  double global_squares;
  PetscFunctionBeginUser;
  PetscCall(MPIU_Allreduce(&local_force_squares_, &global_squares, 1, MPI_DOUBLE, MPI_SUM, comm_));
  *scale = std::sqrt(global_squares);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::MaxRotationIncrement(double *max_rotation)
{
  PetscFunctionBeginUser;
  double local = 0.0;
  for (PetscInt l = 0; l < map_->num_owned_nodes; ++l) local = std::max(local, nodes_[l].rotation_increment.norm());
  PetscCall(MPIU_Allreduce(&local, max_rotation, 1, MPI_DOUBLE, MPI_MAX, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::EvaluateResults(std::vector<ElementResults> *results, double *strain_energy)
{
  PetscFunctionBeginUser;
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  double        local_energy = 0.0;
  results->resize(map.local_elements.size());
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    Vec3               positions[kBeamMaxNodes];
    Mat3               triads[kBeamMaxNodes];
    ElementConfiguration(element, positions, triads, nullptr);
    double           r[kBeamMaxDofs], energy = 0.0;
    BeamGaussResults gauss;
    const BeamKernelStatus status = BeamInternalForces(element_references_[k], section_stiffness_[element.section], positions, triads, r, nullptr, &energy, &gauss);
    PetscCheck(status == BeamKernelStatus::Ok, PETSC_COMM_SELF, PETSC_ERR_PLIB, "element %d cannot be evaluated in a converged state", map.local_elements[k]);
    local_energy += energy;
    ElementResults &out = (*results)[k];
    out                 = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    const int    ng     = element_references_[k].num_gauss;
    for (int g = 0; g < ng; ++g) {
      out.strain += gauss.strain[g] / ng;
      out.curvature += gauss.curvature[g] / ng;
      out.force += gauss.force[g] / ng;
      out.moment += gauss.moment[g] / ng;
    }
  }
  PetscCall(MPIU_Allreduce(&local_energy, strain_energy, 1, MPI_DOUBLE, MPI_SUM, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
