// The projection of the initial velocities (Assembler::ProjectInitialVelocities): the unknowns are
// the velocities of the independent nodes and the rates of the free joint coordinates (stored in
// the increment fields, as the accelerations of the initial-acceleration problem); slaves follow
// through their joints' maps N, drives and prescribed supports impose their rates (state.cpp).
//
// With V(y) the nodal velocities of the unknowns y, the beams' strain rates are edot = B V
// (elements/beam_rates.hpp) and the objective is
//   Phi(y) = 1/2 sum_elements V^T K_e V + 1/2 w sum_slaves with a given velocity |V_s - V_s,given|^2,
// K_e = B^T C B the element's material stiffness (the internal-force kernel with the stresses set
// to zero), w = the largest diagonal entry of the assembled K (so a slave's given velocity weighs
// like a stiff beam). Unknowns held at given values (nodes' initial conditions, coordinates' initial
// rates) and unknowns no term reaches (left at rest) are removed by identity rows and columns. The
// gradient at the given velocities y_g, R = A y_g + r_0, lies in the range of A (Phi is a sum of
// squares), so A delta = -R is consistent; conjugate gradients from delta = 0 give its minimum-norm
// solution: no component along the motions nothing determines.
#include "assembly/assembler.hpp"
#include "core/block_envelope_pc.hpp"
#include "core/dense_lu.hpp"

#include "contributors/beam_contributor.hpp"
#include "elements/beam_rates.hpp"

#include <petscksp.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace msflex {

// The relay path of the projection: the condensed operator through the residual, and the coupled
// matrix's LU as preconditioner (Assembler::ProjectInitialVelocities).
struct RelayProjection {
  Assembler                         *self = nullptr;
  const std::vector<PetscInt>       *held = nullptr;
  Vec                                y = nullptr, base_R = nullptr; // the given velocities and R there
  KSP                                coupled = nullptr;
  std::function<PetscErrorCode(Vec)> assemble;       // R at the velocities set last
  Vec                                work = nullptr; // the operator's and the preconditioner's scratch
};

// out = A v on the condensed rows (held rows and the relays' rows: out = v).
static PetscErrorCode RelayProjectionMult(Mat shell, Vec v, Vec out)
{
  RelayProjection *relay;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(shell, &relay));
  const PetscInt first = relay->self->Map().first_owned;
  Vec            trial = relay->work;
  PetscCall(VecCopy(v, trial));
  PetscCall(relay->self->ZeroRelayEntries(trial));
  PetscScalar *values;
  PetscCall(VecGetArray(trial, &values));
  for (PetscInt row : *relay->held) values[row - first] = 0.0;
  PetscCall(VecRestoreArray(trial, &values));
  PetscCall(VecAXPY(trial, 1.0, relay->y));
  PetscCall(relay->self->SetIncrements(trial));
  PetscCall(relay->assemble(out));
  PetscCall(VecAXPY(out, -1.0, relay->base_R));
  const PetscScalar *given;
  PetscCall(VecGetArrayRead(v, &given));
  PetscCall(VecGetArray(out, &values));
  for (PetscInt row : *relay->held) values[row - first] = given[row - first];
  PetscCall(VecRestoreArray(out, &values));
  PetscCall(VecRestoreArrayRead(v, &given));
  PetscCall(relay->self->CopyRelayEntries(v, out));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// z = the condensed rows of (coupled matrix + shift on the condensed rows)^{-1} b; relays' rows z = b.
