#include "assembly/assembler.hpp"
#include "core/errors.hpp"
#include "elements/massless.hpp"

#include "contributors/beam_contributor.hpp"
#include "contributors/inertia_contributor.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <petscpc.h>

namespace msflex {

namespace {
// em's beta of eq. (20) from the summed work mismatch M, correction work C and round-off scale S
// of the internal work and energies (the sum of |u| |f| over the elements' nodes and of their
// |Pi_n| + |Pi_{n+1}|): M / C, or 0 when M or C is within round-off of S (1e-13 S).
// A mismatch at round-off needs no correction (near steady motion); a correction that does work
// only at round-off cannot make one (a rigidly moving beam, whose F_corr vanishes): either way
// beta would be a ratio of round-off, whose force Newton would then have to balance. (S was the
// sum of |u.f| per node: on a beam spinning steadily with damping the increments run across the
// tension, u.f ~ 0 while |u| |f| ~ 1, so M was noise of 1e-15 against a floor of 1e-19, and
// beta = noise / C swung to 10^3 as the damped vibration and C died out; Newton then failed.)
double BetaOfWorkSums(const double sums[3])
{
  const double floor = 1e-13 * sums[2];
  return std::abs(sums[0]) > floor && std::abs(sums[1]) > floor ? sums[0] / sums[1] : 0.0;
}

PetscLogEvent event_residual = 0, event_jacobian = 0, event_energy_correction = 0, event_csr_destinations = 0;

// Per joint in EvaluateJointReactions' vector: the slave's residual (6), the rates (6), the drive's
// generalised force (1, at kDriveForceSlot).
constexpr int kJointOutputStride = 13, kDriveForceSlot = 12;

// Global row/column indices of an element's DOFs (-1 for constrained DOFs: PETSc ignores them).
int ElementIndices(const BeamElement &element, const DofMap &map, PetscInt *indices)
{
  const int num_nodes = element.order + 1;
  for (int a = 0; a < num_nodes; ++a)
    for (int d = 0; d < 6; ++d) indices[6 * a + d] = map.node_dofs[element.nodes[a]][d];
  return 6 * num_nodes;
}
// The round-off floor of the residual from the nodal coordinates. An element's strains come from
// differences of positions x_a - x_c of magnitude |x| ~ R (the model's largest reference
// coordinate), each rounded to eps R, divided by
// the element length h: a stress error of |C_N| eps R / h per element, independent from element
// to element, so the residual's norm cannot drop below about eps sqrt(sum_e (|C_N| R / h_e)^2),
// which grows like N^1.5 with the element count N. Newton stops there instead of iterating on
// round-off (ForceScaledConvergenceTest in integrators/newton.cpp). Returns the local sum.
// The size of the model's coordinates: the largest |x_i| of a node's reference position.
double ModelReach(const Model &model)
{
  double reach = 0.0;
  for (const Node &node : model.nodes) reach = std::max(reach, node.position.cwiseAbs().maxCoeff());
  return reach;
}

// Per unit reach: sum_e (|C_N| / h_e)^2, the rounding eps R of the coordinates in the strains.
double LocalPositionRoundoffSquares(const Model &model, const DofMap &map)
{
  if (model.nodes.empty()) return 0.0;
  const double reach   = 1.0;
  double       squares = 0.0;
  for (const int e : map.local_elements) {
    const BeamElement &element = model.elements[e];
    const Section     &section = model.sections[element.section];
    const double       h       = (model.nodes[element.nodes[element.order]].position - model.nodes[element.nodes[0]].position).norm();
    if (!(h > 0.0)) continue;
    const double axial_shear = std::sqrt(section.EA * section.EA + section.GA2 * section.GA2 + section.GA3 * section.GA3);
    squares += std::pow(axial_shear * reach / h, 2);
  }
  return squares;
}
} // namespace

Assembler::~Assembler()
{
  MatDestroy(&jacobian_);
  MatDestroy(&correction_jacobian_);
  VecDestroy(&rank_one_left_);
  VecDestroy(&rank_one_right_);
  VecDestroy(&beta_gradient_correction_);
  VecDestroy(&solution_template_);
  VecDestroy(&ghosted_increments_);
  VecDestroy(&scratch_residual_);
  VecDestroy(&last_increments_);
  VecDestroy(&set_increments_);
  VecScatterDestroy(&to_ghosted_);
  VecDestroy(&joint_output_);
}

PetscErrorCode Assembler::Setup(MPI_Comm comm, const Model &model, const DofMap &map, MatrixPattern pattern, std::vector<ForceContributor *> contributors,
                                const BeamContributor *beams, const InertiaContributor *inertia, State *state)
{
  PetscFunctionBeginUser;
  if (!event_residual) {
    PetscCall(PetscLogEventRegister("AssembleResidual", MAT_CLASSID, &event_residual));
    PetscCall(PetscLogEventRegister("AssembleJacobian", MAT_CLASSID, &event_jacobian));
    PetscCall(PetscLogEventRegister("AssembleEmBeta", MAT_CLASSID, &event_energy_correction)); // em: the elements' forces and beta's sums
    PetscCall(PetscLogEventRegister("CsrDestinations", MAT_CLASSID, &event_csr_destinations));
  }
  comm_         = comm;
  model_        = &model;
  map_          = &map;
  state_        = state;
  contributors_ = std::move(contributors);
  beams_        = beams;
  inertia_      = inertia;
  element_contributors_.clear();
  node_contributors_.clear();
  for (ForceContributor *c : contributors_) {
    if (c->ActsOnElements()) element_contributors_.push_back(c);
    if (c->ActsOnNodes()) node_contributors_.push_back(c);
  }

  double global_stiffness_squares, stiffness_squares = beams->LocalStiffnessSquares();
  PetscCall(MPIU_Allreduce(&stiffness_squares, &global_stiffness_squares, 1, MPI_DOUBLE, MPI_SUM, comm));
  // Per unit reach: the positions' part, and the inertia's at R = 1 and R = 0 (its part without R).
  const double local_sums[3] = {LocalPositionRoundoffSquares(model, map), inertia ? inertia->LocalInertiaRoundoffSquares(1.0) : 0.0,
                                inertia ? inertia->LocalInertiaRoundoffSquares(0.0) : 0.0};
  double       sums[3];
  PetscCall(MPIU_Allreduce(local_sums, sums, 3, MPI_DOUBLE, MPI_SUM, comm));
  stiffness_roundoff_squares_          = global_stiffness_squares;
  position_roundoff_squares_per_reach_ = sums[0];
  inertia_roundoff_squares_fixed_      = sums[2];
  inertia_roundoff_squares_per_reach_  = std::max(0.0, sums[1] - sums[2]);
  const double local_reach             = ModelReach(model);
  // Joints pass their slaves' forces on to the masters as moments, with lever arms up to the
  // model's reach (a chain of joints: its length): the inertia's rounding reaches the residual
  // multiplied by them (StagnationLevel).
  double reach = 0.0;
  PetscCall(MPIU_Allreduce(&local_reach, &reach, 1, MPI_DOUBLE, MPI_MAX, comm));
  has_joints_  = map.global_count.joints > 0;
  setup_reach_ = reach;
  reach_       = -1.0;
  SetRoundoffReach(reach);
  double damping_squares = 0.0;
  for (ForceContributor *c : contributors_) damping_squares += c->LocalDampingRoundoffSquares();
  PetscCall(MPIU_Allreduce(&damping_squares, &global_damping_squares_, 1, MPI_DOUBLE, MPI_SUM, comm));

  element_force_scratch_.assign(kBeamMaxDofs * map.local_elements.size(), 0.0);
  element_correction_scratch_.assign(kBeamMaxDofs * map.local_elements.size(), 0.0);
  element_has_slave_.assign(map.local_elements.size(), 0);
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    for (int a = 0; a <= element.order; ++a) element_has_slave_[k] |= state->node_joint[map.node_to_local[element.nodes[a]]] >= 0;
  }

