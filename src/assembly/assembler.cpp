#include "assembly/assembler.hpp"

#include "core/errors.hpp"
#include "joints/joint_model.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace msflex {

namespace {
PetscLogEvent event_residual = 0, event_jacobian = 0, event_preallocation = 0, event_csr_destinations = 0;

// Global row/column indices of an element's DOFs (-1 for constrained DOFs: PETSc ignores them).
int ElementIndices(const BeamElement &element, const DofMap &map, PetscInt *indices)
{
  const int num_nodes = element.order + 1;
  for (int a = 0; a < num_nodes; ++a)
    for (int d = 0; d < 6; ++d) indices[6 * a + d] = map.node_dofs[element.nodes[a]][d];
  return 6 * num_nodes;
}

// Body-frame rotary inertia that an element lumps to its node a by nodal quadrature of eq. (17):
// integral of I_a ds times the section inertia rhoJ turned from the section into the node frame.
Mat3 LumpedRotaryInertia(const BeamElementReference &ref, const BeamElement &element, const Section &section, int a)
{
  const Mat3 &T0 = element.reference_triads[a];
  return ref.nodal_length[a] * (T0 * section.rhoJ.asDiagonal() * T0.transpose());
}
} // namespace

Assembler::~Assembler()
{
  MatDestroy(&jacobian_);
  VecDestroy(&solution_template_);
  VecDestroy(&ghosted_increments_);
  VecDestroy(&scratch_residual_);
  VecScatterDestroy(&to_ghosted_);
  VecDestroy(&joint_output_);
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

void Assembler::ElementStartConfiguration(const BeamElement &element, Vec3 *positions, Mat3 *triads) const
{
  for (int a = 0; a <= element.order; ++a) {
    const NodeState &s = nodes_[map_->node_to_local[element.nodes[a]]];
    positions[a]       = s.position_start;
    triads[a]          = QuaternionToMatrix(s.rotation_start) * element.reference_triads[a];
  }
}

double Assembler::FunctionValue(int function, double t) const { return function < 0 ? t : model_->functions[function].Evaluate(t); }

// Derivatives of a load or motion function by second-order one-sided differences (the tables are
// only piecewise smooth, so stay on the side of the coming motion).
double Assembler::FunctionDerivative(int function, double t, int order) const
{
  const double h  = 1e-4 * std::max(1.0, std::abs(t));
  const double f0 = FunctionValue(function, t), f1 = FunctionValue(function, t + h), f2 = FunctionValue(function, t + 2 * h);
  if (order == 1) return (-3.0 * f0 + 4.0 * f1 - f2) / (2.0 * h);
  const double f3 = FunctionValue(function, t + 3 * h);
  return (2.0 * f0 - 5.0 * f1 + 4.0 * f2 - f3) / (h * h);
}

PetscErrorCode Assembler::Setup(MPI_Comm comm, const Model &model, const DofMap &map)
{
  PetscFunctionBeginUser;
  if (!event_residual) {
    PetscCall(PetscLogEventRegister("AssembleResidual", MAT_CLASSID, &event_residual));
    PetscCall(PetscLogEventRegister("AssembleJacobian", MAT_CLASSID, &event_jacobian));
    PetscCall(PetscLogEventRegister("Preallocation", MAT_CLASSID, &event_preallocation));
    PetscCall(PetscLogEventRegister("CsrDestinations", MAT_CLASSID, &event_csr_destinations));
  }
  comm_  = comm;
  model_ = &model;
  map_   = &map;

  for (const Section &s : model.sections) section_stiffness_.push_back({Vec3(s.EA, s.GA2, s.GA3), Vec3(s.GJ, s.EI2, s.EI3)});

  auto setup_element = [&](int e, BeamElementReference *ref) -> PetscErrorCode {
    const BeamElement &element = model.elements[e];
    Vec3               positions[kBeamMaxNodes];
    PetscFunctionBeginUser;
    for (int a = 0; a <= element.order; ++a) positions[a] = model.nodes[element.nodes[a]].position;
    const BeamKernelStatus status = BeamElementSetup(element.order + 1, positions, element.reference_triads.data(), ref);
    const Beam            &beam   = model.beams[element.beam];
    MSFLEX_INPUT_CHECK(status == BeamKernelStatus::Ok, beam.mark, "beam '%s': an element is degenerate (zero length or reference triads turning by pi or more)",
                       beam.name.c_str());
    PetscFunctionReturn(PETSC_SUCCESS);
  };
  element_references_.resize(map.local_elements.size());
  for (size_t k = 0; k < map.local_elements.size(); ++k) PetscCall(setup_element(map.local_elements[k], &element_references_[k]));

  nodes_.resize(map.local_nodes.size());
  for (size_t l = 0; l < nodes_.size(); ++l) {
    nodes_[l].position_start = model.nodes[map.local_nodes[l]].position;
    NodeStateUpdateCurrent(&nodes_[l]);
  }
  // Rotary inertia of owned nodes from every element that touches them (on any rank) and from
  // their rigid bodies, whose translational inertia sits at their centre of mass.
  node_inertia_.assign(map.num_owned_nodes, Mat3::Zero());
  for (size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement &element = model.elements[e];
    if (model.sections[element.section].rhoJ.isZero(0.0)) continue;
    // A local element's reference data is already there; others are set up on first use.
    BeamElementReference        other_ref;
    const BeamElementReference *ref = map.element_to_local[e] >= 0 ? &element_references_[map.element_to_local[e]] : nullptr;
    for (int a = 0; a <= element.order; ++a) {
      const int l = map.node_to_local[element.nodes[a]];
      if (l < 0 || l >= map.num_owned_nodes) continue;
      if (!ref) {
        PetscCall(setup_element((int)e, &other_ref));
        ref = &other_ref;
      }
      node_inertia_[l] += LumpedRotaryInertia(*ref, element, model.sections[element.section], a);
    }
  }
  has_translational_mass_.assign(nodes_.size(), 0);
  has_rotary_inertia_.assign(nodes_.size(), 0);
  for (const BeamElement &element : model.elements) {
    const Section &section = model.sections[element.section];
    for (int a = 0; a <= element.order; ++a) {
      const int l = map.node_to_local[element.nodes[a]];
      if (l < 0) continue;
      if (section.rhoA > 0.0) has_translational_mass_[l] = 1;
      if (!section.rhoJ.isZero(0.0)) has_rotary_inertia_[l] = 1;
    }
  }
  for (const RigidBody &body : model.rigid_bodies) {
    const int l = map.node_to_local[body.node];
    if (l < 0) continue;
    if (body.mass > 0.0) has_translational_mass_[l] = has_rotary_inertia_[l] = 1; // with an offset, the mass also resists rotation
    if (!body.inertia.isZero(0.0)) has_rotary_inertia_[l] = 1;
  }
  // Joints carry inertia between their nodes: never replace the equations of a master or a slave.
  for (const Joint &joint : model.joints)
    for (int node : {joint.master, joint.slave}) {
      const int l = node >= 0 ? map.node_to_local[node] : -1;
      if (l >= 0) has_translational_mass_[l] = has_rotary_inertia_[l] = 1;
    }
  rigid_bodies_.clear();
  for (size_t b = 0; b < model.rigid_bodies.size(); ++b) {
    const RigidBody &body = model.rigid_bodies[b];
    const int        l    = map.node_to_local[body.node];
    if (l < 0 || l >= map.num_owned_nodes) continue;
    node_inertia_[l] += body.inertia;
    LocalRigidBody local;
    local.global_index = map.global_rigid_bodies[b];
    local.local_node   = l;
    local.mass         = body.mass;
    local.offset       = body.offset;
    rigid_bodies_.push_back(local);
  }

  double stiffness_squares = 0.0;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamSectionStiffness &c = section_stiffness_[model.elements[map.local_elements[k]].section];
    const double                L = element_references_[k].length;
    stiffness_squares += c.axial_shear.squaredNorm() + c.torsion_bending.squaredNorm() / (L * L);
  }
  double global_stiffness_squares;
  PetscCall(MPIU_Allreduce(&stiffness_squares, &global_stiffness_squares, 1, MPI_DOUBLE, MPI_SUM, comm));
  roundoff_force_level_ = 100.0 * std::numeric_limits<double>::epsilon() * std::sqrt(global_stiffness_squares);

  element_line_load_.assign(map.local_elements.size(), Vec3::Zero());
  dead_force_.assign(map.num_owned_nodes, Vec3::Zero());
  dead_moment_ = follower_force_start_ = follower_moment_start_ = follower_force_end_ = follower_moment_end_ = dead_force_;
  element_force_scratch_.assign(kBeamMaxDofs * map.local_elements.size(), 0.0);
  element_correction_scratch_.assign(kBeamMaxDofs * map.local_elements.size(), 0.0);

  // Matrix with exact preallocation; a missed preallocation is a bug, so make it an error.
  std::vector<PetscInt> diagonal_nonzeros, off_diagonal_nonzeros, pattern_row_start, pattern_columns;
  PetscCall(PetscLogEventBegin(event_preallocation, 0, 0, 0, 0));
  PetscCall(DofMapPreallocation(map, model, &diagonal_nonzeros, &off_diagonal_nonzeros, &pattern_row_start, &pattern_columns));
  PetscCall(MatCreate(comm, &jacobian_));
  PetscCall(MatSetSizes(jacobian_, map.num_owned, map.num_owned, map.num_global, map.num_global));
  PetscCall(MatSetType(jacobian_, MATAIJ));
  PetscCall(MatSetOptionsPrefix(jacobian_, "jacobian_"));
  PetscCall(MatSetFromOptions(jacobian_));
  PetscCall(MatSeqAIJSetPreallocation(jacobian_, 0, diagonal_nonzeros.data()));
  PetscCall(MatMPIAIJSetPreallocation(jacobian_, 0, diagonal_nonzeros.data(), 0, off_diagonal_nonzeros.data()));
  // AIJ: the exact pattern itself, all zeros, in one pass (no element-by-element insertion).
  PetscCall(MatSeqAIJSetPreallocationCSR(jacobian_, pattern_row_start.data(), pattern_columns.data(), nullptr));
  PetscCall(MatMPIAIJSetPreallocationCSR(jacobian_, pattern_row_start.data(), pattern_columns.data(), nullptr));
  std::vector<PetscInt>().swap(pattern_columns);
  PetscCall(MatSetOption(jacobian_, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscCall(MatCreateVecs(jacobian_, &solution_template_, nullptr));
  PetscCall(VecDuplicate(solution_template_, &scratch_residual_));
  PetscCall(PetscLogEventEnd(event_preallocation, 0, 0, 0, 0));
  PetscCall(AttachRigidBodyModes());
  PetscCall(PetscLogEventBegin(event_csr_destinations, 0, 0, 0, 0));
  PetscCall(CreateCsrDestinations());
  PetscCall(PetscLogEventEnd(event_csr_destinations, 0, 0, 0, 0));

  // Scatter from the distributed unknowns to the free DOFs of every local node (owned and ghost)
  // and the free coordinates of every local joint.
  std::vector<PetscInt> from;
  ghosted_slot_.assign(6 * nodes_.size(), -1);
  for (size_t l = 0; l < nodes_.size(); ++l)
    for (int d = 0; d < 6; ++d) {
      const PetscInt global = map.node_dofs[map.local_nodes[l]][d];
      if (global < 0) continue;
      ghosted_slot_[6 * l + d] = (PetscInt)from.size();
      from.push_back(global);
    }
  joints_.clear();
  node_local_joint_.assign(nodes_.size(), -1);
  expansion_rows_.assign(nodes_.size(), {});
  expansion_columns_.assign(nodes_.size(), {});
  slave_residual_.assign(nodes_.size(), Vec6::Zero());
  size_t max_unknowns = 6;
  for (int j : map.local_joints) {
    const Joint &joint = model.joints[j];
    LocalJoint   J;
    J.local_index  = (int)joints_.size();
    J.local_slave  = map.node_to_local[joint.slave];
    J.local_master = joint.master >= 0 ? map.node_to_local[joint.master] : -1;
    J.geometry     = JointGeometryOf(joint, JointReferenceOffset(model, joint));
    for (int c = 0; c < JointNumCoordinates(J.geometry); ++c) {
      if (map.joint_dofs[j][c] < 0) continue;
      J.slot[c] = (PetscInt)from.size();
      from.push_back(map.joint_dofs[j][c]);
    }
    node_local_joint_[J.local_slave] = (int)joints_.size();
    const size_t m                   = map.node_unknowns[joint.slave].size();
    expansion_rows_[J.local_slave].assign(6 * m, 0.0);
    expansion_columns_[J.local_slave].assign(6 * m, 0.0);
    max_unknowns = std::max(max_unknowns, m);
    joints_.push_back(J);
  }
  expansion_scratch_.assign(max_unknowns * max_unknowns, 0.0);
  joint_geometric_scratch_.assign(3 * (6 + kJointMaxReleased) * max_unknowns + max_unknowns * max_unknowns, 0.0);
  PetscCall(VecCreateMPI(comm, 12 * (PetscInt)map.num_owned_joints, 12 * map.global_count.joints, &joint_output_));
  IS from_is;
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, (PetscInt)from.size(), from.data(), PETSC_COPY_VALUES, &from_is));
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, (PetscInt)from.size(), &ghosted_increments_));
  PetscCall(VecScatterCreate(solution_template_, from_is, ghosted_increments_, nullptr, &to_ghosted_));
  PetscCall(ISDestroy(&from_is));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AttachRigidBodyModes()
{
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  Vec           modes[6];
  MatNullSpace  near_null_space;
  PetscFunctionBeginUser;
  Vec3 centroid = Vec3::Zero();
  for (const Node &node : model.nodes) centroid += node.position / (double)model.nodes.size();
  for (int k = 0; k < 6; ++k) {
    PetscCall(VecDuplicate(solution_template_, &modes[k]));
    PetscCall(VecZeroEntries(modes[k]));
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const int                      node = map.local_nodes[l];
    const std::array<PetscInt, 6> &dofs = map.node_dofs[node];
    const Vec3                     r    = model.nodes[node].position - centroid;
    for (int k = 0; k < 6; ++k) {
      const Vec3 t = k < 3 ? Vec3(Vec3::Unit(k)) : Vec3::Zero(), w = k < 3 ? Vec3::Zero() : Vec3(Vec3::Unit(k - 3));
      const Vec3 u = t + w.cross(r);
      for (int d = 0; d < 6; ++d)
        if (dofs[d] >= 0) PetscCall(VecSetValue(modes[k], dofs[d], d < 3 ? u(d) : w(d - 3), INSERT_VALUES));
    }
  }
  for (int k = 0; k < 6; ++k) {
    PetscCall(VecAssemblyBegin(modes[k]));
    PetscCall(VecAssemblyEnd(modes[k]));
  }
  // Gram-Schmidt; a mode that vanishes (all its DOFs constrained) is dropped.
  int kept = 0;
  for (int k = 0; k < 6; ++k) {
    PetscScalar dots[6];
    PetscReal   norm;
    if (kept > 0) {
      PetscCall(VecMDot(modes[k], kept, modes, dots));
      for (int i = 0; i < kept; ++i) dots[i] = -dots[i];
      PetscCall(VecMAXPY(modes[k], kept, dots, modes));
    }
    PetscCall(VecNorm(modes[k], NORM_2, &norm));
    if (norm > 1e-10) {
      PetscCall(VecScale(modes[k], 1.0 / norm));
      std::swap(modes[kept], modes[k]);
      ++kept;
    }
  }
  PetscCall(MatNullSpaceCreate(comm_, PETSC_FALSE, kept, modes, &near_null_space));
  PetscCall(MatSetNearNullSpace(jacobian_, near_null_space));
  PetscCall(MatNullSpaceDestroy(&near_null_space));
  for (int k = 0; k < 6; ++k) PetscCall(VecDestroy(&modes[k]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Fixes the pattern with one assembly of zeros, then records where each element-matrix entry
// lands in the CSR arrays of the owned rows.
PetscErrorCode Assembler::CreateCsrDestinations()
{
  const DofMap &map = *map_;
  PetscBool     is_seq, is_mpi;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)jacobian_, MATSEQAIJ, &is_seq));
  PetscCall(PetscObjectTypeCompare((PetscObject)jacobian_, MATMPIAIJ, &is_mpi));
  // AIJ matrices got the pattern from the CSR preallocation; other types get it entry by entry:
  // the nodal blocks (inertia, follower loads, rigid bodies, joints' geometric stiffness, also of
  // nodes without elements, and the couplings slave nodes create), then every element's
  // coupling of the unknowns of all its nodes.
  if (!is_seq && !is_mpi) {
    std::vector<double>   more_zeros;
    std::vector<PetscInt> coupled;
    for (size_t l = 0; l < map.local_nodes.size(); ++l) {
      const std::vector<PetscInt> &unknowns = map.node_unknowns[map.local_nodes[l]];
      more_zeros.assign(unknowns.size() * unknowns.size(), 0.0);
      PetscCall(MatSetValues(jacobian_, (PetscInt)unknowns.size(), unknowns.data(), (PetscInt)unknowns.size(), unknowns.data(), more_zeros.data(), ADD_VALUES));
    }
    for (int e : map.local_elements) {
      coupled.clear();
      for (int a = 0; a <= model_->elements[e].order; ++a)
        coupled.insert(coupled.end(), map.node_unknowns[model_->elements[e].nodes[a]].begin(), map.node_unknowns[model_->elements[e].nodes[a]].end());
      more_zeros.assign(coupled.size() * coupled.size(), 0.0);
      PetscCall(MatSetValues(jacobian_, (PetscInt)coupled.size(), coupled.data(), (PetscInt)coupled.size(), coupled.data(), more_zeros.data(), ADD_VALUES));
    }
  }
  PetscCall(MatAssemblyBegin(jacobian_, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(jacobian_, MAT_FINAL_ASSEMBLY));
  csr_destinations_.clear();
  csr_destination_offsets_.clear();
  if (!is_seq && !is_mpi) PetscFunctionReturn(PETSC_SUCCESS);

  const PetscInt *off_diagonal_columns     = nullptr; // global column of each off-diagonal block column, ascending
  PetscInt        num_off_diagonal_columns = 0;
  diagonal_block_                          = jacobian_;
  off_diagonal_block_                      = nullptr;
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
    const PetscInt *it = std::lower_bound(begin, end, column);
    return (it != end && *it == column) ? (PetscInt)(it - columns) : -1;
  };
  const PetscInt first = map.first_owned, last = map.first_owned + map.num_owned;
  // One flat table for all elements (nd^2 entries each, from csr_destination_offsets_[k]).
  csr_destination_offsets_.assign(map.local_elements.size() + 1, 0);
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const size_t nd                 = 6 * (size_t)(model_->elements[map.local_elements[k]].order + 1);
    csr_destination_offsets_[k + 1] = csr_destination_offsets_[k] + nd * nd;
  }
  csr_destinations_.assign(csr_destination_offsets_.back(), kCsrSkip);
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    PetscInt  indices[kBeamMaxDofs];
    const int nd          = ElementIndices(model_->elements[map.local_elements[k]], map, indices);
    PetscInt *destination = csr_destinations_.data() + csr_destination_offsets_[k];
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
          const PetscInt *it           = std::lower_bound(off_diagonal_columns, off_diagonal_columns + num_off_diagonal_columns, column);
          const PetscInt  local_column = (PetscInt)(it - off_diagonal_columns);
          slot = (it != off_diagonal_columns + num_off_diagonal_columns && *it == column) ? find(ib, jb, row - first, local_column) : -1;
          if (slot >= 0) slot = kCsrOffDiagonal - slot;
        }
        PetscCheck(slot != -1, PETSC_COMM_SELF, PETSC_ERR_PLIB, "entry (%" PetscInt_FMT ", %" PetscInt_FMT ") missing from the preallocated pattern", row,
                   column);
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
  const PetscInt *destination = csr_destinations_.data() + csr_destination_offsets_[local_element];
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