static PetscErrorCode RelayProjectionPreconditioner(PC pc, Vec b, Vec z)
{
  RelayProjection *relay;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &relay));
  Vec rhs = relay->work;
  PetscCall(VecCopy(b, rhs));
  PetscCall(relay->self->ZeroRelayEntries(rhs));
  PetscCall(KSPSolve(relay->coupled, rhs, z));
  KSPConvergedReason reason;
  PetscCall(KSPGetConvergedReason(relay->coupled, &reason));
  if (reason < 0) PetscCall(PCSetFailedReason(pc, PC_SUBPC_ERROR));
  PetscCall(relay->self->CopyRelayEntries(b, z));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::ProjectInitialVelocities(double t, InitialVelocityReport *report)
{
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  State        &state = *state_;
  PetscFunctionBeginUser;
  *report = InitialVelocityReport{};
  StateBeginStep(model, map, InitialVelocityProblem(t), state_);
  ForgetIncrements();
  UpdateExpansions();

  // The given velocities per node (spatial), and which nodes and coordinates have one.
  std::vector<const InitialCondition *> given(state.nodes.size(), nullptr);
  for (const InitialCondition &ic : model.initial_conditions)
    if (ic.has_velocity)
      for (int node : ic.nodes) {
        const int l = map.node_to_local[node];
        if (l >= 0) given[l] = &ic;
      }
  auto given_velocity = [&](int l) {
    Vec6                    V  = Vec6::Zero();
    const InitialCondition *ic = given[l];
    if (!ic) return V;
    const Vec3 X = model.nodes[map.local_nodes[l]].position;
    V.head<3>()  = ic->velocity + (ic->rigid_body_field ? Vec3(ic->angular_velocity.cross(X - ic->center)) : Vec3::Zero());
    V.tail<3>()  = ic->angular_velocity;
    return V;
  };

  // y_g: the given velocities (rest elsewhere); the rows held at them.
  Vec                   y, delta, R;
  std::vector<PetscInt> held;
  PetscCall(VecDuplicate(solution_template_, &y));
  PetscCall(VecDuplicate(solution_template_, &delta));
  PetscCall(VecDuplicate(solution_template_, &R));
  PetscCall(VecSetOption(R, VEC_IGNORE_NEGATIVE_INDICES, PETSC_TRUE)); // node vectors carry -1 on fixed DOFs
  PetscCall(VecZeroEntries(y));
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (IsSlave((int)l) || !given[l]) continue;
    const Vec6                     V    = given_velocity((int)l);
    const std::array<PetscInt, 6> &dofs = map.node_dofs[map.local_nodes[l]];
    for (int d = 0; d < 6; ++d)
      if (dofs[d] >= 0) {
        PetscCall(VecSetValue(y, dofs[d], V(d), INSERT_VALUES));
        held.push_back(dofs[d]);
      }
  }
  for (const CoordinateInitialCondition &ic : model.coordinate_initial_conditions) {
    if (!ic.has_rate) continue;
    const int j = map.joint_to_local[ic.joint];
    if (j < 0 || state.joints[j].local_slave >= map.num_owned_nodes) continue;
    const PetscInt row = map.joint_dofs[ic.joint][ic.coordinate];
    if (row < 0) continue;
    PetscCall(VecSetValue(y, row, ic.rate, INSERT_VALUES));
    held.push_back(row);
  }
  PetscCall(VecAssemblyBegin(y));
  PetscCall(VecAssemblyEnd(y));
  PetscCall(SetIncrements(y));

  // The beams' material stiffness at the start configuration (one kernel call per element: the
  // reference strains shifted to the current ones, so the stresses and the geometric terms vanish).
  double                           local_diagonal = 0.0, weight;
  const auto                      &references     = beams_->References();
  std::vector<std::vector<double>> element_matrices(map.local_elements.size());
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const BeamElement &element = model.elements[map.local_elements[k]];
    const Section     &section = model.sections[element.section];
    const int          nd      = 6 * (element.order + 1);
    Vec3 positions[kBeamMaxNodes], zero[kBeamMaxNodes], strain[kBeamMaxGauss], curvature[kBeamMaxGauss], rate[kBeamMaxGauss], kappa_rate[kBeamMaxGauss];
    Mat3 triads[kBeamMaxNodes];
    BeamElementReference shifted = references[k];
    double               force[kBeamMaxDofs];
    std::vector<double> &K = element_matrices[k];
    for (Vec3 &v : zero) v.setZero();
    beams_->StartConfiguration(state, k, positions, triads);
    K.assign((size_t)nd * nd, 0.0);
    if (BeamStrainRates(shifted, positions, triads, zero, zero, strain, curvature, rate, kappa_rate) != BeamKernelStatus::Ok) continue;
    for (int gp = 0; gp < shifted.num_gauss; ++gp) shifted.strain0[gp] += strain[gp], shifted.curvature0[gp] += curvature[gp];
    const BeamSectionStiffness stiffness{Vec3(section.EA, section.GA2, section.GA3), Vec3(section.GJ, section.EI2, section.EI3)};
    if (BeamInternalForces(shifted, stiffness, positions, triads, force, K.data(), nullptr, nullptr) != BeamKernelStatus::Ok) continue;
    for (int i = 0; i < nd; ++i) local_diagonal = std::max(local_diagonal, K[(size_t)i * nd + i]);
  }
  PetscCall(MPIU_Allreduce(&local_diagonal, &weight, 1, MPI_DOUBLE, MPI_MAX, comm_));
  if (!(weight > 0.0)) weight = 1.0;

  // A and R = A y_g + r_0 (the strain-rate forces K_e V and the slaves' pulls to their given velocities).
  auto assemble_into = [&](Vec R, bool with_matrix, double *strain_rate) -> PetscErrorCode {
    PetscFunctionBeginUser;
    PetscCall(VecSetOption(R, VEC_IGNORE_NEGATIVE_INDICES, PETSC_TRUE)); // also the CG's work vectors
    PetscCall(VecZeroEntries(R));
    if (with_matrix) PetscCall(MatZeroEntries(jacobian_));
    double local_rate = 0.0;
    for (size_t k = 0; k < map.local_elements.size(); ++k) {
      const BeamElement &element = model.elements[map.local_elements[k]];
      const int          n = element.order + 1, nd = 6 * n;
      int                nodes[kBeamMaxNodes];
      double             V[kBeamMaxDofs], r[kBeamMaxDofs];
      for (int a = 0; a < n; ++a) {
        nodes[a]           = map.node_to_local[element.nodes[a]];
        const NodeState &s = state.nodes[nodes[a]];
        for (int i = 0; i < 3; ++i) V[6 * a + i] = s.displacement_increment(i), V[6 * a + 3 + i] = s.rotation_increment(i);
      }
      const std::vector<double> &K            = element_matrices[k];
      double                     element_rate = 0.0;
      for (int i = 0; i < nd; ++i) {
        r[i] = 0.0;
        for (int j = 0; j < nd; ++j) r[i] += K[(size_t)i * nd + j] * V[j];
        element_rate += V[i] * r[i];
      }
      local_rate += std::max(element_rate, 0.0); // V^T K_e V >= 0: below 0 only by rounding
      for (int a = 0; a < n; ++a) PetscCall(AddNodeResidual(R, nodes[a], &r[6 * a]));
      if (with_matrix) PetscCall(AddExpandedMatrix(jacobian_, n, nodes, K.data()));
    }
    for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
      if (!IsSlave((int)l) || !given[l]) continue;
      const NodeState &s = state.nodes[l];
      Vec6             V;
      V << s.displacement_increment, s.rotation_increment;
      const Vec6 g = weight * (V - given_velocity((int)l));
      PetscCall(AddNodeResidual(R, (int)l, g.data()));
      if (with_matrix) PetscCall(AddNodeBlock(jacobian_, (int)l, Mat6(weight * Mat6::Identity())));
    }
    PetscCall(FinishRelayForces(R));
    PetscCall(VecAssemblyBegin(R));
    PetscCall(VecAssemblyEnd(R));
    if (with_matrix) {
      PetscCall(MatAssemblyBegin(jacobian_, MAT_FINAL_ASSEMBLY));
      PetscCall(MatAssemblyEnd(jacobian_, MAT_FINAL_ASSEMBLY));
    }
    PetscCall(MPIU_Allreduce(&local_rate, strain_rate, 1, MPI_DOUBLE, MPI_SUM, comm_));
    PetscFunctionReturn(PETSC_SUCCESS);
  };
  auto assemble = [&](bool with_matrix, double *strain_rate) -> PetscErrorCode { return assemble_into(R, with_matrix, strain_rate); };
  PetscCall(assemble(true, &report->strain_rate_before));
  // The preconditioner's shift scales with the largest diagonal entry of A itself, with 1 on the
  // held rows (not with the relays' coupling, added below).
  PetscReal largest_diagonal;
  Vec       diagonal;
  PetscCall(VecDuplicate(solution_template_, &diagonal));
  PetscCall(MatGetDiagonal(jacobian_, diagonal));

  // Rows no term reaches stay at rest; held rows stay at their given values. With relay nodes, a
  // row reached only below a relay counts as reached (DropRelayReachedRows); the matrix then gets
  // their exact coupling, for the preconditioner below.
  {
    std::vector<PetscInt> empty_rows, sorted_held = held;
    PetscCall(EmptyRowsOfJacobian(&empty_rows));
    if (map.num_relays > 0) {
      PetscCall(DropRelayReachedRows(&empty_rows));
      PetscCall(AddRelayCoupling(jacobian_));
      PetscCall(MatAssemblyBegin(jacobian_, MAT_FINAL_ASSEMBLY));
      PetscCall(MatAssemblyEnd(jacobian_, MAT_FINAL_ASSEMBLY));
    }
    std::sort(sorted_held.begin(), sorted_held.end());
    PetscInt at_rest = 0;
    for (const PetscInt row : empty_rows)
      if (!std::binary_search(sorted_held.begin(), sorted_held.end(), row)) {
        held.push_back(row);
        ++at_rest;
      }
    const PetscInt counts[2] = {(PetscInt)held.size() - at_rest, at_rest};
    PetscInt       totals[2];
    PetscCallMPI(MPIU_Allreduce(counts, totals, 2, MPIU_INT, MPI_SUM, comm_));
    report->held    = totals[0];
    report->at_rest = totals[1];
    report->chosen  = map.NumStateUnknowns() - totals[0] - totals[1];
  }
  for (PetscInt row : held) PetscCall(VecSetValue(diagonal, row, 1.0, INSERT_VALUES));
  PetscCall(VecAssemblyBegin(diagonal));
  PetscCall(VecAssemblyEnd(diagonal));
  PetscCall(VecAbs(diagonal));
  PetscCall(VecMax(diagonal, nullptr, &largest_diagonal));
  PetscCall(VecDestroy(&diagonal));
  PetscCall(MatSetOption(jacobian_, MAT_KEEP_NONZERO_PATTERN, PETSC_TRUE));
  PetscCall(MatZeroRowsColumns(jacobian_, (PetscInt)held.size(), held.data(), 1.0, nullptr, nullptr));
  for (PetscInt row : held) PetscCall(VecSetValue(R, row, 0.0, INSERT_VALUES));
  PetscCall(VecAssemblyBegin(R));
  PetscCall(VecAssemblyEnd(R));
  PetscCall(VecScale(R, -1.0));
  // Nothing strains (no velocity given, none driven or prescribed at t, or only rigid motions): the
  // answer is delta = 0, and the solve below would cost a factorisation of the whole tangent
  // (12.4 s and 1.8 GB of a lattice of 10^5 elements starting at rest).
  PetscReal R_norm;
  PetscCall(VecNorm(R, NORM_INFINITY, &R_norm));
  PetscCall(VecZeroEntries(delta));
  report->solved = R_norm > 0.0;
  if (report->solved) {
    // A delta = -R: minimum-norm solution by preconditioned conjugate gradients.
    Mat P;
    KSP ksp;
    PC  pc;
    PetscCall(MatDuplicate(jacobian_, MAT_COPY_VALUES, &P));
    PetscCall(KSPCreate(comm_, &ksp));
    PetscCall(KSPSetOptionsPrefix(ksp, "velocity_projection_"));
    PetscCall(KSPSetType(ksp, KSPCG));
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(KSPSetTolerances(ksp, 1e-12, 0.0, PETSC_DEFAULT, 200));
    // Stop on the true residual: the preconditioned one carries the residual's round-off along the
    // motions nothing determines, amplified by the inverse shift, and iterating on until it fell
    // wandered along those motions (a free hinge below a spun screw started at 0.0115 rad/s on one
    // rank and -9.76 on two instead of the minimum-norm 1.3445; a rack-and-pinion stopped with
    // DIVERGED_INDEFINITE_MAT).
    PetscCall(KSPSetNormType(ksp, KSP_NORM_UNPRECONDITIONED));
    // With relay nodes the matrix is a saddle point, not A: conjugate gradients run on the condensed
    // A itself, applied as the change of the residual (exact: R is affine in the velocities, and
    // condensed by FinishRelayForces), with identity on the held rows and the relays' rows; the
    // preconditioner solves the coupled matrix shifted on the condensed rows only, whose condensed
    // form is the A + shift I of the other case.
    RelayProjection relay{};
    Mat             shell   = nullptr;
    Vec             base_R  = nullptr;
    Vec             shifted = nullptr;
    KSP             coupled = nullptr;
    if (map.num_relays == 0) {
      PetscCall(MatShift(P, 1e-8 * largest_diagonal));
      PetscCall(KSPSetOperators(ksp, jacobian_, P));
      // As Newton's tangent (ChooseDirectSolver): a banded one by msflex's block LU or PETSc's LU in
      // RCM order (the Main stage of a 1000-element chain, mostly this projection: 25-34 ms with
      // MUMPS, 10-13 with the block LU; with joint coordinates, AIJ, MUMPS took 0.77 s and 179 MiB
      // to choose one hinge rate of a 40,000-element beam), else MUMPS or the dense LU. The shifted
      // matrix is positive definite, so the banded LUs miss no pivoting.
      PetscCall(ChooseDirectSolver(banded_under_rcm_, P, pc));
    } else {
      PetscCall(VecDuplicate(solution_template_, &shifted));
      PetscCall(VecSet(shifted, 1e-8 * largest_diagonal));
      PetscCall(ZeroRelayEntries(shifted));
      PetscCall(MatDiagonalSet(P, shifted, ADD_VALUES));
      PetscCall(VecDuplicate(solution_template_, &base_R));
      PetscCall(VecCopy(R, base_R));
      PetscCall(VecScale(base_R, -1.0)); // R at the given velocities
      PetscCall(KSPCreate(comm_, &coupled));
      PetscCall(KSPSetOptionsPrefix(coupled, "velocity_projection_coupled_"));
      PetscCall(KSPSetType(coupled, KSPPREONLY));
      PetscCall(KSPSetOperators(coupled, P, P));
      PC coupled_pc;
      PetscCall(KSPGetPC(coupled, &coupled_pc));
      PetscCall(SetDirectSolver(coupled_pc, P));
      PetscCall(KSPSetFromOptions(coupled));
      PetscCall(PrepareRelayDirectSolver(coupled_pc, P, "-velocity_projection_coupled_pc_factor_mat_solver_type", model.analysis.condensation_depth));
      relay.self    = this;
      relay.held    = &held;
      relay.y       = y;
      relay.base_R  = base_R;
      relay.coupled = coupled;
      PetscCall(VecDuplicate(solution_template_, &relay.work));
      relay.assemble = [&](Vec target) {
        double rate;
        return assemble_into(target, false, &rate);
      };
      PetscCall(MatCreateShell(comm_, map.num_owned, map.num_owned, map.num_global, map.num_global, &relay, &shell));
      PetscCall(MatShellSetOperation(shell, MATOP_MULT, (void (*)(void))RelayProjectionMult));
      PetscCall(KSPSetOperators(ksp, shell, shell));
      PetscCall(PCSetType(pc, PCSHELL));
      PetscCall(PCShellSetContext(pc, &relay));
      PetscCall(PCShellSetApply(pc, RelayProjectionPreconditioner));
    }
    PetscCall(KSPSetFromOptions(ksp));
    PetscCall(KSPSolve(ksp, R, delta));
    KSPConvergedReason reason;
    PetscCall(KSPGetConvergedReason(ksp, &reason));
    PetscCall(KSPGetIterationNumber(ksp, &report->iterations));
    // Conjugate gradients measure the preconditioned residual, which the shift's near-singular LU
    // (a free hinge's mode) can hold at round-off above the tolerance while the true residual has
    // converged; CG then breaks down (DIVERGED_INDEFINITE_MAT on a flexible double pendulum whose
    // true residual was 1e-15 of the start's). Such a stop is accepted on the true residual.
    if (reason <= 0) {
      Mat       A;
      Vec       check;
      PetscReal true_norm;
      PetscCall(KSPGetOperators(ksp, &A, nullptr));
      PetscCall(VecDuplicate(R, &check));
      PetscCall(MatMult(A, delta, check));
      PetscCall(VecAXPY(check, -1.0, R));
      PetscCall(ZeroRelayEntries(check));
      PetscCall(VecNorm(check, NORM_INFINITY, &true_norm));
      PetscCall(VecDestroy(&check));
      if (std::isfinite(true_norm) && true_norm <= 1e-10 * R_norm) reason = KSP_CONVERGED_RTOL;
    }
    PetscCall(KSPDestroy(&ksp));
    PetscCall(KSPDestroy(&coupled));
    PetscCall(VecDestroy(&relay.work));
    PetscCall(MatDestroy(&shell));
    PetscCall(VecDestroy(&base_R));
    PetscCall(VecDestroy(&shifted));
    PetscCall(MatDestroy(&P));
    PetscCheck(reason > 0, comm_, PETSC_ERR_NOT_CONVERGED,
               "the projection of the initial velocities did not converge (%s); run with -analysis_initial_velocities given", KSPConvergedReasons[reason]);
  }
  PetscCall(ZeroRelayEntries(delta));
  PetscCall(VecAXPY(y, 1.0, delta));
  PetscCall(SetIncrements(y));
  PetscCall(assemble(false, &report->strain_rate_after));

  // The velocities into the state's motion: nodes (angular velocity in the body frame), joint
  // coordinates (their rates), rigid bodies' centres of mass.
  double local_change = 0.0;
  for (size_t l = 0; l < state.nodes.size(); ++l) {
    NodeState &s                  = state.nodes[l];
    s.translation_motion.velocity = s.displacement_increment;
    s.rotation_motion.velocity    = QuaternionToMatrix(s.rotation_start).transpose() * s.rotation_increment;
    if (given[l] && (PetscInt)l < map.num_owned_nodes) {
      Vec6 V;
      V << s.displacement_increment, s.rotation_increment;
      local_change = std::max(local_change, (V - given_velocity((int)l)).cwiseAbs().maxCoeff());
    }
  }
  PetscCallMPI(MPIU_Allreduce(&local_change, &report->slave_change, 1, MPI_DOUBLE, MPI_MAX, comm_));
  for (JointState &J : state.joints)
    for (int c = 0; c < kJointMaxReleased; ++c) J.coordinate_motion[c / 3].velocity(c % 3) = J.increment[c];
  for (RigidBodyState &body : state.bodies) {
    const NodeState &s           = state.nodes[body.local_node];
    body.centre_of_mass.velocity = s.translation_motion.velocity + s.rotation_increment.cross(QuaternionToMatrix(s.rotation_start) * body.offset);
  }
  PetscCall(VecDestroy(&y));
  PetscCall(VecDestroy(&delta));
  PetscCall(VecDestroy(&R));
  // Back to the start state (no increments).
  state.equations = StaticStep(t, t);
  DiscardStep();
  UpdateExpansions();
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