  // Matrix with exact preallocation; a missed preallocation is a bug, so make it an error.
  PetscCall(MatCreate(comm, &jacobian_));
  PetscCall(MatSetSizes(jacobian_, map.num_owned, map.num_owned, map.num_global, map.num_global));
  // -jacobian_dense_below N: a model of at most N unknowns on one rank gets a dense tangent,
  // factored by msflex's dense LU; an exactly singular tangent is a failed step, as with MUMPS
  // (src/core/dense_lu.cpp). -jacobian_mat_type wins. The default depends on what factors the
  // tangent (docs/solvers.md):
  //  - where it is factored for its inertia at every equilibrium (statics with the stability
  //    account or path control, modes, buckling), 128: LAPACK's LDL^T then counts the pivots
  //    instead of MUMPS (bend45, 96 unknowns: 0.012 s dense against 0.021 s sparse; the deep
  //    arch's 475 take 0.61 s dense against 0.19 s);
  //  - elsewhere 16: PETSc's banded LU of a sparse tangent cost less than the dense LU from about
  //    18 unknowns on (a chain of 4 elements, 24 unknowns: 36 against 40 us per step; 12 elements:
  //    76 against 156; the flying spaghetti's 66: 0.113 against 0.180 s), while a dense tangent
  //    stays faster for a few unknowns (the massless pendulum's 13: 0.033 against 0.034 s).
  PetscMPIInt ranks;
  PetscCallMPI(MPI_Comm_size(comm, &ranks));
  // 0 when the options choose the preconditioner or factorisation package themselves (-pc_type,
  // -pc_factor_mat_solver_type): those are for sparse matrices.
  char      pc_type[64] = "";
  PetscBool chosen_pc = PETSC_FALSE, chosen_package = PETSC_FALSE;
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-pc_type", pc_type, sizeof(pc_type), &chosen_pc));
  PetscCall(PetscOptionsHasName(nullptr, nullptr, "-pc_factor_mat_solver_type", &chosen_package));
  const AnalysisSettings &analysis             = model.analysis;
  const bool              multigrid            = analysis.linear_solver == LinearSolverKind::Multigrid;
  const bool              factored_for_inertia = analysis.type == AnalysisType::Modes || analysis.type == AnalysisType::Buckling ||
                                    (analysis.type == AnalysisType::Static && (analysis.stability || analysis.control != PathControl::Load));
  PetscInt dense_below = chosen_pc || chosen_package || multigrid ? 0 : factored_for_inertia ? 128 : 16; // default
  MSFLEX_CALL_READING_OPTIONS(comm, PetscOptionsGetInt(nullptr, "jacobian_", "-dense_below", &dense_below, nullptr));
  PetscCheck(dense_below >= 0, comm, PETSC_ERR_USER_INPUT, "bad option: -jacobian_dense_below %" PetscInt_FMT ": must be >= 0 (0: never)", dense_below);
  PetscCall(MatSetType(jacobian_, ranks == 1 && map.num_global <= dense_below ? MATSEQDENSE : MATAIJ));
  PetscCall(MatSetOptionsPrefix(jacobian_, "jacobian_"));
  MSFLEX_CALL_READING_OPTIONS(PetscObjectComm((PetscObject)jacobian_), MatSetFromOptions(jacobian_));
  PetscBool type_chosen;
  PetscCall(PetscOptionsHasName(nullptr, "jacobian_", "-mat_type", &type_chosen));
  // -jacobian_mat_type: AIJ (the default), BAIJ (blocks of 6 when every unknown is in a node's
  // block, else 1: BlockPattern) and dense (small models). SBAIJ stores one
  // triangle of a symmetric matrix, and the tangent is not symmetric (follower loads, joints,
  // out of equilibrium); other types cannot be assembled into.
  PetscBool is_aij, is_baij, is_dense;
  MatType   type;
  PetscCall(MatGetType(jacobian_, &type));
  PetscCall(PetscObjectTypeCompareAny((PetscObject)jacobian_, &is_aij, MATSEQAIJ, MATMPIAIJ, ""));
  PetscCall(PetscObjectTypeCompareAny((PetscObject)jacobian_, &is_baij, MATSEQBAIJ, MATMPIBAIJ, ""));
  PetscCall(PetscObjectTypeCompareAny((PetscObject)jacobian_, &is_dense, MATSEQDENSE, MATMPIDENSE, ""));
  PetscBool is_sbaij;
  PetscCall(PetscObjectTypeCompareAny((PetscObject)jacobian_, &is_sbaij, MATSEQSBAIJ, MATMPISBAIJ, ""));
  PetscCheck(is_aij || is_baij || is_dense, comm, PETSC_ERR_USER_INPUT,
             "bad option: -jacobian_mat_type %s is not supported (%s): use aij (the default), baij or dense", type,
             is_sbaij ? "it stores one triangle of a symmetric matrix, and the tangent is not symmetric" : "msflex assembles into aij, baij and dense only");
  // Algebraic multigrid (msflex's, or PETSc's chosen by -pc_type) reads the graph of an AIJ matrix.
  const bool algebraic_multigrid = chosen_pc ? !strcmp(pc_type, PCGAMG) || !strcmp(pc_type, PCML) || !strcmp(pc_type, PCHYPRE) : multigrid;
  PetscCheck(is_aij || !algebraic_multigrid, comm, PETSC_ERR_USER_INPUT,
             "bad option: -jacobian_mat_type %s with %s%s: algebraic multigrid needs aij (the default)", type,
             chosen_pc ? "-pc_type " : "-analysis_linear_solver multigrid", chosen_pc ? pc_type : "");
  PetscCheck(!is_dense || ranks == 1, comm, PETSC_ERR_USER_INPUT,
             "bad option: -jacobian_mat_type dense runs on one rank only (no parallel dense LU): use aij or baij");
  // Banded under RCM (one rank, sparse, the solver chosen by structure): a banded LU factors it
  // (ChooseDirectSolver, core/block_envelope_pc.hpp).
  banded_under_rcm_ = false;
  if (ranks == 1 && !is_dense && analysis.direct_solver == DirectSolverChoice::Auto && !multigrid) {
    double mean_square;
    PetscCall(MeanSquaredRcmEnvelope(pattern, &mean_square));
    banded_under_rcm_ = mean_square <= kBandedEnvelope * kBandedEnvelope;
  }
  // Such a tangent, when every unknown is in a node's block, is stored as BAIJ with blocks of 6
  // unless an option chose the type: PETSc's LU of 6x6 blocks factors a 1000-element chain in 0.45
  // ms against 0.61 (AIJ) and solves in 0.04 against 0.065, msflex's block LU (the default for it)
  // in 0.19 (docs/performance.md). Only where a banded
  // LU factors it (no package, PC or relay row asks for MUMPS), and not where MUMPS factors the
  // tangent for its inertia (statics with stability or path control, modes, buckling:
  // TangentFactor takes AIJ and would convert it at every point).
  const bool baij_if_blocked = is_aij && !type_chosen && banded_under_rcm_ && !chosen_pc && !chosen_package && map.num_relays == 0 && !factored_for_inertia;
  // Blocks of 6 where every unknown belongs to one: a node's 6 unknowns consecutive from a
  // multiple of 6 and coupled as a whole, on every rank (no partly supported node, no joint
  // coordinate); else blocks of 1. BAIJ stores them; an AIJ tangent takes them only for multigrid,
  // which then aggregates whole nodes (their six rigid-body modes): MUMPS compresses by the block
  // size (ICNTL(15)), which changes its pivot order and the direct solver's last bits.
  constexpr PetscInt    kNodeBlock = 6;
  std::vector<PetscInt> block_diagonal, block_off_diagonal;
  PetscBool             blocked = PETSC_FALSE;
  if (is_baij || baij_if_blocked || (is_aij && multigrid)) {
    blocked = BlockPattern(pattern, map.first_owned, kNodeBlock, &block_diagonal, &block_off_diagonal) ? PETSC_TRUE : PETSC_FALSE;
    PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &blocked, 1, MPIU_BOOL, MPI_LAND, comm));
  }
  if (baij_if_blocked && blocked) {
    PetscCall(MatSetType(jacobian_, MATSEQBAIJ));
    is_aij  = PETSC_FALSE;
    is_baij = PETSC_TRUE;
  }
  if (is_aij) {
    if (blocked) PetscCall(MatSetBlockSize(jacobian_, kNodeBlock));
    PetscCall(MatSeqAIJSetPreallocation(jacobian_, 0, pattern.diagonal_nonzeros.data()));
    PetscCall(MatMPIAIJSetPreallocation(jacobian_, 0, pattern.diagonal_nonzeros.data(), 0, pattern.off_diagonal_nonzeros.data()));
    // AIJ: the exact pattern itself, all zeros, in one pass (no element-by-element insertion).
    PetscCall(MatSeqAIJSetPreallocationCSR(jacobian_, pattern.row_start.data(), pattern.columns.data(), nullptr));
    PetscCall(MatMPIAIJSetPreallocationCSR(jacobian_, pattern.row_start.data(), pattern.columns.data(), nullptr));
  } else if (is_baij) {
    node_blocks_ = blocked == PETSC_TRUE;
    if (blocked) {
      PetscCall(MatSetBlockSize(jacobian_, kNodeBlock));
      PetscCall(MatXAIJSetPreallocation(jacobian_, kNodeBlock, block_diagonal.data(), block_off_diagonal.data(), nullptr, nullptr));
    } else PetscCall(MatXAIJSetPreallocation(jacobian_, 1, pattern.diagonal_nonzeros.data(), pattern.off_diagonal_nonzeros.data(), nullptr, nullptr));
    // The exact pattern as zeros, row by row (assembled with the first matrix, CreateCsrDestinations).
    std::vector<double> zeros;
    for (PetscInt r = 0; r + 1 < (PetscInt)pattern.row_start.size(); ++r) {
      const PetscInt row = map.first_owned + r, count = pattern.row_start[r + 1] - pattern.row_start[r];
      zeros.assign((size_t)count, 0.0);
      PetscCall(MatSetValues(jacobian_, 1, &row, count, pattern.columns.data() + pattern.row_start[r], zeros.data(), ADD_VALUES));
    }
  } else {
    PetscCall(MatSetUp(jacobian_));
  }
  pattern = MatrixPattern{};
  PetscCall(MatSetOption(jacobian_, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscCall(MatCreateVecs(jacobian_, &solution_template_, nullptr));
  PetscCall(VecDuplicate(solution_template_, &scratch_residual_));
  PetscCall(VecDuplicate(solution_template_, &last_increments_));
  PetscCall(VecDuplicate(solution_template_, &set_increments_));
  coordinate_residual_.assign(state->joints.size(), std::array<double, kJointMaxReleased>{});
  reaction_slot_.assign(state->nodes.size(), -1);
  reaction_sums_.assign(model.probes.size(), Vec6::Zero());
  for (size_t p = 0; p < model.probes.size(); ++p)
    if (model.probes[p].kind == Probe::Kind::Reaction && model.probes[p].node >= 0) {
      const int l = map.node_to_local[model.probes[p].node];
      if (l >= 0) reaction_slot_[l] = (int)p;
    }
  state->probe_reactions.assign(model.probes.size(), Vec6::Zero());
  PetscCall(AttachRigidBodyModes());
  PetscCall(PetscLogEventBegin(event_csr_destinations, 0, 0, 0, 0));
  PetscCall(CreateCsrDestinations());
  PetscCall(PetscLogEventEnd(event_csr_destinations, 0, 0, 0, 0));

  // Scatter from the distributed unknowns to the free DOFs of every local node (owned and ghost)
  // and the free coordinates of every local joint.
  std::vector<PetscInt> from;
  ghosted_slot_.assign(6 * state->nodes.size(), -1);
  for (size_t l = 0; l < state->nodes.size(); ++l)
    for (int d = 0; d < 6; ++d) {
      const PetscInt global = map.IsRelay((int)l) ? -1 : map.node_dofs[map.local_nodes[l]][d]; // a relay follows its joint
      if (global < 0) continue;
      ghosted_slot_[6 * l + d] = (PetscInt)from.size();
      from.push_back(global);
    }
  expansion_rows_.assign(state->nodes.size(), {});
  expansion_columns_.assign(state->nodes.size(), {});
  slave_residual_.assign(state->nodes.size(), Vec6::Zero());
  relay_force_.assign(state->nodes.size(), Vec6::Zero());
  relay_anchor_.assign(state->nodes.size(), -1);
  relay_joints_.clear();
  relay_rows_ = map.OwnedRelayRows();
  for (PetscInt &row : relay_rows_) row -= map.first_owned;
  prescribed_residual_.assign(state->nodes.size(), Vec6::Zero());
  // Slaves whose chain of masters reaches a reaction probe or a prescribed DOF (masters first).
  passes_to_master_.assign(state->nodes.size(), 0);
  for (const JointState &J : state->joints) {
    if (J.local_master < 0) continue;
    bool receives = reaction_slot_[J.local_master] >= 0 || passes_to_master_[J.local_master];
    for (int d = 0; d < 6; ++d) receives = receives || map.constraints[map.local_nodes[J.local_master]][d].kind == Support::Kind::Prescribed;
    passes_to_master_[J.local_slave] = receives ? 1 : 0;
  }
  joint_slots_.assign(state->joints.size(), {-1, -1, -1, -1, -1, -1});
  size_t max_unknowns = 6;
  for (size_t j = 0; j < state->joints.size(); ++j) {
    const JointState &J = state->joints[j];
    const int         g = J.joint;
    for (int c = 0; c < JointNumCoordinates(J.geometry); ++c) {
      if (map.joint_dofs[g][c] < 0) continue;
      joint_slots_[j][c] = (PetscInt)from.size();
      from.push_back(map.joint_dofs[g][c]);
    }
    const size_t m = map.JointMapUnknowns(model.joints[g].slave).size();
    // The relay a slave's expansion ends on (joints come masters first): its master if that is a
    // relay, or its master's anchor.
    if (map.IsRelay(J.local_slave)) relay_joints_.push_back((int)j);
    if (J.local_master >= 0) relay_anchor_[J.local_slave] = map.IsRelay(J.local_master) ? J.local_master : relay_anchor_[J.local_master];
    expansion_rows_[J.local_slave].assign(6 * m, 0.0);
    expansion_columns_[J.local_slave].assign(6 * m, 0.0);
    max_unknowns = std::max(max_unknowns, m);
  }
  expansion_scratch_.assign(std::max(max_unknowns * max_unknowns, 6 * max_unknowns), 0.0);
  expansion_product_scratch_.assign(6 * std::max<size_t>(max_unknowns, 6), 0.0);
  joint_geometric_scratch_.assign(3 * (6 + kJointMaxReleased) * max_unknowns + max_unknowns * max_unknowns, 0.0);
  // Standard type: a sequential vector on one rank, whose assembly is a no-op (an MPI vector's
  // does a two-sided handshake every step even then). The slots each rank adds into are the same
  // at every step, so the off-process pattern of the first assembly is kept.
  PetscCall(VecCreate(comm, &joint_output_));
  PetscCall(VecSetSizes(joint_output_, kJointOutputStride * (PetscInt)map.num_owned_joints, kJointOutputStride * map.global_count.joints));
  PetscCall(VecSetType(joint_output_, VECSTANDARD));
  PetscCall(VecSetOption(joint_output_, VEC_SUBSET_OFF_PROC_ENTRIES, PETSC_TRUE));
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
  // The centroid of the whole model's nodes (each counted by its owner).
  double sums[4] = {0, 0, 0, (double)map.num_owned_nodes}, global[4];
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l)
    for (int i = 0; i < 3; ++i) sums[i] += model.nodes[map.local_nodes[l]].position(i);
  PetscCall(MPIU_Allreduce(sums, global, 4, MPI_DOUBLE, MPI_SUM, comm_));
  const Vec3 centroid = global[3] > 0 ? Vec3(Vec3(global[0], global[1], global[2]) / global[3]) : Vec3::Zero();
  for (int k = 0; k < 6; ++k) {
    PetscCall(VecDuplicate(solution_template_, &modes[k]));
    PetscCall(VecZeroEntries(modes[k]));
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const int node = map.local_nodes[l];
    if (map.IsRelay((int)l)) continue; // its own unknowns follow its joint
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

// Fixes the pattern with one assembly, then records where each element-matrix entry lands in the
// value arrays of the owned rows: AIJ (block size 1) or BAIJ with node blocks (block size 6, each
// block stored column by column).
PetscErrorCode Assembler::CreateCsrDestinations()
{
  const DofMap &map = *map_;
  PetscBool     is_seq, is_mpi;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompareAny((PetscObject)jacobian_, &is_seq, MATSEQAIJ, node_blocks_ ? MATSEQBAIJ : "", ""));
  PetscCall(PetscObjectTypeCompareAny((PetscObject)jacobian_, &is_mpi, MATMPIAIJ, node_blocks_ ? MATMPIBAIJ : "", ""));
  // AIJ matrices got the pattern from the CSR preallocation, BAIJ as zeros (Setup); dense needs none.
  PetscCall(MatAssemblyBegin(jacobian_, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(jacobian_, MAT_FINAL_ASSEMBLY));
  csr_destinations_.clear();
  csr_destination_offsets_.clear();
  node_csr_destinations_.clear();
  if (!is_seq && !is_mpi) PetscFunctionReturn(PETSC_SUCCESS);

  const PetscInt  bs                       = node_blocks_ ? 6 : 1;
  const PetscInt *off_diagonal_columns     = nullptr; // global (block) column of each off-diagonal block column, ascending
  PetscInt        num_off_diagonal_columns = 0;
  diagonal_block_                          = jacobian_;
  off_diagonal_block_                      = nullptr;
  if (is_mpi) {
    if (node_blocks_) PetscCall(MatMPIBAIJGetSeqBAIJ(jacobian_, &diagonal_block_, &off_diagonal_block_, &off_diagonal_columns));
    else PetscCall(MatMPIAIJGetSeqAIJ(jacobian_, &diagonal_block_, &off_diagonal_block_, &off_diagonal_columns));
    PetscCall(MatGetSize(off_diagonal_block_, nullptr, &num_off_diagonal_columns));
    num_off_diagonal_columns /= bs;
  }
  // Row and column structure of the (block) rows: MatGetRowIJ's fourth argument compresses BAIJ
  // to its blocks, but AIJ to its inodes (rows of equal pattern), which the values do not follow.
  const PetscBool compressed = node_blocks_ ? PETSC_TRUE : PETSC_FALSE;
  const PetscInt *ia, *ja, *ib = nullptr, *jb = nullptr;
  PetscInt        num_rows;
  PetscBool       done;
  PetscCall(MatGetRowIJ(diagonal_block_, 0, PETSC_FALSE, compressed, &num_rows, &ia, &ja, &done));
  PetscCheck(done && num_rows * bs == map.num_owned, PETSC_COMM_SELF, PETSC_ERR_PLIB, "no CSR access to the diagonal block");
  if (off_diagonal_block_) {
    PetscCall(MatGetRowIJ(off_diagonal_block_, 0, PETSC_FALSE, compressed, &num_rows, &ib, &jb, &done));
    PetscCheck(done && num_rows * bs == map.num_owned, PETSC_COMM_SELF, PETSC_ERR_PLIB, "no CSR access to the off-diagonal block");
  }
  // Position of (block) column `column` in (block) row `row`, or -1.
  auto find = [](const PetscInt *row_start, const PetscInt *columns, PetscInt row, PetscInt column) -> PetscInt {
    const PetscInt *begin = columns + row_start[row], *end = columns + row_start[row + 1];
    const PetscInt *it = std::lower_bound(begin, end, column);
    return (it != end && *it == column) ? (PetscInt)(it - columns) : -1;
  };
  const PetscInt first = map.first_owned, last = map.first_owned + map.num_owned;
  // Slot of owned entry (row, column) in the values of the diagonal part (>= 0), of the
  // off-diagonal part (kCsrOffDiagonal - index), or -1 when the pattern lacks it. Entry (r, c) of
  // block b sits at bs^2 b + bs c + r.
  auto slot_of = [&](PetscInt row, PetscInt column) -> PetscInt {
    const PetscInt block_row = (row - first) / bs, within = bs * (column % bs) + (row - first) % bs;
    if (column >= first && column < last) {
      const PetscInt block = find(ia, ja, block_row, (column - first) / bs);
      return block < 0 ? -1 : bs * bs * block + within;
    }
    const PetscInt *it = std::lower_bound(off_diagonal_columns, off_diagonal_columns + num_off_diagonal_columns, column / bs);
    if (it == off_diagonal_columns + num_off_diagonal_columns || *it != column / bs) return -1;
    const PetscInt block = find(ib, jb, block_row, (PetscInt)(it - off_diagonal_columns));
    return block < 0 ? -1 : kCsrOffDiagonal - (bs * bs * block + within);
  };
  // One flat table for all elements, one destination per entry (AIJ) or per node block (BAIJ,
  // where a node's unknowns are all free or all absent and a block row lies on one rank): u^2
  // destinations per element of u = nd / bs units, from csr_destination_offsets_[k].
  csr_destination_offsets_.assign(map.local_elements.size() + 1, 0);
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const size_t units              = 6 * (size_t)(model_->elements[map.local_elements[k]].order + 1) / bs;
    csr_destination_offsets_[k + 1] = csr_destination_offsets_[k] + units * units;
  }
  csr_destinations_.assign(csr_destination_offsets_.back(), kCsrSkip);
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    PetscInt  indices[kBeamMaxDofs];
    const int units       = ElementIndices(model_->elements[map.local_elements[k]], map, indices) / (int)bs;
    PetscInt *destination = csr_destinations_.data() + csr_destination_offsets_[k];
    for (int i = 0; i < units; ++i) {
      const PetscInt row = indices[bs * i];
      if (row < 0) continue;
      if (row < first || row >= last) {
        for (int j = 0; j < units; ++j) destination[i * units + j] = kCsrOtherRank;
        continue;
      }
      for (int j = 0; j < units; ++j) {
        const PetscInt column = indices[bs * j];
        if (column < 0) continue;
        const PetscInt slot = slot_of(row, column);
        PetscCheck(slot != -1, PETSC_COMM_SELF, PETSC_ERR_PLIB, "entry (%" PetscInt_FMT ", %" PetscInt_FMT ") missing from the preallocated pattern", row,
                   column);
        destination[i * units + j] = slot;
      }
    }
  }
  // Owned nodes' own blocks (inertia, nodal loads): rows and columns among the node's unknowns;
  // (6 / bs)^2 destinations per node.
  const PetscInt node_units = 6 / bs;
  node_csr_destinations_.assign(NodeDestinationCount() * (size_t)map.num_owned_nodes, kCsrSkip);
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    PetscInt       *destination = node_csr_destinations_.data() + NodeDestinationCount() * (size_t)l;
    const PetscInt *dofs        = map.node_dofs[map.local_nodes[l]].data();
    bool            direct      = !IsCondensed((int)l);
    for (int i = 0; i < node_units && direct; ++i) {
      if (dofs[bs * i] < 0) continue;
      for (int j = 0; j < node_units && direct; ++j) {
        const PetscInt row = dofs[bs * i], column = dofs[bs * j];
        if (column < 0) continue;
        const PetscInt slot = row >= first && row < last && column >= first && column < last ? slot_of(row, column) : -1;
        if (slot < 0) direct = false;
        destination[node_units * i + j] = slot;
      }
    }
    if (!direct) destination[0] = kCsrOtherRank;
  }
  PetscCall(MatRestoreRowIJ(diagonal_block_, 0, PETSC_FALSE, compressed, &num_rows, &ia, &ja, &done));
  if (off_diagonal_block_) PetscCall(MatRestoreRowIJ(off_diagonal_block_, 0, PETSC_FALSE, compressed, &num_rows, &ib, &jb, &done));
  PetscFunctionReturn(PETSC_SUCCESS);
}