PetscErrorCode Assembler::BeginStep(double t_start, double t_end, const TimeScheme *scheme)
{
  PetscFunctionBeginUser;
  mode_ = scheme ? Mode::Dynamic : Mode::Static;
  if (scheme) scheme_ = *scheme;
  // The mid-point family takes the mean of the loads at both ends of the step.
  const bool midpoint = scheme && scheme->Midpoint();
  load_weight_start_  = midpoint ? 0.5 : 0.0;
  load_weight_end_    = midpoint ? 0.5 : 1.0;
  PetscCall(ComputeLoads(t_start, t_end));
  PetscCall(ApplyPrescribedValues(t_start, t_end));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::BeginInitialAcceleration(double t)
{
  PetscFunctionBeginUser;
  mode_              = Mode::InitialAcceleration;
  load_weight_start_ = 0.0;
  load_weight_end_   = 1.0;
  PetscCall(ComputeLoads(t, t));
  PetscCall(ApplyPrescribedValues(t, t));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::ComputeLoads(double t_start, double t_end)
{
  PetscFunctionBeginUser;
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  const double  w0 = load_weight_start_, w1 = load_weight_end_;
  std::fill(element_line_load_.begin(), element_line_load_.end(), Vec3::Zero());
  for (const DistributedLoad &load : model.distributed_loads) {
    const double factor = w0 * FunctionValue(load.function, t_start) + w1 * FunctionValue(load.function, t_end);
    for (int e : load.elements) {
      const int k = map.element_to_local[e];
      if (k < 0) continue;
      const double scale = load.gravity ? model.sections[model.elements[e].section].rhoA : 1.0;
      element_line_load_[k] += factor * scale * load.force_per_length;
    }
  }
  for (LocalRigidBody &body : rigid_bodies_) {
    body.gravity_force.setZero();
    for (const DistributedLoad &load : model.distributed_loads)
      if (load.gravity)
        body.gravity_force += (w0 * FunctionValue(load.function, t_start) + w1 * FunctionValue(load.function, t_end)) * body.mass * load.force_per_length;
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    dead_force_[l].setZero(), dead_moment_[l].setZero();
    follower_force_start_[l].setZero(), follower_moment_start_[l].setZero(), follower_force_end_[l].setZero(), follower_moment_end_[l].setZero();
  }
  for (const NodalLoad &load : model.nodal_loads) {
    const double f0 = FunctionValue(load.function, t_start), f1 = FunctionValue(load.function, t_end);
    for (int node : load.nodes) {
      const int l = map.node_to_local[node];
      if (l < 0 || l >= map.num_owned_nodes) continue;
      if (load.follower) {
        follower_force_start_[l] += f0 * load.force, follower_moment_start_[l] += f0 * load.moment;
        follower_force_end_[l] += f1 * load.force, follower_moment_end_[l] += f1 * load.moment;
      } else {
        dead_force_[l] += (w0 * f0 + w1 * f1) * load.force;
        dead_moment_[l] += (w0 * f0 + w1 * f1) * load.moment;
      }
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Fixed DOFs keep a zero increment. A prescribed displacement reaches its absolute target
// X + value f(t_end); a prescribed rotation component turns by value (f(t_end) - f(t_start)) about
// its global axis. In the initial-acceleration problem the unknowns are accelerations, so a
// prescribed DOF gets value f''(t).
PetscErrorCode Assembler::ApplyPrescribedValues(double t_start, double t_end)
{
  PetscFunctionBeginUser;
  const DofMap &map = *map_;
  for (size_t l = 0; l < nodes_.size(); ++l) {
    const int  node = map.local_nodes[l];
    NodeState &s    = nodes_[l];
    for (int d = 0; d < 6; ++d) {
      const DofConstraint &c = map.constraints[node][d];
      if (c.kind == Support::Kind::Free) continue;
      double value = 0.0;
      if (c.kind == Support::Kind::Prescribed) {
        if (mode_ == Mode::InitialAcceleration) value = c.value * FunctionDerivative(c.function, t_end, 2);
        else if (d < 3) value = model_->nodes[node].position(d) + c.value * FunctionValue(c.function, t_end) - s.position_start(d);
        else value = c.value * (FunctionValue(c.function, t_end) - FunctionValue(c.function, t_start));
      }
      if (d < 3) s.displacement_increment(d) = value;
      else s.rotation_increment(d - 3) = value;
    }
    UpdateDerivedState(&s);
  }
  // A driven released coordinate reaches value f(t_end) (its second derivative in the
  // initial-acceleration problem).
  for (LocalJoint &J : joints_) {
    const Joint &joint = ModelJoint(J);
    for (int c = 0; c < kJointMaxReleased; ++c) J.increment[c] = 0.0;
    if (joint.driven_coordinate < 0) continue;
    const int c    = joint.driven_coordinate;
    J.increment[c] = mode_ == Mode::InitialAcceleration ? joint.drive_value * FunctionDerivative(joint.drive_function, t_end, 2)
                                                        : joint.drive_value * FunctionValue(joint.drive_function, t_end) - J.start.q[c];
  }
  UpdateSlaves();
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The configuration and, in dynamics, the end-of-step translational motion and the tangent-scaled
// rotation increment implied by the increments. In the initial-acceleration problem the
// "increments" are accelerations and the configuration stays at the start of the step.
void Assembler::UpdateDerivedState(NodeState *s) const
{
  if (mode_ == Mode::InitialAcceleration) return;
  NodeStateUpdateCurrent(s);
  if (mode_ != Mode::Dynamic) return;
  s->translation_update = AdvanceMotion(scheme_, s->translation_motion, s->displacement_increment);
  TangentScaledIncrement(s->rotation_increment, &s->tangent_scaled_increment, &s->tangent_scaled_derivative);
}

PetscErrorCode Assembler::PredictIncrements(Vec increments)
{
  PetscFunctionBeginUser;
  PetscCall(VecZeroEntries(increments));
  if (mode_ != Mode::Dynamic) PetscFunctionReturn(PETSC_SUCCESS);
  const DofMap &map = *map_;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const NodeState &s = nodes_[l];
    Vec6             guess;
    guess.head<3>() = scheme_.dt * s.translation_motion.velocity;
    guess.tail<3>() = scheme_.dt * (QuaternionToMatrix(s.rotation_start) * s.rotation_motion.velocity);
    for (int d = 0; d < 6; ++d) {
      const PetscInt row = map.node_dofs[map.local_nodes[l]][d];
      if (row >= 0) PetscCall(VecSetValue(increments, row, guess(d), INSERT_VALUES));
    }
  }
  PetscCall(VecAssemblyBegin(increments));
  PetscCall(VecAssemblyEnd(increments));
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
    UpdateDerivedState(&s);
  }
  for (LocalJoint &J : joints_)
    for (int c = 0; c < kJointMaxReleased; ++c)
      if (J.slot[c] >= 0) J.increment[c] = PetscRealPart(values[J.slot[c]]);
  PetscCall(VecRestoreArrayRead(ghosted_increments_, &values));
  UpdateSlaves();
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The element's residual: internal forces (at t_{n+1}, or the mid-point forces of mc/em) plus the
// consistent translational inertia minus the distributed loads. For em also the correction
// vector and the element's share of beta's numerator and denominator.
PetscErrorCode Assembler::ElementForces(size_t k, double *force, double *correction, double *work_mismatch, double *correction_work, double *work_scale,
                                        PetscBool *ok)
{
  const BeamElement          &element = model_->elements[map_->local_elements[k]];
  const BeamElementReference &ref     = element_references_[k];
  const int                   n       = element.order + 1;
  Vec3                        positions[kBeamMaxNodes];
  Mat3                        triads[kBeamMaxNodes];
  PetscFunctionBeginUser;
  *ok = PETSC_TRUE;
  ElementConfiguration(element, positions, triads, nullptr);
  const NodeState *node[kBeamMaxNodes];
  for (int a = 0; a < n; ++a) node[a] = &nodes_[map_->node_to_local[element.nodes[a]]];
  *work_mismatch = *correction_work = *work_scale = 0.0;
  if (mode_ == Mode::Dynamic && scheme_.Midpoint()) {
    Vec3   positions_start[kBeamMaxNodes];
    Mat3   triads_start[kBeamMaxNodes];
    double energy_start, energy_end;
    ElementStartConfiguration(element, positions_start, triads_start);
    if (BeamMidpointInternalForces(ref, section_stiffness_[element.section], positions_start, triads_start, positions, triads, force, correction, &energy_start,
                                   &energy_end) != BeamKernelStatus::Ok) {
      *ok = PETSC_FALSE;
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    double work = 0.0;
    for (int a = 0; a < n; ++a) {
      const Vec3  &u = node[a]->displacement_increment, &alpha = node[a]->tangent_scaled_increment;
      const double node_work = u.dot(Vec3(&force[6 * a])) + alpha.dot(Vec3(&force[6 * a + 3]));
      work += node_work;
      *work_scale += std::abs(node_work);
      *correction_work += u.dot(Vec3(&correction[6 * a])) + alpha.dot(Vec3(&correction[6 * a + 3]));
    }
    *work_mismatch = (energy_end - energy_start) - work;
  } else {
    // In the initial-acceleration problem the configuration is the start state, whose internal
    // forces balance inertia and loads.
    if (BeamInternalForces(ref, section_stiffness_[element.section], positions, triads, force, nullptr, nullptr, nullptr) != BeamKernelStatus::Ok)
      *ok = PETSC_FALSE;
  }
  if (!*ok) PetscFunctionReturn(PETSC_SUCCESS);
  // Consistent translational inertia: f_a += rhoA sum_b (integral of I_a I_b ds) xddot_b.
  const double rhoA = model_->sections[element.section].rhoA;
  if (mode_ != Mode::Static && rhoA > 0.0) {
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const Vec3 &acceleration = mode_ == Mode::InitialAcceleration ? node[b]->displacement_increment : node[b]->translation_update.acceleration;
        const Vec3  f            = rhoA * ref.mass_shape[a][b] * acceleration;
        for (int i = 0; i < 3; ++i) force[6 * a + i] += f(i);
      }
  }
  // Consistent dead line load: f_a = integral of I_a q ds.
  for (int a = 0; a < n; ++a)
    for (int i = 0; i < 3; ++i) force[6 * a + i] -= ref.nodal_length[a] * element_line_load_[k](i);
  // Initial accelerations: massless DOF groups take the equation "acceleration = 0" (NodalForces).
  if (mode_ == Mode::InitialAcceleration)
    for (int a = 0; a < n; ++a) {
      const int l = map_->node_to_local[element.nodes[a]];
      for (int i = 0; i < 3; ++i) {
        if (!has_translational_mass_[l]) force[6 * a + i] = 0.0;
        if (!has_rotary_inertia_[l]) force[6 * a + 3 + i] = 0.0;
      }
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Loads and rotary inertia on an owned node: residual (6) and its derivative with respect to
// the node's unknowns (6x6, already with respect to omega, not spins).
void Assembler::NodalForces(PetscInt l, double *force, Mat6 *tangent)
{
  const NodeState &s       = nodes_[l];
  const Mat3       R_start = QuaternionToMatrix(s.rotation_start);
  const Vec3       f_end = s.rotation * follower_force_end_[l], m_end = s.rotation * follower_moment_end_[l];
  Vec6             r;
  r.head<3>() = -(dead_force_[l] + load_weight_start_ * (R_start * follower_force_start_[l]) + load_weight_end_ * f_end);
  r.tail<3>() = -(dead_moment_[l] + load_weight_start_ * (R_start * follower_moment_start_[l]) + load_weight_end_ * m_end);
  if (tangent) tangent->setZero();
  // Follower loads: d(-Lambda f0) = hat(f) d theta = hat(f) H(omega) d omega.
  if (tangent && mode_ != Mode::InitialAcceleration) {
    tangent->block<3, 3>(0, 3) += load_weight_end_ * Skew(f_end) * s.rotation_tangent;
    tangent->block<3, 3>(3, 3) += load_weight_end_ * Skew(m_end) * s.rotation_tangent;
  }
  const Mat3 &J = node_inertia_[l];
  if (mode_ == Mode::Dynamic && !J.isZero(0.0)) {
    Vec3         moment;
    Mat3         moment_tangent;
    MotionUpdate update;
    RotationalInertia(scheme_, J, R_start, s.rotation_increment, s.rotation_motion, &moment, tangent ? &moment_tangent : nullptr, &update);
    r.tail<3>() += moment;
    if (tangent) tangent->block<3, 3>(3, 3) += moment_tangent;
  } else if (mode_ == Mode::InitialAcceleration) {
    // R (J Wdot + W x J W) with Wdot = R^T wdot, wdot the unknown spatial angular acceleration.
    const Vec3 &W = s.rotation_motion.velocity;
    r.tail<3>() += R_start * (J * (R_start.transpose() * s.rotation_increment) + W.cross(J * W));
    if (tangent) tangent->block<3, 3>(3, 3) += R_start * J * R_start.transpose();
    // Massless groups: the equation is "acceleration = 0".
    if (!has_translational_mass_[l]) {
      r.head<3>() = s.displacement_increment;
      if (tangent) tangent->block<3, 3>(0, 0) = Mat3::Identity(), tangent->block<3, 3>(0, 3).setZero();
    }
    if (!has_rotary_inertia_[l]) {
      r.tail<3>() = s.rotation_increment;
      if (tangent) tangent->block<3, 3>(3, 3) = Mat3::Identity(), tangent->block<3, 3>(3, 0).setZero();
    }
  }
  for (int i = 0; i < 6; ++i) force[i] = r(i);
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
  // Pass 1: element vectors (and, for em, the pieces of beta).
  double sums[3] = {0.0, 0.0, 0.0}; // work mismatch, correction work, scale of the internal work
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    double    mismatch, correction_work, work_scale;
    PetscBool ok;
    PetscCall(ElementForces(k, &element_force_scratch_[kBeamMaxDofs * k], &element_correction_scratch_[kBeamMaxDofs * k], &mismatch, &correction_work,
                            &work_scale, &ok));
    if (!ok) *geometry_ok = PETSC_FALSE;
    sums[0] += mismatch;
    sums[1] += correction_work;
    sums[2] += work_scale;
  }
  // em (eq. 20): beta makes the work of the internal forces equal the change of strain energy.
  // A mismatch within round-off of the internal work (1e-13 of the sum of |u.f|) is not
  // corrected: near steady motion the correction does almost no work and beta would be a ratio of
  // round-off, which stalls Newton.
  energy_correction_ = 0.0;
  if (mode_ == Mode::Dynamic && scheme_.kind == TimeSchemeKind::EnergyMomentum) {
    double global[3];
    PetscCall(MPIU_Allreduce(sums, global, 3, MPI_DOUBLE, MPI_SUM, comm_));
    if (std::abs(global[0]) > 1e-13 * global[2] && global[1] != 0.0) energy_correction_ = global[0] / global[1];
  }
  // Pass 2: assemble. The residual left on prescribed DOFs is the reaction that drives them; its
  // work over the increments counts as external work.
  prescribed_work_     = 0.0;
  auto add_node_vector = [&](int node, const double *r) -> PetscErrorCode {
    PetscFunctionBeginUser;
    const int        l = map.node_to_local[node];
    const NodeState &s = nodes_[l];
    for (int d = 0; d < 6; ++d) {
      local_force_squares_ += r[d] * r[d];
      if (map.constraints[node][d].kind == Support::Kind::Prescribed)
        prescribed_work_ += r[d] * (d < 3 ? s.displacement_increment(d) : s.tangent_scaled_increment(d - 3));
    }
    if (node_local_joint_[l] >= 0) slave_residual_[l] += Eigen::Map<const Vec6>(r);
    PetscCall(AddNodeVector(residual, l, r));
    PetscFunctionReturn(PETSC_SUCCESS);
  };
  for (Vec6 &g : slave_residual_) g.setZero();
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    double            *f       = &element_force_scratch_[kBeamMaxDofs * k];
    if (energy_correction_ != 0.0)
      for (int i = 0; i < 6 * (element.order + 1); ++i) f[i] += energy_correction_ * element_correction_scratch_[kBeamMaxDofs * k + i];
    for (int a = 0; a <= element.order; ++a) PetscCall(add_node_vector(element.nodes[a], &f[6 * a]));
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    double r[6];
    NodalForces(l, r, nullptr);
    PetscCall(add_node_vector(map.local_nodes[l], r));
  }
  for (LocalRigidBody &body : rigid_bodies_) {
    Vec6 r;
    PetscCall(RigidBodyForces(&body, &r, nullptr));
    PetscCall(add_node_vector(map.local_nodes[body.local_node], r.data()));
  }
  PetscCall(VecAssemblyBegin(residual));
  PetscCall(VecAssemblyEnd(residual));
  PetscCall(PetscLogEventEnd(event_residual, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Translational inertia of a rigid body's centre of mass and its weight, mapped to the node. The
// weight acts at the centre of mass with the lever arm of the scheme's virtual work: r_{n+1}
// (statics, Newmark family), (r_n + r_{n+1})/2 (mid-point), r_n (initial accelerations).
PetscErrorCode Assembler::RigidBodyForces(LocalRigidBody *body, Vec6 *force, Mat6 *tangent)
{
  const NodeState &s       = nodes_[body->local_node];
  const Mat3       R_start = QuaternionToMatrix(s.rotation_start);
  const Vec3       r_start = R_start * body->offset, r_end = s.rotation * body->offset;
  PetscFunctionBeginUser;
  force->setZero();
  if (tangent) tangent->setZero();
  if (mode_ == Mode::Dynamic) {
    OffsetPointMassInertia(scheme_, body->mass, body->offset, R_start, s.displacement_increment, s.rotation_increment, body->centre_of_mass, force, tangent,
                           &body->centre_of_mass_update);
  } else if (mode_ == Mode::InitialAcceleration) {
    // a_c = a + wdot x r + w x (w x r): force m a_c, moment r x m a_c.
    const Vec3 w     = R_start * s.rotation_motion.velocity;
    const Vec3 F     = body->mass * (s.displacement_increment + s.rotation_increment.cross(r_start) + w.cross(w.cross(r_start)));
    force->head<3>() = F;
    force->tail<3>() = r_start.cross(F);
    if (tangent) {
      const Mat3 hr              = Skew(r_start);
      tangent->block<3, 3>(0, 0) = body->mass * Mat3::Identity();
      tangent->block<3, 3>(0, 3) = -body->mass * hr;
      tangent->block<3, 3>(3, 0) = body->mass * hr;
      tangent->block<3, 3>(3, 3) = -body->mass * hr * hr;
    }
  }
  if (!body->gravity_force.isZero(0.0)) {
    const bool   midpoint   = mode_ == Mode::Dynamic && scheme_.Midpoint();
    const double arm_weight = mode_ == Mode::InitialAcceleration ? 0.0 : (midpoint ? 0.5 : 1.0); // d arm / d r_{n+1}
    const Vec3   arm        = mode_ == Mode::InitialAcceleration ? r_start : (midpoint ? Vec3(0.5 * (r_start + r_end)) : r_end);
    force->head<3>() -= body->gravity_force;
    force->tail<3>() -= arm.cross(body->gravity_force);
    // d(-arm x F) = hat(F) d arm,  d r_{n+1} = -hat(r_{n+1}) H(omega) d omega
    if (tangent && arm_weight != 0.0) tangent->block<3, 3>(3, 3) -= arm_weight * Skew(body->gravity_force) * Skew(r_end) * s.rotation_tangent;
  }
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
  // Stiffness weight: 1 at t_{n+1}; the mid-point forces move half as fast as the end state; none
  // in the initial-acceleration problem. Mass weight: d(acceleration)/d(unknown).
  double stiffness_weight = 1.0, mass_weight = 0.0;
  if (mode_ == Mode::Dynamic) {
    stiffness_weight = scheme_.Midpoint() ? 0.5 : 1.0;
    mass_weight      = scheme_.InertiaCoefficient();
  } else if (mode_ == Mode::InitialAcceleration) {
    stiffness_weight = 0.0;
    mass_weight      = 1.0;
  }
  PetscCall(MatZeroEntries(jacobian));
  PetscScalar *diagonal_values = nullptr, *off_diagonal_values = nullptr;
  if (!csr_destinations_.empty()) {
    PetscCall(MatSeqAIJGetArray(diagonal_block_, &diagonal_values));
    if (off_diagonal_block_) PetscCall(MatSeqAIJGetArray(off_diagonal_block_, &off_diagonal_values));
  }
  // Consistent translational mass of local element k into its (6n x 6n) matrix K.
  auto add_consistent_mass = [&](size_t k, const BeamElement &element, double *K) {
    const double rhoA = model.sections[element.section].rhoA;
    if (mass_weight == 0.0 || !(rhoA > 0.0)) return;
    const int n = element.order + 1, nd = 6 * n;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        for (int i = 0; i < 3; ++i) K[(6 * a + i) * nd + 6 * b + i] += mass_weight * rhoA * element_references_[k].mass_shape[a][b];
  };
  for (Vec6 &g : slave_residual_) g.setZero();
  std::vector<size_t> elements_with_slaves;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    const int          n       = element.order + 1;
    const int          nd      = 6 * n;
    double             r[kBeamMaxDofs], K[kBeamMaxDofs * kBeamMaxDofs];
    PetscInt           indices[kBeamMaxDofs];
    bool               touches_slave = false;
    for (int a = 0; a < n; ++a) touches_slave |= node_local_joint_[map.node_to_local[element.nodes[a]]] >= 0;
    if (touches_slave) { // through the nodes' expansions, after the direct CSR updates
      elements_with_slaves.push_back(k);
      continue;
    }
    std::fill(K, K + nd * nd, 0.0);
    if (stiffness_weight != 0.0) {
      Vec3        positions[kBeamMaxNodes];
      Mat3        triads[kBeamMaxNodes];
      const Mat3 *tangents[kBeamMaxNodes];
      ElementConfiguration(element, positions, triads, tangents);
      if (BeamInternalForces(element_references_[k], section_stiffness_[element.section], positions, triads, r, K, nullptr, nullptr) != BeamKernelStatus::Ok) {
        *geometry_ok = PETSC_FALSE;
        continue;
      }
      // Column scaling from spins to incremental rotation vectors: d theta_b = H(omega_b) d omega_b.
      for (int b = 0; b < n; ++b) {
        const Mat3 &H = *tangents[b];
        for (int i = 0; i < nd; ++i) {
          double      *row = &K[i * nd + 6 * b + 3];
          const double k0 = row[0], k1 = row[1], k2 = row[2];
          for (int j = 0; j < 3; ++j) row[j] = stiffness_weight * (k0 * H(0, j) + k1 * H(1, j) + k2 * H(2, j));
        }
        for (int i = 0; i < nd; ++i)
          for (int j = 0; j < 3; ++j) K[i * nd + 6 * b + j] *= stiffness_weight;
      }
    }
    add_consistent_mass(k, element, K);
    ElementIndices(element, map, indices);
    PetscCall(AddElementMatrix(k, indices, nd, K, diagonal_values, off_diagonal_values));
  }
  if (!csr_destinations_.empty()) {
    PetscCall(MatSeqAIJRestoreArray(diagonal_block_, &diagonal_values));
    if (off_diagonal_block_) PetscCall(MatSeqAIJRestoreArray(off_diagonal_block_, &off_diagonal_values));
  }
  // Elements touching slave nodes: spin-form tangent through the expansions, and their residual
  // gathered on the slaves for the joints' geometric stiffness.
  for (size_t k : elements_with_slaves) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    const int          n       = element.order + 1;
    const int          nd      = 6 * n;
    double             r[kBeamMaxDofs], K[kBeamMaxDofs * kBeamMaxDofs], g[kBeamMaxDofs], correction[kBeamMaxDofs], unused[3];
    PetscBool          ok = PETSC_TRUE;
    std::fill(K, K + nd * nd, 0.0);
    if (stiffness_weight != 0.0) {
      Vec3 positions[kBeamMaxNodes];
      Mat3 triads[kBeamMaxNodes];
      ElementConfiguration(element, positions, triads, nullptr);
      if (BeamInternalForces(element_references_[k], section_stiffness_[element.section], positions, triads, r, K, nullptr, nullptr) != BeamKernelStatus::Ok)
        ok = PETSC_FALSE;
      for (int i = 0; i < nd * nd; ++i) K[i] *= stiffness_weight;
    }
    if (ok) PetscCall(ElementForces(k, g, correction, &unused[0], &unused[1], &unused[2], &ok));
    if (!ok) {
      *geometry_ok = PETSC_FALSE;
      continue;
    }
    add_consistent_mass(k, element, K);
    for (int a = 0; a < n; ++a) {
      const int l = map.node_to_local[element.nodes[a]];
      if (node_local_joint_[l] >= 0) slave_residual_[l] += Eigen::Map<const Vec6>(&g[6 * a]);
    }
    PetscCall(AddExpandedElementMatrix(jacobian, element, K));
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    double r[6];
    Mat6   block;
    NodalForces(l, r, &block);
    if (node_local_joint_[l] >= 0) slave_residual_[l] += Eigen::Map<const Vec6>(r);
    if (!block.isZero(0.0)) PetscCall(AddNodeBlock(jacobian, (int)l, block));
  }
  for (LocalRigidBody &body : rigid_bodies_) {
    Vec6 r;
    Mat6 block;
    PetscCall(RigidBodyForces(&body, &r, &block));
    if (node_local_joint_[body.local_node] >= 0) slave_residual_[body.local_node] += r;
    PetscCall(AddNodeBlock(jacobian, body.local_node, block));
  }
  if (mode_ != Mode::InitialAcceleration) PetscCall(AddJointGeometricStiffness(jacobian));
  PetscCall(MatAssemblyBegin(jacobian, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(jacobian, MAT_FINAL_ASSEMBLY));
  PetscCall(PetscLogEventEnd(event_jacobian, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::CommitStep()
{
  PetscFunctionBeginUser;
  if (mode_ == Mode::Dynamic) {
    for (LocalRigidBody &body : rigid_bodies_) {
      const NodeState   &s       = nodes_[body.local_node];
      const Mat3         R_start = QuaternionToMatrix(s.rotation_start);
      const Vec3         u_c     = s.displacement_increment + (s.rotation - R_start) * body.offset;
      const MotionUpdate next    = AdvanceMotion(scheme_, body.centre_of_mass, u_c);
      body.centre_of_mass        = {next.velocity, next.acceleration, next.pseudo_acceleration};
    }
    for (NodeState &s : nodes_) {
      const Mat3 R_start = QuaternionToMatrix(s.rotation_start);
      // Material increment: Theta = R_n^T omega (Newmark family), theta = R_n^T alpha (mid-point).
      const Vec3         increment = R_start.transpose() * (scheme_.Midpoint() ? s.tangent_scaled_increment : s.rotation_increment);
      const MotionUpdate rotation  = AdvanceMotion(scheme_, s.rotation_motion, increment);
      s.translation_motion         = {s.translation_update.velocity, s.translation_update.acceleration, s.translation_update.pseudo_acceleration};
      s.rotation_motion            = {rotation.velocity, rotation.acceleration, rotation.pseudo_acceleration};
    }
  }
  for (NodeState &s : nodes_) NodeStateCommit(&s);
  for (LocalJoint &J : joints_) {
    const int nt = J.geometry.num_translations;
    if (J.geometry.rotation == JointRotation::Free) {
      J.start.free_rotation_start = ExpSO3(Vec3(J.increment[nt], J.increment[nt + 1], J.increment[nt + 2])) * J.start.free_rotation_start;
      for (int c = 0; c < nt; ++c) J.start.q[c] += J.increment[c];
    } else {
      for (int c = 0; c < kJointMaxReleased; ++c) J.start.q[c] += J.increment[c];
    }
    for (double &increment : J.increment) increment = 0.0;
  }
  UpdateSlaves();
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::CommitInitialAcceleration()
{
  PetscFunctionBeginUser;
  PetscCheck(mode_ == Mode::InitialAcceleration, PETSC_COMM_SELF, PETSC_ERR_ORDER, "no initial-acceleration problem was set up");
  for (LocalRigidBody &body : rigid_bodies_) {
    const NodeState &s = nodes_[body.local_node];
    const Mat3       R = QuaternionToMatrix(s.rotation_start);
    const Vec3       r = R * body.offset, w = R * s.rotation_motion.velocity;
    const Vec3       a               = s.displacement_increment + s.rotation_increment.cross(r) + w.cross(w.cross(r));
    body.centre_of_mass.acceleration = body.centre_of_mass.pseudo_acceleration = a;
  }
  for (NodeState &s : nodes_) {
    const Mat3 R                      = QuaternionToMatrix(s.rotation_start);
    s.translation_motion.acceleration = s.translation_motion.pseudo_acceleration = s.displacement_increment;
    s.rotation_motion.acceleration = s.rotation_motion.pseudo_acceleration = R.transpose() * s.rotation_increment;
    s.displacement_increment.setZero();
    s.rotation_increment.setZero();
  }
  for (LocalJoint &J : joints_)
    for (double &increment : J.increment) increment = 0.0;
  mode_ = Mode::Static;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::DiscardStep()
{
  PetscFunctionBeginUser;
  for (NodeState &s : nodes_) {
    s.displacement_increment.setZero();
    s.rotation_increment.setZero();
    UpdateDerivedState(&s);
  }
  for (LocalJoint &J : joints_)
    for (double &increment : J.increment) increment = 0.0;
  UpdateSlaves();
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::SetInitialVelocities(double t)
{
  PetscFunctionBeginUser;
  const Model                          &model = *model_;
  const DofMap                         &map   = *map_;
  std::vector<const InitialCondition *> condition(model.nodes.size(), nullptr);
  for (const InitialCondition &ic : model.initial_conditions)
    for (int node : ic.nodes) condition[node] = &ic;
  for (size_t l = 0; l < nodes_.size(); ++l) {
    const int  node = map.local_nodes[l];
    NodeState &s    = nodes_[l];
    Vec3       v = Vec3::Zero(), w = Vec3::Zero();
    if (const InitialCondition *ic = condition[node]) {
      w = ic->angular_velocity;
      v = ic->velocity + (ic->rigid_body_field ? Vec3(ic->angular_velocity.cross(model.nodes[node].position - ic->center)) : Vec3::Zero());
    }
    for (int d = 0; d < 6; ++d) {
      const DofConstraint &c = map.constraints[node][d];
      if (c.kind == Support::Kind::Free) continue;
      const double rate = c.kind == Support::Kind::Prescribed ? c.value * FunctionDerivative(c.function, t, 1) : 0.0;
      if (d < 3) v(d) = rate;
      else w(d - 3) = rate;
    }
    s.translation_motion.velocity = v;
    s.rotation_motion.velocity    = QuaternionToMatrix(s.rotation_start).transpose() * w;
  }
  // A slave without an initial condition moves rigidly with its master (released rates zero).
  for (const LocalJoint &J : joints_) {
    const Joint &joint = ModelJoint(J);
    if (condition[joint.slave]) continue;
    NodeState &slave = nodes_[J.local_slave];
    Vec3       v = Vec3::Zero(), w = Vec3::Zero();
    if (J.local_master >= 0) {
      const NodeState &master = nodes_[J.local_master];
      w                       = QuaternionToMatrix(master.rotation_start) * master.rotation_motion.velocity;
      v                       = master.translation_motion.velocity + w.cross(slave.position_start - master.position_start);
    }
    slave.translation_motion.velocity = v;
    slave.rotation_motion.velocity    = QuaternionToMatrix(slave.rotation_start).transpose() * w;
  }
  for (LocalRigidBody &body : rigid_bodies_) {
    const NodeState &s           = nodes_[body.local_node];
    const Mat3       R           = QuaternionToMatrix(s.rotation_start);
    body.centre_of_mass.velocity = s.translation_motion.velocity + (R * s.rotation_motion.velocity).cross(R * body.offset);
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
  const Model  &model        = *model_;
  const DofMap &map          = *map_;
  double        local_energy = 0.0;
  results->resize(map.local_elements.size());
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    Vec3               positions[kBeamMaxNodes];
    Mat3               triads[kBeamMaxNodes];
    ElementConfiguration(element, positions, triads, nullptr);
    double                 r[kBeamMaxDofs], energy = 0.0;
    BeamGaussResults       gauss;
    const BeamKernelStatus status =
        BeamInternalForces(element_references_[k], section_stiffness_[element.section], positions, triads, r, nullptr, &energy, &gauss);
    PetscCheck(status == BeamKernelStatus::Ok, PETSC_COMM_SELF, PETSC_ERR_PLIB, "element %d cannot be evaluated in a converged state", map.local_elements[k]);
    local_energy += energy;
    ElementResults &out = (*results)[k];
    out                 = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    const int ng        = element_references_[k].num_gauss;
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

PetscErrorCode Assembler::EvaluateDynamics(DynamicsDiagnostics *diagnostics)
{
  PetscFunctionBeginUser;
  const Model  &model    = *model_;
  const DofMap &map      = *map_;
  double        local[7] = {0, 0, 0, 0, 0, 0, 0}; // T, p (3), L (3)
  auto          add      = [&local](double T, const Vec3 &p, const Vec3 &L) {
    local[0] += T;
    for (int i = 0; i < 3; ++i) local[1 + i] += p(i), local[4 + i] += L(i);
  };
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    const double       rhoA    = model.sections[element.section].rhoA;
    for (int a = 0; a <= element.order; ++a) {
      const NodeState &sa = nodes_[map.node_to_local[element.nodes[a]]];
      for (int b = 0; b <= element.order; ++b) {
        const NodeState &sb = nodes_[map.node_to_local[element.nodes[b]]];
        const Vec3       p  = rhoA * element_references_[k].mass_shape[a][b] * sb.translation_motion.velocity;
        add(0.5 * sa.translation_motion.velocity.dot(p), p, sa.position_start.cross(p));
      }
    }
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const NodeState &s  = nodes_[l];
    const Vec3       JW = node_inertia_[l] * s.rotation_motion.velocity;
    add(0.5 * s.rotation_motion.velocity.dot(JW), Vec3::Zero(), QuaternionToMatrix(s.rotation_start) * JW);
  }
  for (const LocalRigidBody &body : rigid_bodies_) {
    const NodeState &s  = nodes_[body.local_node];
    const Vec3       xc = s.position_start + QuaternionToMatrix(s.rotation_start) * body.offset;
    const Vec3       p  = body.mass * body.centre_of_mass.velocity;
    add(0.5 * body.centre_of_mass.velocity.dot(p), p, xc.cross(p));
  }
  double global[7];
  PetscCall(MPIU_Allreduce(local, global, 7, MPI_DOUBLE, MPI_SUM, comm_));
  diagnostics->kinetic_energy   = global[0];
  diagnostics->linear_momentum  = Vec3(global[1], global[2], global[3]);
  diagnostics->angular_momentum = Vec3(global[4], global[5], global[6]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::StepExternalWork(double *work)
{
  PetscBool evaluable;
  PetscFunctionBeginUser;
  // The reactions on prescribed DOFs at exactly these increments.
  PetscCall(AssembleResidual(scratch_residual_, &evaluable));
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  double        local = 0.0;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    for (int a = 0; a <= element.order; ++a)
      local += element_references_[k].nodal_length[a] * element_line_load_[k].dot(nodes_[map.node_to_local[element.nodes[a]]].displacement_increment);
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const NodeState &s       = nodes_[l];
    const Mat3       R_start = QuaternionToMatrix(s.rotation_start);
    const Vec3       F = dead_force_[l] + load_weight_start_ * (R_start * follower_force_start_[l]) + load_weight_end_ * (s.rotation * follower_force_end_[l]);
    const Vec3 M = dead_moment_[l] + load_weight_start_ * (R_start * follower_moment_start_[l]) + load_weight_end_ * (s.rotation * follower_moment_end_[l]);
    Vec3       alpha;
    TangentScaledIncrement(s.rotation_increment, &alpha, nullptr);
    local += F.dot(s.displacement_increment) + M.dot(alpha);
  }
  for (const LocalRigidBody &body : rigid_bodies_) {
    const NodeState &s = nodes_[body.local_node];
    local += body.gravity_force.dot(s.displacement_increment + (s.rotation - QuaternionToMatrix(s.rotation_start)) * body.offset);
  }
  local += prescribed_work_;
  // Drives: the generalised reaction on a driven coordinate times its test increment.
  PropagateSlaveResiduals();
  for (const LocalJoint &J : joints_) {
    const int c = ModelJoint(J).driven_coordinate;
    if (c >= 0) local += J.rows_map.col(6 + c).dot(slave_residual_[J.local_slave]) * J.released_test[c];
  }
  PetscCall(MPIU_Allreduce(&local, work, 1, MPI_DOUBLE, MPI_SUM, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