void Assembler::AddToStoredBlock(const double *rows, int row_stride, double *block)
{
  for (int c = 0; c < 6; ++c)
    for (int r = 0; r < 6; ++r) block[6 * c + r] += rows[r * row_stride + c];
}

bool Assembler::NodeBlockIndices(int n, const PetscInt *indices, PetscInt *block_indices) const
{
  if (!node_blocks_) return false;
  for (int b = 0; b < n; ++b) {
    const PetscInt *node = indices + 6 * b;
    if (node[0] < 0) {
      for (int d = 1; d < 6; ++d)
        if (node[d] >= 0) return false;
      block_indices[b] = -1;
      continue;
    }
    if (node[0] % 6 != 0) return false;
    for (int d = 1; d < 6; ++d)
      if (node[d] != node[0] + d) return false;
    block_indices[b] = node[0] / 6;
  }
  return true;
}

// Columns from spins to the nodes' unknowns (d theta_b = H(omega_b) d omega_b; none for
// accelerations), then owned rows straight into the CSR values, rows of other ranks through
// MatSetValues (PETSc's stash); without CSR destinations (non-AIJ matrices) all through MatSetValues.
PetscErrorCode Assembler::AddDirectElementMatrix(Mat target, size_t k, double *K, PetscScalar *diagonal_values, PetscScalar *off_diagonal_values)
{
  const BeamElement &element = model_->elements[map_->local_elements[k]];
  const int          n = element.order + 1, nd = 6 * n;
  PetscInt           indices[kBeamMaxDofs];
  PetscFunctionBeginUser;
  if (!state_->equations.InitialAcceleration())
    for (int b = 0; b < n; ++b) {
      const Mat3 &H = state_->nodes[map_->node_to_local[element.nodes[b]]].rotation_tangent;
      for (int i = 0; i < nd; ++i) {
        double      *row = &K[i * nd + 6 * b + 3];
        const double k0 = row[0], k1 = row[1], k2 = row[2];
        for (int j = 0; j < 3; ++j) row[j] = k0 * H(0, j) + k1 * H(1, j) + k2 * H(2, j);
      }
    }
  ElementIndices(element, *map_, indices);
  if (csr_destinations_.empty()) {
    PetscInt block_indices[kBeamMaxNodes];
    if (NodeBlockIndices(n, indices, block_indices)) PetscCall(MatSetValuesBlocked(target, n, block_indices, n, block_indices, K, ADD_VALUES));
    else PetscCall(MatSetValues(target, nd, indices, nd, indices, K, ADD_VALUES));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const PetscInt *destination = csr_destinations_.data() + csr_destination_offsets_[k];
  if (node_blocks_) {
    // Node block (a, b) of the row-major K into its 6x6 block, stored column by column.
    for (int a = 0; a < n; ++a) {
      const PetscInt *row_destination = destination + a * n;
      const double   *block_rows      = K + 6 * a * nd;
      if (row_destination[0] == kCsrOtherRank) {
        PetscInt block_row = indices[6 * a] / 6, block_columns[kBeamMaxNodes];
        for (int b = 0; b < n; ++b) block_columns[b] = indices[6 * b] < 0 ? -1 : indices[6 * b] / 6;
        PetscCall(MatSetValuesBlocked(target, 1, &block_row, n, block_columns, block_rows, ADD_VALUES));
        continue;
      }
      for (int b = 0; b < n; ++b) {
        const PetscInt slot = row_destination[b];
        if (slot == kCsrSkip) continue;
        AddToStoredBlock(block_rows + 6 * b, nd, slot >= 0 ? diagonal_values + slot : off_diagonal_values + (kCsrOffDiagonal - slot));
      }
    }
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  for (int i = 0; i < nd; ++i) {
    const PetscInt *row_destination = destination + i * nd;
    const double   *row_values      = K + i * nd;
    if (row_destination[0] == kCsrOtherRank) {
      PetscCall(MatSetValues(target, 1, &indices[i], nd, indices, row_values, ADD_VALUES));
      continue;
    }
    for (int j = 0; j < nd; ++j) {
      const PetscInt slot = row_destination[j];
      if (slot >= 0) diagonal_values[slot] += row_values[j];
      else if (slot <= kCsrOffDiagonal) off_diagonal_values[kCsrOffDiagonal - slot] += row_values[j];
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

void Assembler::DiscardStep()
{
  StateDiscardStep(*model_, state_);
  ForgetIncrements();
}

void Assembler::SetRoundoffReach(double reach)
{
  if (reach == reach_) return;
  reach_ = reach;
  roundoff_force_level_ =
      std::numeric_limits<double>::epsilon() * std::sqrt(1e4 * stiffness_roundoff_squares_ + reach * reach * position_roundoff_squares_per_reach_);
  global_inertia_roundoff_squares_ = inertia_roundoff_squares_per_reach_ * reach * reach + inertia_roundoff_squares_fixed_;
  joint_lever_arm_                 = has_joints_ ? reach : 0.0;
}

PetscErrorCode Assembler::BeginStep(const StepEquations &equations)
{
  PetscFunctionBeginUser;
  StateBeginStep(*model_, *map_, equations, state_);
  {
    // The reach of the configuration the step starts from, where it exceeds the reference's.
    double local_reach = 0.0, reach;
    for (const NodeState &s : state_->nodes) local_reach = std::max(local_reach, s.position.cwiseAbs().maxCoeff());
    PetscCall(MPIU_Allreduce(&local_reach, &reach, 1, MPI_DOUBLE, MPI_MAX, comm_));
    SetRoundoffReach(std::max(setup_reach_, reach));
  }
  ForgetIncrements();
  UpdateExpansions();
  for (ForceContributor *c : contributors_) c->BeginStep(*state_);
  inertial_roundoff_level_ = 0.0;
  damping_roundoff_level_  = 0.0;
  stagnation_level_        = 0.0;
  if (equations.Dynamic()) {
    double squares = inertia_->LocalMomentumRateSquares(*state_, equations.scheme.dt);
    PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &squares, 1, MPI_DOUBLE, MPI_SUM, comm_));
    inertial_roundoff_level_ = 100.0 * std::numeric_limits<double>::epsilon() * std::sqrt(squares);
    // The inertia times the configuration's rounding, eps c sqrt(sum (m R)^2 + |J|^2) with c the
    // scheme's inertia coefficient, which the momenta miss at rest or at a turning point: a bound
    // of the residual's noise there, ten times over (StagnationLevel).
    // With joints, a moment of that rounding about a master, whose lever arm reaches as far as the
    // model does (a chain of 6000 rigid bodies, 6000 m long: a floor of 11 N m at its root, which
    // the forces alone put at 4e-3).
    stagnation_level_ = 10.0 * std::numeric_limits<double>::epsilon() * equations.scheme.InertiaCoefficient() * std::sqrt(global_inertia_roundoff_squares_) *
                        (1.0 + joint_lever_arm_);
    // Damping forces C_d times strain rates, which are the strains' increments (rounded as the
    // strains are) times a rate coefficient: eps times 100 C_d times it, as the stiffness's floor
    // is eps times 100 K (structural damping of tau = 0.01 s at dt = 1 ms raised the floor
    // 20-fold, and Newton, asked for less, stalled in the first step). The mid-point schemes'
    // damping takes (e_{n+1} - e_n) / dt, the Newmark family's the velocity of the update.
    const double rate_coefficient = equations.scheme.Midpoint() ? 1.0 / equations.scheme.dt : std::abs(equations.scheme.VelocityCoefficient());
    damping_roundoff_level_       = 100.0 * std::numeric_limits<double>::epsilon() * std::sqrt(global_damping_squares_) * rate_coefficient;
  }
  massless_rows_.clear();
  num_massless_unknowns_ = 0;
  if (equations.InitialAcceleration()) PetscCall(FindMasslessUnknowns());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::EmptyRowsOfJacobian(std::vector<PetscInt> *rows) const
{
  Vec       row_max;
  PetscReal largest;
  PetscInt  first;
  PetscFunctionBeginUser;
  rows->clear();
  PetscCall(VecDuplicate(solution_template_, &row_max));
  PetscCall(MatGetRowMaxAbs(jacobian_, row_max, nullptr));
  PetscCall(VecMax(row_max, nullptr, &largest));
  PetscCall(VecGetOwnershipRange(row_max, &first, nullptr));
  const PetscScalar *values;
  PetscCall(VecGetArrayRead(row_max, &values));
  for (PetscInt i = 0; i < map_->num_owned; ++i)
    if (!(PetscAbsScalar(values[i]) > 1e-14 * largest)) rows->push_back(first + i);
  PetscCall(VecRestoreArrayRead(row_max, &values));
  PetscCall(VecDestroy(&row_max));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::FindMasslessUnknowns()
{
  PetscBool ok;
  PetscInt  count = 0;
  PetscFunctionBeginUser;
  // The mass matrix is the tangent of the initial-acceleration problem (the accelerations enter
  // linearly, so it does not depend on them). A zero row is an unknown no mass reaches; the mass
  // matrix is symmetric, so its column is zero too and the other equations do not see it.
  // Without the relays' coupling, whose rows are never empty; a row reached only below a relay
  // then counts as reached (DropRelayReachedRows, as in the velocity projection).
  skip_relay_coupling_      = true;
  const PetscErrorCode code = AssembleJacobian(jacobian_, &ok);
  skip_relay_coupling_      = false;
  PetscCall(code);
  PetscCall(EmptyRowsOfJacobian(&massless_rows_));
  if (map_->num_relays > 0) PetscCall(DropRelayReachedRows(&massless_rows_));
  const PetscInt local = (PetscInt)massless_rows_.size();
  PetscCallMPI(MPIU_Allreduce(&local, &count, 1, MPIU_INT, MPI_SUM, comm_));
  num_massless_unknowns_ = count;
  (void)ok;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::MasslessImbalance(double *ratio)
{
  Vec       zero, forces;
  PetscBool ok;
  PetscFunctionBeginUser;
  *ratio = 0.0;
  PetscCheck(state_->equations.InitialAcceleration(), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONGSTATE,
             "MasslessImbalance: begin the initial-acceleration problem first");
  // The residual at zero accelerations with no row replaced: on a row without mass no inertia
  // enters (the accelerations are zero, the velocity terms carry mass), so it holds the force out
  // of balance there.
  PetscCall(VecDuplicate(solution_template_, &zero));
  PetscCall(VecDuplicate(solution_template_, &forces));
  PetscCall(VecZeroEntries(zero));
  PetscCall(SetIncrements(zero));
  mass_matrix_only_         = true;
  const PetscErrorCode code = AssembleResidual(forces, &ok, false);
  mass_matrix_only_         = false;
  // What that assembly left (slave forces, reactions) is not the problem's: made again when asked
  // for (accelerations exactly zero would not change the increments' version).
  by_products_version_ = -1;
  PetscCall(code);
  const PetscScalar *f;
  double             sums[2] = {0.0, 0.0}, global[2]; // rows without mass, all rows
  PetscCall(VecGetArrayRead(forces, &f));
  for (PetscInt i = 0; i < map_->num_owned; ++i) sums[1] += std::pow(PetscRealPart(f[i]), 2);
  for (PetscInt row : massless_rows_) sums[0] += std::pow(PetscRealPart(f[row - map_->first_owned]), 2);
  for (PetscInt l = 0; l < map_->num_owned_nodes; ++l) {
    if (IsSlave((int)l)) continue; // its rows are its joint's (massless_rows_)
    const NodeMassGroups &groups = inertia_->Groups((int)l);
    for (int d = 0; d < 6; ++d) {
      const PetscInt row = map_->node_dofs[map_->local_nodes[l]][d];
      if (row < 0 || (d < 3 ? groups.translational : groups.rotary)) continue;
      sums[0] += std::pow(PetscRealPart(f[row - map_->first_owned]), 2);
    }
  }
  PetscCall(VecRestoreArrayRead(forces, &f));
  PetscCallMPI(MPIU_Allreduce(sums, global, 2, MPI_DOUBLE, MPI_SUM, comm_));
  *ratio = global[1] > 0 ? std::sqrt(global[0] / global[1]) : 0.0;
  PetscCall(VecDestroy(&zero));
  PetscCall(VecDestroy(&forces));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::SetMasslessResidualRows(Vec residual)
{
  PetscScalar       *r;
  const PetscScalar *x;
  PetscFunctionBeginUser;
  if (massless_rows_.empty()) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArray(residual, &r));
  PetscCall(VecGetArrayRead(last_increments_, &x));
  for (PetscInt row : massless_rows_) r[row - map_->first_owned] = x[row - map_->first_owned];
  PetscCall(VecRestoreArrayRead(last_increments_, &x));
  PetscCall(VecRestoreArray(residual, &r));
  PetscFunctionReturn(PETSC_SUCCESS);
}

void Assembler::AddCoordinate(int joint, int coordinate, double residual, double tangent)
{
  const PetscInt row  = map_->joint_dofs[state_->joints[joint].joint][coordinate];
  PetscErrorCode code = PETSC_SUCCESS;
  if (block_residual_) {
    coordinate_residual_[joint][coordinate] += residual;
    if (row >= 0) {
      local_force_squares_ += residual * residual;
      code = VecSetValue(block_residual_, row, residual, ADD_VALUES);
    }
  }
  if (block_jacobian_ && row >= 0 && code == PETSC_SUCCESS) code = MatSetValue(block_jacobian_, row, row, tangent, ADD_VALUES);
  if (code != PETSC_SUCCESS) block_trouble_ = true;
}

PetscErrorCode Assembler::StepDissipation(double *dissipation)
{
  double local = 0.0;
  PetscFunctionBeginUser;
  for (const ForceContributor *c : contributors_) c->AddStepDissipation(*state_, &local);
  PetscCall(MPIU_Allreduce(&local, dissipation, 1, MPI_DOUBLE, MPI_SUM, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::EvaluateSupportReactions()
{
  PetscBool evaluable;
  PetscFunctionBeginUser;
  for (Vec6 &sum : reaction_sums_) sum.setZero();
  collect_reactions_ = true;
  PetscCall(AssembleResidual(scratch_residual_, &evaluable));
  collect_reactions_ = false;
  // Every rank holding a probe's node added its share of the supported directions (a free one's
  // residual is the out-of-balance, not a reaction); the sums of all ranks are the reaction. The
  // directions are taken where the node is held (node >= 0): on a rank without it, rank 0 that
  // writes the history among them, the node is not in the restricted model.
  std::vector<double> local(6 * reaction_sums_.size(), 0.0), global(6 * reaction_sums_.size());
  for (size_t p = 0; p < reaction_sums_.size(); ++p) {
    const int node = model_->probes[p].node;
    if (model_->probes[p].kind != Probe::Kind::Reaction || node < 0) continue;
    for (int d = 0; d < 6; ++d)
      if (map_->constraints[node][d].kind != Support::Kind::Free) local[6 * p + d] = reaction_sums_[p](d);
  }
  PetscCall(MPIU_Allreduce(local.data(), global.data(), (PetscMPIInt)local.size(), MPI_DOUBLE, MPI_SUM, comm_));
  for (size_t p = 0; p < reaction_sums_.size(); ++p) state_->probe_reactions[p] = Eigen::Map<const Vec6>(&global[6 * p]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::PredictIncrements(Vec increments)
{
  PetscFunctionBeginUser;
  PetscCall(VecZeroEntries(increments));
  if (!state_->equations.Dynamic()) PetscFunctionReturn(PETSC_SUCCESS);
  const DofMap &map = *map_;
  const double  dt  = state_->equations.scheme.dt;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (map.IsRelay((int)l)) continue; // follows its joint
    const NodeState &s = state_->nodes[l];
    Vec6             guess;
    guess.head<3>() = dt * s.translation_motion.velocity;
    guess.tail<3>() = dt * (QuaternionToMatrix(s.rotation_start) * s.rotation_motion.velocity);
    for (int d = 0; d < 6; ++d) {
      const PetscInt row = map.node_dofs[map.local_nodes[l]][d];
      if (row >= 0) PetscCall(VecSetValue(increments, row, guess(d), INSERT_VALUES));
    }
  }
  // A released coordinate moves on at its rate too (a free screw or hinge turning at speed starts
  // near its end-of-step position, not at the start: the turning arm's em steps took 7 Newton
  // iterations from zero increments). Set on the rank owning the coordinate's unknown.
  PetscInt first, last;
  PetscCall(VecGetOwnershipRange(increments, &first, &last));
  for (const JointState &J : state_->joints)
    for (int c = 0; c < kJointMaxReleased; ++c) {
      const PetscInt row = map.joint_dofs[J.joint][c];
      if (row >= first && row < last) PetscCall(VecSetValue(increments, row, dt * J.CoordinateRate(c), INSERT_VALUES));
    }
  PetscCall(VecAssemblyBegin(increments));
  PetscCall(VecAssemblyEnd(increments));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::SetIncrements(Vec increments, bool keep_if_current)
{
  const PetscScalar *values;
  PetscFunctionBeginUser;
  if (state_->equations.InitialAcceleration() && increments != last_increments_) PetscCall(VecCopy(increments, last_increments_));
  // A new version of the unknowns unless they equal the last ones set (SNES assembles the tangent
  // at the iterate whose residual it has just evaluated: em's beta of that residual is then exact
  // for the tangent, AssembleJacobian).
  PetscBool same = PETSC_FALSE;
  if (increments_known_) PetscCall(VecEqual(increments, set_increments_, &same));
  if (!same) {
    ++increments_version_;
    PetscCall(VecCopy(increments, set_increments_));
    increments_known_ = true;
  } else if (keep_if_current) {
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecScatterBegin(to_ghosted_, increments, ghosted_increments_, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(to_ghosted_, increments, ghosted_increments_, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(ghosted_increments_, &values));
  for (size_t l = 0; l < state_->nodes.size(); ++l) {
    NodeState &s = state_->nodes[l];
    for (int d = 0; d < 6; ++d) {
      const PetscInt slot = ghosted_slot_[6 * l + d];
      if (slot < 0) continue;
      if (d < 3) s.displacement_increment(d) = PetscRealPart(values[slot]);
      else s.rotation_increment(d - 3) = PetscRealPart(values[slot]);
    }
    StateUpdateNode(state_->equations, &s);
  }
  for (size_t j = 0; j < state_->joints.size(); ++j)
    for (int c = 0; c < kJointMaxReleased; ++c)
      if (joint_slots_[j][c] >= 0) state_->joints[j].increment[c] = PetscRealPart(values[joint_slots_[j][c]]);
  PetscCall(VecRestoreArrayRead(ghosted_increments_, &values));
  StateUpdateSlaves(*model_, state_);
  UpdateExpansions();
  PetscFunctionReturn(PETSC_SUCCESS);
}

void Assembler::EvaluateElement(size_t k, bool want_tangent, ElementContribution *out, const double *combined_beta, bool keep_iterate, bool beams_only)
{
  const StepEquations &eq = state_->equations;
  // em with beta = 0 known (the round-off rule): no energy terms, the tangent is K_mc.
  const bool energy_terms = eq.Dynamic() && eq.scheme.kind == TimeSchemeKind::EnergyMomentum && !(combined_beta && *combined_beta == 0.0);
  out->Clear(model_->elements[map_->local_elements[k]].order + 1, want_tangent, energy_terms, combined_beta);
  out->iterate_key = keep_iterate ? increments_version_ : -1;
  for (ForceContributor *c : element_contributors_) {
    if (beams_only && c != static_cast<const ForceContributor *>(beams_)) continue;
    c->AddElement(*state_, k, out);
    if (!out->evaluable) return;
  }
  if (state_->equations.InitialAcceleration() && !mass_matrix_only_) inertia_->DropMasslessElementRows(*state_, k, out);
}

void Assembler::EvaluateNode(int l, bool want_tangent, NodeContribution *out)
{
  out->Clear(want_tangent);
  for (ForceContributor *c : node_contributors_) c->AddNode(*state_, l, out);
  if (state_->equations.InitialAcceleration() && !mass_matrix_only_) inertia_->SetMasslessNodeEquations(*state_, l, out);
}

void Assembler::Add(const NodeBlock &block, const double *residual, const double *tangent)
{
  PetscErrorCode code = PETSC_SUCCESS;
  // The initial-acceleration problem's equation of a group without mass is "acceleration = 0"
  // (InertiaContributor::SetMasslessNodeEquations): a block's forces there are dropped, as an
  // element's are (a spring on a massless node gave it the acceleration of its force on a unit mass).
  const bool drop_massless = inertia_ && state_->equations.InitialAcceleration() && !mass_matrix_only_;
  for (int a = 0; a < block.num_nodes && code == PETSC_SUCCESS; ++a) {
    const int l = block.nodes[a];
    double    kept[6];
    std::copy(residual + 6 * a, residual + 6 * a + 6, kept);
    if (drop_massless) DropMasslessRows(1, &inertia_->Groups(l), kept);
    if (block_residual_) code = AddNodeResidual(block_residual_, l, kept);
    else if (IsSlave(l)) slave_residual_[l] += Eigen::Map<const Vec6>(kept);
  }
  if (code == PETSC_SUCCESS && block_jacobian_ && tangent) {
    if (block.num_nodes == 1) code = AddNodeBlock(block_jacobian_, block.nodes[0], Eigen::Map<const Mat6>(tangent));
    else code = AddExpandedMatrix(block_jacobian_, block.num_nodes, block.nodes, tangent);
  }
  if (code != PETSC_SUCCESS) block_trouble_ = true;
}

PetscErrorCode Assembler::StartResidual(Vec residual)
{
  PetscFunctionBeginUser;
  // Constrained DOFs have index -1; Vecs (unlike Mats) must be told to skip them.
  PetscCall(VecSetOption(residual, VEC_IGNORE_NEGATIVE_INDICES, PETSC_TRUE));
  PetscCall(VecZeroEntries(residual));
  local_force_squares_ = 0.0;
  for (Vec6 &reaction : prescribed_residual_) reaction.setZero();
  for (Vec6 &g : relay_force_) g.setZero();
  for (auto &row : coordinate_residual_) row.fill(0.0);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AddContributorBlocks(Vec residual, Mat jacobian)
{
  PetscFunctionBeginUser;
  block_residual_ = residual;
  block_jacobian_ = jacobian;
  block_trouble_  = false;
  for (ForceContributor *c : contributors_) c->AddBlocks(*state_, jacobian != nullptr, this);
  block_residual_ = nullptr;
  block_jacobian_ = nullptr;
  PetscCheck(!block_trouble_, PETSC_COMM_SELF, PETSC_ERR_PLIB, "a contributor's block could not be added to the %s", jacobian ? "tangent" : "residual");
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::FinishResidual(Vec residual, double strain_energy, PetscBool geometry_ok)
{
  PetscFunctionBeginUser;
  PetscCall(FinishRelayForces(residual));
  PetscCall(VecAssemblyBegin(residual));
  PetscCall(VecAssemblyEnd(residual));
  residual_strain_energy_         = strain_energy;
  residual_strain_energy_version_ = geometry_ok ? increments_version_ : -1;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AssembleResidual(Vec residual, PetscBool *geometry_ok, bool tangent_may_follow)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_residual, 0, 0, 0, 0));
  const DofMap &map = *map_;
  *geometry_ok      = PETSC_TRUE;
  PetscCall(StartResidual(residual));
  // Pass 1: element vectors (and, for em, the pieces of beta; the strain energy, kept for the history).
  double              sums[3]       = {0.0, 0.0, 0.0}; // work mismatch, correction work, scale of the internal work
  double              strain_energy = 0.0;
  ElementContribution element;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    EvaluateElement(k, false, &element, nullptr, tangent_may_follow);
    const int nd = 6 * element.num_nodes;
    if (!element.evaluable) {
      *geometry_ok = PETSC_FALSE;
      std::fill(element.residual, element.residual + nd, 0.0);
      std::fill(element.correction, element.correction + nd, 0.0);
    }
    std::copy(element.residual, element.residual + nd, &element_force_scratch_[kBeamMaxDofs * k]);
    std::copy(element.correction, element.correction + nd, &element_correction_scratch_[kBeamMaxDofs * k]);
    sums[0] += element.work_mismatch;
    sums[1] += element.correction_work;
    sums[2] += element.work_scale;
    strain_energy += element.strain_energy;
  }
  // em (eq. 20): beta makes the work of the internal forces equal the change of strain energy
  // (BetaOfWorkSums: 0 when either work is at round-off).
  energy_correction_ = 0.0;
  if (state_->equations.Dynamic() && state_->equations.scheme.kind == TimeSchemeKind::EnergyMomentum) {
    double global[3];
    PetscCall(MPIU_Allreduce(sums, global, 3, MPI_DOUBLE, MPI_SUM, comm_));
    AdoptEnergyCorrection(global);
  }
  // Pass 2: assemble. The residual left on prescribed DOFs is the reaction that drives them; its
  // work over the increments counts as external work.
  for (Vec6 &g : slave_residual_) g.setZero();
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element_nodes = model_->elements[map.local_elements[k]];
    double            *f             = &element_force_scratch_[kBeamMaxDofs * k];
    if (energy_correction_ != 0.0)
      for (int i = 0; i < 6 * (element_nodes.order + 1); ++i) f[i] += energy_correction_ * element_correction_scratch_[kBeamMaxDofs * k + i];
    for (int a = 0; a <= element_nodes.order; ++a) PetscCall(AddNodeResidual(residual, map.node_to_local[element_nodes.nodes[a]], &f[6 * a]));
  }
  NodeContribution node;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    EvaluateNode((int)l, false, &node);
    PetscCall(AddNodeResidual(residual, (int)l, node.residual));
  }
  PetscCall(AddContributorBlocks(residual, nullptr));
  PetscCall(FinishResidual(residual, strain_energy, *geometry_ok));
  if (state_->equations.InitialAcceleration() && !mass_matrix_only_) PetscCall(SetMasslessResidualRows(residual));
  by_products_version_    = increments_version_;
  by_products_propagated_ = false;
  PetscCall(PetscLogEventEnd(event_residual, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::SetupEnergyCorrectionTangent(bool with_matrix)
{
  PetscFunctionBeginUser;
  if (with_matrix && !correction_jacobian_) PetscCall(MatDuplicate(jacobian_, MAT_DO_NOT_COPY_VALUES, &correction_jacobian_));
  if (rank_one_left_) PetscFunctionReturn(PETSC_SUCCESS);
  for (Vec *v : {&rank_one_left_, &rank_one_right_, &beta_gradient_correction_}) {
    PetscCall(VecDuplicate(solution_template_, v));
    PetscCall(VecSetOption(*v, VEC_IGNORE_NEGATIVE_INDICES, PETSC_TRUE));
  }
  slave_correction_residual_.assign(state_->nodes.size(), Vec6::Zero());
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The value arrays of a matrix's owned rows (diagonal and off-diagonal parts), AIJ or BAIJ, for
// the direct element path; null when the matrix type has none.
static PetscErrorCode GetCsrValues(Mat matrix, bool have_destinations, Mat *diagonal, Mat *off_diagonal, PetscScalar **diagonal_values,
                                   PetscScalar **off_diagonal_values)
{
  PetscBool is_mpi_aij, is_mpi_baij, is_baij;
  PetscFunctionBeginUser;
  *diagonal_values = *off_diagonal_values = nullptr;
  *diagonal = matrix, *off_diagonal = nullptr;
  if (!have_destinations) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscObjectTypeCompare((PetscObject)matrix, MATMPIAIJ, &is_mpi_aij));
  PetscCall(PetscObjectTypeCompare((PetscObject)matrix, MATMPIBAIJ, &is_mpi_baij));
  if (is_mpi_aij) PetscCall(MatMPIAIJGetSeqAIJ(matrix, diagonal, off_diagonal, nullptr));
  if (is_mpi_baij) PetscCall(MatMPIBAIJGetSeqBAIJ(matrix, diagonal, off_diagonal, nullptr));
  PetscCall(PetscObjectTypeCompare((PetscObject)*diagonal, MATSEQBAIJ, &is_baij));
  for (auto [part, values] : {std::pair{*diagonal, diagonal_values}, std::pair{*off_diagonal, off_diagonal_values}}) {
    if (!part) continue;
    if (is_baij) PetscCall(MatSeqBAIJGetArray(part, values));
    else PetscCall(MatSeqAIJGetArray(part, values));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode RestoreCsrValues(Mat diagonal, Mat off_diagonal, PetscScalar **diagonal_values, PetscScalar **off_diagonal_values)
{
  PetscBool is_baij;
  PetscFunctionBeginUser;
  if (!*diagonal_values) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscObjectTypeCompare((PetscObject)diagonal, MATSEQBAIJ, &is_baij));
  for (auto [part, values] : {std::pair{diagonal, diagonal_values}, std::pair{off_diagonal, off_diagonal_values}}) {
    if (!*values) continue;
    if (is_baij) PetscCall(MatSeqBAIJRestoreArray(part, values));
    else PetscCall(MatSeqAIJRestoreArray(part, values));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AssembleJacobian(Mat jacobian, PetscBool *geometry_ok)
{
  PetscFunctionBeginUser;
  PetscCall(AssembleTangentPass(jacobian, nullptr, geometry_ok));
  PetscFunctionReturn(PETSC_SUCCESS);
}

bool Assembler::CanAssembleResidualWithJacobian() const { return !state_->equations.InitialAcceleration() && !mass_matrix_only_; }

PetscErrorCode Assembler::AssembleResidualWithJacobian(Vec residual, PetscBool *geometry_ok)
{
  PetscFunctionBeginUser;
  PetscCheck(CanAssembleResidualWithJacobian(), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONGSTATE,
             "the residual and the tangent are assembled together only outside the initial-acceleration problem");
  const StepEquations &eq = state_->equations;
  if (eq.Dynamic() && eq.scheme.kind == TimeSchemeKind::EnergyMomentum) {
    PetscBool all_ok;
    PetscCall(EnergyCorrectionOfElements(&all_ok));
    // An element that cannot be evaluated: the residual alone, as AssembleResidual reports it
    // (the line search shortens the step; no tangent is asked for there).
    if (!all_ok) {
      PetscCall(AssembleResidual(residual, geometry_ok, false));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
  }
  PetscCall(AssembleTangentPass(jacobian_, residual, geometry_ok));
  PetscFunctionReturn(PETSC_SUCCESS);
}

void Assembler::AdoptEnergyCorrection(const double global_sums[3])
{
  energy_correction_         = BetaOfWorkSums(global_sums);
  energy_correction_work_    = global_sums[1];
  energy_correction_version_ = increments_version_;
}

PetscErrorCode Assembler::EnergyCorrectionOfElements(PetscBool *all_ok)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_energy_correction, 0, 0, 0, 0));
  // work mismatch, correction work, scale of the internal work (as AssembleResidual sums them), and
  // the count of elements that could not be evaluated
  double              sums[4] = {0.0, 0.0, 0.0, 0.0}, global[4];
  ElementContribution element;
  for (size_t k = 0; k < map_->local_elements.size(); ++k) {
    // The beams alone: no other element contributor adds to beta's sums, and every element's
    // residual is assembled in the tangent's visit.
    EvaluateElement(k, false, &element, nullptr, true, true);
    if (!element.evaluable) {
      sums[3] += 1.0;
      break;
    }
    sums[0] += element.work_mismatch;
    sums[1] += element.correction_work;
    sums[2] += element.work_scale;
  }
  PetscCall(MPIU_Allreduce(sums, global, 4, MPI_DOUBLE, MPI_SUM, comm_));
  *all_ok = global[3] == 0.0 ? PETSC_TRUE : PETSC_FALSE;
  if (*all_ok) AdoptEnergyCorrection(global);
  PetscCall(PetscLogEventEnd(event_energy_correction, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// One pass over elements, nodes and blocks for the tangent and, when `residual` is given (not the
// initial-acceleration problem: CanAssembleResidualWithJacobian; in em after
// EnergyCorrectionOfElements gave beta at these unknowns), the residual too, from the same kernel
// calls: every residual entry is added in the order AssembleResidual adds it.
PetscErrorCode Assembler::AssembleTangentPass(Mat jacobian, Vec residual, PetscBool *geometry_ok)
{
  PetscFunctionBeginUser;
  ++matrix_assemblies_;
  PetscCheck(jacobian == jacobian_, PETSC_COMM_SELF, PETSC_ERR_SUP, "the assembler assembles into its own matrix only");
  PetscCall(PetscLogEventBegin(event_jacobian, 0, 0, 0, 0));
  const DofMap        &map = *map_;
  const StepEquations &eq  = state_->equations;
  const bool           em  = eq.Dynamic() && eq.scheme.kind == TimeSchemeKind::EnergyMomentum;
  *geometry_ok             = PETSC_TRUE;
  tangent_version_         = -1;
  by_products_version_     = -1; // slave_residual_ is rebuilt
  double strain_energy     = 0.0;
  if (residual) {
    PetscCall(StartResidual(residual));
    if (!em) energy_correction_ = 0.0; // em: beta of these unknowns (EnergyCorrectionOfElements)
  }
  // em: when the last residual was assembled at these unknowns (SNES's order: residual, then the
  // tangent at the same iterate), its beta and correction work hold here: the beam kernel builds
  // K_mc + beta K_corr at once, and b = (grad M - beta grad C) / C goes into one vector.
  // Otherwise beta comes from this pass's sums: K_corr goes into a matrix of its own, added once
  // beta is known, and grad C into a vector of its own.
  const bool   fused               = em && energy_correction_version_ == increments_version_;
  const bool   separate_correction = em && !fused;
  const double fused_beta          = fused ? energy_correction_ : 0.0;
  const double fused_scale         = fused && fused_beta != 0.0 ? 1.0 / energy_correction_work_ : 0.0;
  if (em) PetscCall(SetupEnergyCorrectionTangent(separate_correction));
  PetscCall(MatZeroEntries(jacobian));
  if (em) {
    if (separate_correction) PetscCall(MatZeroEntries(correction_jacobian_));
    for (Vec v : {rank_one_left_, rank_one_right_, beta_gradient_correction_}) PetscCall(VecZeroEntries(v));
    for (Vec6 &g : slave_correction_residual_) g.setZero();
  }
  const bool   direct = !csr_destinations_.empty();
  Mat          diagonal, off_diagonal, correction_diagonal = nullptr, correction_off_diagonal = nullptr;
  PetscScalar *diagonal_values, *off_diagonal_values, *correction_diagonal_values = nullptr, *correction_off_diagonal_values = nullptr;
  PetscCall(GetCsrValues(jacobian, direct, &diagonal, &off_diagonal, &diagonal_values, &off_diagonal_values));
  if (separate_correction)
    PetscCall(GetCsrValues(correction_jacobian_, direct, &correction_diagonal, &correction_off_diagonal, &correction_diagonal_values,
                           &correction_off_diagonal_values));
  for (Vec6 &g : slave_residual_) g.setZero();
  // One element loop: an element touching slave nodes goes through the expansions (its residual
  // gathered on the slaves for the joints' geometric stiffness), any other straight into the CSR
  // values of the owned rows (both are in place in the matrix's value arrays). em: the correction
  // vector (rows) and beta's gradients (columns) into vectors.
  ElementContribution element;
  double              sums[3] = {0.0, 0.0, 0.0}; // work mismatch, correction work, scale of the internal work
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    EvaluateElement(k, true, &element, fused ? &fused_beta : nullptr);
    if (!element.evaluable) {
      *geometry_ok = PETSC_FALSE;
      continue;
    }
    const BeamElement &element_nodes = model_->elements[map.local_elements[k]];
    const int          nd            = 6 * (element_nodes.order + 1);
    int                local_nodes[kBeamMaxNodes];
    for (int a = 0; a <= element_nodes.order; ++a) local_nodes[a] = map.node_to_local[element_nodes.nodes[a]];
    if (residual) {
      strain_energy += element.strain_energy;
      // em: R = R_mc + beta R_corr, element by element as AssembleResidual adds it
      if (fused && fused_beta != 0.0)
        for (int i = 0; i < nd; ++i) element.residual[i] += fused_beta * element.correction[i];
      for (int a = 0; a <= element_nodes.order; ++a) PetscCall(AddNodeResidual(residual, local_nodes[a], &element.residual[6 * a])); // slaves' too
    }
    if (separate_correction) {
      sums[0] += element.work_mismatch, sums[1] += element.correction_work, sums[2] += element.work_scale;
      for (int a = 0; a <= element_nodes.order; ++a) {
        PetscCall(AddNodeVector(rank_one_left_, local_nodes[a], &element.correction[6 * a], Through::Rows));
        PetscCall(AddNodeVector(rank_one_right_, local_nodes[a], &element.mismatch_gradient[6 * a], Through::Columns));
        PetscCall(AddNodeVector(beta_gradient_correction_, local_nodes[a], &element.correction_work_gradient[6 * a], Through::Columns));
      }
    } else if (fused && fused_beta != 0.0) {
      double gradient[kBeamMaxDofs];
      for (int i = 0; i < nd; ++i) gradient[i] = fused_scale * (element.mismatch_gradient[i] - fused_beta * element.correction_work_gradient[i]);
      for (int a = 0; a <= element_nodes.order; ++a) {
        PetscCall(AddNodeVector(rank_one_left_, local_nodes[a], &element.correction[6 * a], Through::Rows));
        PetscCall(AddNodeVector(rank_one_right_, local_nodes[a], &gradient[6 * a], Through::Columns));
      }
    }
    if (!element_has_slave_[k]) {
      PetscCall(AddDirectElementMatrix(jacobian, k, element.tangent, diagonal_values, off_diagonal_values));
      if (separate_correction)
        PetscCall(AddDirectElementMatrix(correction_jacobian_, k, element.tangent_correction, correction_diagonal_values, correction_off_diagonal_values));
      continue;
    }
    for (int a = 0; a <= element_nodes.order; ++a) {
      if (!IsSlave(local_nodes[a])) continue;
      if (residual) continue; // AddNodeResidual above gathered R, beta R_corr included
      slave_residual_[local_nodes[a]] += Eigen::Map<const Vec6>(&element.residual[6 * a]);
      if (em) slave_correction_residual_[local_nodes[a]] += Eigen::Map<const Vec6>(&element.correction[6 * a]);
    }
    PetscCall(AddExpandedMatrix(jacobian, element_nodes.order + 1, local_nodes, element.tangent));
    if (separate_correction) PetscCall(AddExpandedMatrix(correction_jacobian_, element_nodes.order + 1, local_nodes, element.tangent_correction));
  }
  if (separate_correction)
    PetscCall(RestoreCsrValues(correction_diagonal, correction_off_diagonal, &correction_diagonal_values, &correction_off_diagonal_values));
  NodeContribution node;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    EvaluateNode((int)l, true, &node);
    if (residual) PetscCall(AddNodeResidual(residual, (int)l, node.residual));
    else if (IsSlave((int)l)) slave_residual_[l] += Eigen::Map<const Vec6>(node.residual);
    if (!node.tangent.isZero(0.0)) PetscCall(AddDirectNodeBlock(jacobian, (int)l, node.tangent, diagonal_values));
  }
  PetscCall(RestoreCsrValues(diagonal, off_diagonal, &diagonal_values, &off_diagonal_values));
  PetscCall(AddContributorBlocks(residual, jacobian));
  if (residual) PetscCall(FinishResidual(residual, strain_energy, *geometry_ok));
  // em: beta at these increments (eq. 20, BetaOfWorkSums) and the rank-one term R_corr (grad beta)^T,
  // grad beta = (grad M - beta grad C) / C: with beta known from the residual the vectors already
  // hold it; otherwise beta comes from this pass's sums and grad beta from its two gradients.
  double beta = fused_beta;
  if (em)
    for (Vec v : {rank_one_left_, rank_one_right_}) {
      PetscCall(VecAssemblyBegin(v));
      PetscCall(VecAssemblyEnd(v));
    }
  if (separate_correction) {
    double global[3];
    PetscCall(MPIU_Allreduce(sums, global, 3, MPI_DOUBLE, MPI_SUM, comm_));
    beta = BetaOfWorkSums(global);
    PetscCall(VecAssemblyBegin(beta_gradient_correction_));
    PetscCall(VecAssemblyEnd(beta_gradient_correction_));
    PetscCall(MatAssemblyBegin(correction_jacobian_, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(correction_jacobian_, MAT_FINAL_ASSEMBLY));
    if (beta != 0.0) {
      PetscCall(VecAXPY(rank_one_right_, -beta, beta_gradient_correction_));
      PetscCall(VecScale(rank_one_right_, 1.0 / global[1]));
    }
  }
  rank_one_active_ = em && beta != 0.0;
  if (rank_one_active_)
    for (size_t l = 0; l < slave_residual_.size(); ++l) slave_residual_[l] += beta * slave_correction_residual_[l];
  if (!eq.InitialAcceleration()) PetscCall(AddJointGeometricStiffness(jacobian));
  if (!skip_relay_coupling_) PetscCall(AddRelayCoupling(jacobian));
  PetscCall(MatAssemblyBegin(jacobian, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(jacobian, MAT_FINAL_ASSEMBLY));
  if (separate_correction && beta != 0.0) PetscCall(MatAXPY(jacobian, beta, correction_jacobian_, SAME_NONZERO_PATTERN));
  // (The global count: MatZeroRows is collective, also on a rank that owns no massless row.)
  if (state_->equations.InitialAcceleration() && !mass_matrix_only_ && num_massless_unknowns_ > 0) {
    // Massless unknowns: acceleration = 0 (the pattern is kept for the direct CSR assembly).
    PetscCall(MatSetOption(jacobian, MAT_KEEP_NONZERO_PATTERN, PETSC_TRUE));
    PetscCall(MatZeroRows(jacobian, (PetscInt)massless_rows_.size(), massless_rows_.data(), 1.0, nullptr, nullptr));
  }
  if (residual) {
    tangent_version_        = increments_version_;
    tangent_assembly_       = matrix_assemblies_;
    by_products_version_    = increments_version_;
    by_products_propagated_ = true; // by AddJointGeometricStiffness
  }
  PetscCall(PetscLogEventEnd(event_jacobian, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::AssembleMassMatrix(Mat mass, PetscBool *geometry_ok)
{
  PetscFunctionBeginUser;
  PetscCheck(state_->equations.InitialAcceleration(), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONGSTATE,
             "the mass matrix is the tangent of the initial-acceleration problem: begin that step first");
  mass_matrix_only_         = true;
  const PetscErrorCode code = AssembleJacobian(mass, geometry_ok);
  mass_matrix_only_         = false;
  PetscCall(code);
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
  const double local = StateMaxRotationIncrement(*state_, state_->equations.Dynamic());
  PetscCall(MPIU_Allreduce(&local, max_rotation, 1, MPI_DOUBLE, MPI_MAX, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::CurrentResidualByProducts()
{
  PetscBool evaluable;
  PetscFunctionBeginUser;
  if (by_products_version_ != increments_version_) PetscCall(AssembleResidual(scratch_residual_, &evaluable));
  if (!by_products_propagated_) PropagateSlaveResiduals();
  by_products_propagated_ = true;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::StepExternalWork(double *work)
{
  const StepEquations &eq = state_->equations;
  PetscFunctionBeginUser;
  // The reactions on prescribed DOFs and drives at exactly these increments.
  PetscCall(CurrentResidualByProducts());
  double local = 0.0;
  for (const ForceContributor *c : contributors_) c->AddStepWork(*state_, &local);
  // Prescribed DOFs: reaction (mid-point, or the mean of both ends) times (u, alpha or omega).
  const bool midpoint = eq.Midpoint();
  for (size_t l = 0; l < state_->nodes.size(); ++l) {
    NodeState &s = state_->nodes[l];
    for (int d = 0; d < 6; ++d) {
      if (map_->constraints[map_->local_nodes[l]][d].kind != Support::Kind::Prescribed) continue;
      const double increment = d < 3 ? s.displacement_increment(d) : midpoint ? s.tangent_scaled_increment(d - 3) : s.rotation_increment(d - 3);
      const double reaction  = midpoint ? prescribed_residual_[l](d) : 0.5 * (s.prescribed_reaction(d) + prescribed_residual_[l](d));
      local += reaction * increment;
    }
    if (!midpoint) s.prescribed_reaction = prescribed_residual_[l];
  }
  // Drives: the generalised reaction on a driven coordinate times its test increment.
  // (with what force elements add on the coordinate's own row: a spring or damper on a driven
  // coordinate is resisted by the drive).
  for (size_t j = 0; j < state_->joints.size(); ++j) {
    JointState &J = state_->joints[j];
    const int   c = model_->joints[J.joint].driven_coordinate;
    if (c < 0) continue;
    const double reaction = DriveReaction(j);
    local += (midpoint ? reaction : 0.5 * (J.drive_reaction + reaction)) * J.released_test[c];
    if (!midpoint) J.drive_reaction = reaction;
  }
  PetscCall(MPIU_Allreduce(&local, work, 1, MPI_DOUBLE, MPI_SUM, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::StoreReactions()
{
  PetscFunctionBeginUser;
  PetscCall(CurrentResidualByProducts());
  for (size_t l = 0; l < state_->nodes.size(); ++l) state_->nodes[l].prescribed_reaction = prescribed_residual_[l];
  for (size_t j = 0; j < state_->joints.size(); ++j) state_->joints[j].drive_reaction = DriveReaction(j);
  PetscFunctionReturn(PETSC_SUCCESS);
}

double Assembler::DriveReaction(size_t j) const
{
  const JointState &J = state_->joints[j];
  const int         c = model_->joints[J.joint].driven_coordinate;
  return c >= 0 ? J.rows_map.col(6 + c).dot(slave_residual_[J.local_slave]) + coordinate_residual_[j][c] : 0.0;
}

PetscErrorCode Assembler::EvaluateJointReactions(double dt, bool keep_rates)
{
  const DofMap &map = *map_;
  PetscMPIInt   rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  PetscCall(CurrentResidualByProducts());
  // Every rank adds the slave residual it assembled into the joint's slot, and for a driven joint
  // that residual mapped on the driven coordinate with what the force elements added on its row
  // (Assembler::StepExternalWork's generalised reaction); the owner adds the rates.
  PetscCall(VecZeroEntries(joint_output_));
  for (size_t j = 0; j < state_->joints.size(); ++j) {
    const JointState &J     = state_->joints[j];
    const PetscInt    first = kJointOutputStride * (PetscInt)map.joint_slot[J.joint];
    PetscInt          rows[kJointOutputStride];
    double            values[kJointOutputStride];
    for (int i = 0; i < kJointOutputStride; ++i) rows[i] = first + i;
    for (int i = 0; i < 6; ++i) values[i] = slave_residual_[J.local_slave](i);
    const bool owner = map.joint_rank[J.joint] == rank;
    for (int k = 0; k < kJointMaxReleased; ++k) values[6 + k] = owner && dt > 0.0 ? J.increment[k] / dt : 0.0;
    values[kDriveForceSlot] = DriveReaction(j);
    PetscCall(VecSetValues(joint_output_, kJointOutputStride, rows, values, ADD_VALUES));
  }
  PetscCall(VecAssemblyBegin(joint_output_));
  PetscCall(VecAssemblyEnd(joint_output_));
  const PetscScalar *output;
  PetscCall(VecGetArrayRead(joint_output_, &output));
  for (JointState &J : state_->joints) {
    if (map.joint_rank[J.joint] != rank) continue;
    const PetscScalar *row = output + kJointOutputStride * (map.joint_slot[J.joint] - map.first_owned_joint_slot);
    for (int i = 0; i < 6; ++i) J.reaction(i) = row[i];
    J.drive_force = row[kDriveForceSlot];
    // The mean rate over the step; at the initial state (no step: dt = 0) the coordinates' own
    // rates, which the initial velocities set (they read 0 for a mechanism started moving).
    if (!keep_rates)
      for (int c = 0; c < kJointMaxReleased; ++c) J.rate[c] = dt > 0.0 ? row[6 + c] : J.CoordinateRate(c);
  }
  PetscCall(VecRestoreArrayRead(joint_output_, &output));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
