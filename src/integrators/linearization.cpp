#include "integrators/linearization.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

namespace {

// Begins the static step lambda_n -> lambda and sets the increments x (null: zero).
PetscErrorCode SetStaticState(Assembler &assembler, double lambda_n, double lambda, Vec x)
{
  PetscFunctionBeginUser;
  PetscCall(assembler.BeginStep(StaticStep(lambda_n, lambda)));
  if (x) PetscCall(assembler.SetIncrements(x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The assembler's matrix after its assembly, copied into `target`.
PetscErrorCode CopyAssembled(Assembler &assembler, PetscBool ok, Mat target, const char *what)
{
  PetscBool all_ok;
  PetscFunctionBeginUser;
  PetscCall(MPIU_Allreduce(&ok, &all_ok, 1, MPIU_BOOL, MPI_LAND, PetscObjectComm((PetscObject)target)));
  PetscCheck(all_ok, PetscObjectComm((PetscObject)target), PETSC_ERR_PLIB, "an element cannot be evaluated at the state of the %s", what);
  PetscCall(MatCopy(assembler.Jacobian(), target, SAME_NONZERO_PATTERN));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Zero increments of every DOF and joint coordinate, also of those a support prescribes or a drive
// moves: the configuration stays at the start of the step whatever the step's end time.
PetscErrorCode HoldConfiguration(MechanicalSystem &system, const Model &model, const DofMap &map)
{
  Assembler &assembler = system.GetAssembler();
  State     &state     = system.GetState();
  Vec        zero;
  PetscFunctionBeginUser;
  for (NodeState &node : state.nodes) node.displacement_increment.setZero(), node.rotation_increment.setZero();
  for (JointState &joint : state.joints)
    for (double &increment : joint.increment) increment = 0.0;
  PetscCall(VecDuplicate(assembler.SolutionTemplate(), &zero));
  PetscCall(VecZeroEntries(zero));
  PetscCall(assembler.SetIncrements(zero)); // updates the nodes, the slaves and the expansions
  PetscCall(VecDestroy(&zero));
  (void)model, (void)map;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode StaticResidual(MechanicalSystem &system, double lambda_n, double lambda, Vec x, Vec residual, PetscBool *ok, double *force_scale)
{
  Assembler &assembler = system.GetAssembler();
  PetscBool  geometry_ok;
  PetscFunctionBeginUser;
  PetscCall(SetStaticState(assembler, lambda_n, lambda, x));
  PetscCall(assembler.AssembleResidual(residual, &geometry_ok));
  PetscCall(MPIU_Allreduce(&geometry_ok, ok, 1, MPIU_BOOL, MPI_LAND, PetscObjectComm((PetscObject)residual)));
  PetscCall(assembler.ForceScale(force_scale));
  if (*ok) {
    PetscReal norm;
    PetscCall(VecNorm(residual, NORM_2, &norm));
    if (!std::isfinite((double)norm)) *ok = PETSC_FALSE;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode StaticLoadPattern(MechanicalSystem &system, double lambda_n, double lambda, Vec x, Vec residual, Vec q)
{
  Assembler   &assembler = system.GetAssembler();
  PetscBool    geometry_ok;
  const double h = 1e-6 * std::max(1.0, std::abs(lambda));
  PetscFunctionBeginUser;
  PetscCall(SetStaticState(assembler, lambda_n, lambda + h, x));
  PetscCall(assembler.AssembleResidual(q, &geometry_ok));
  PetscCall(VecAXPBY(q, 1.0 / h, -1.0 / h, residual)); // q = (R(lambda) - R(lambda + h)) / h
  PetscCall(SetStaticState(assembler, lambda_n, lambda, x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode EquilibriumTangent(MechanicalSystem &system, double lambda, Mat K)
{
  Assembler &assembler = system.GetAssembler();
  PetscBool  ok;
  PetscFunctionBeginUser;
  PetscCall(SetStaticState(assembler, lambda, lambda, nullptr));
  PetscCall(assembler.AssembleJacobian(assembler.Jacobian(), &ok));
  PetscCall(CopyAssembled(assembler, ok, K, "tangent"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MassMatrix(MechanicalSystem &system, double lambda, Mat M)
{
  Assembler &assembler = system.GetAssembler();
  PetscBool  ok;
  PetscFunctionBeginUser;
  PetscCall(assembler.BeginStep(InitialAccelerationProblem(lambda)));
  PetscCall(assembler.AssembleMassMatrix(assembler.Jacobian(), &ok));
  PetscCall(CopyAssembled(assembler, ok, M, "mass matrix"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode GeometricStiffness(MechanicalSystem &system, const Model &model, const DofMap &map, double lambda, Vec direction, double eps, Mat K_sigma)
{
  Assembler                                 &assembler = system.GetAssembler();
  BeamContributor                           &beams     = system.Beams();
  State                                     &state     = system.GetState();
  const State                                committed = state;
  std::vector<BeamContributor::GaussStrains> strains[2];
  Vec                                        x;
  PetscBool                                  ok = PETSC_TRUE;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(direction, &x));
  // The strain rate along the path, e' = (e(+eps u') - e(-eps u')) / (2 eps): each perturbed state
  // is made the start of a step, so that its strains are those of its configuration.
  for (int side = 0; side < 2; ++side) {
    const double s = side == 0 ? eps : -eps;
    PetscCall(VecCopy(direction, x));
    PetscCall(VecScale(x, s));
    PetscCall(SetStaticState(assembler, lambda, lambda + s, x));
    StateCommitStep(model, &state);
    PetscCall(SetStaticState(assembler, lambda + s, lambda + s, nullptr));
    if (!beams.GaussStrainsOf(state, &strains[side])) ok = PETSC_FALSE;
    state = committed;
  }
  PetscCall(VecDestroy(&x));
  PetscBool all_ok;
  PetscCall(MPIU_Allreduce(&ok, &all_ok, 1, MPIU_BOOL, MPI_LAND, PetscObjectComm((PetscObject)K_sigma)));
  PetscCheck(all_ok, PetscObjectComm((PetscObject)K_sigma), PETSC_ERR_PLIB, "an element cannot be evaluated at the perturbed states of the buckling analysis");
  for (size_t k = 0; k < strains[0].size(); ++k)
    for (int g = 0; g < kBeamMaxGauss; ++g) {
      strains[0][k].strain[g]    = (strains[0][k].strain[g] - strains[1][k].strain[g]) / (2.0 * eps);
      strains[0][k].curvature[g] = (strains[0][k].curvature[g] - strains[1][k].curvature[g]) / (2.0 * eps);
    }
  // K(x; loads at lambda) and K(x; prestrain e', loads at lambda + 1), both in the configuration x
  // (prescribed DOFs and drives held where they are): their difference is linear in the stresses
  // and loads, so it is K_sigma exactly.
  PetscCall(EquilibriumTangent(system, lambda, K_sigma));
  beams.AddPrestrain(strains[0]);
  PetscCall(assembler.BeginStep(StaticStep(lambda, lambda + 1.0)));
  PetscCall(HoldConfiguration(system, model, map));
  PetscCall(assembler.AssembleJacobian(assembler.Jacobian(), &ok));
  beams.ClearPrestrain();
  PetscCall(MPIU_Allreduce(&ok, &all_ok, 1, MPIU_BOOL, MPI_LAND, PetscObjectComm((PetscObject)K_sigma)));
  PetscCheck(all_ok, PetscObjectComm((PetscObject)K_sigma), PETSC_ERR_PLIB, "an element cannot be evaluated with the prestress of the buckling analysis");
  PetscCall(MatAYPX(K_sigma, -1.0, assembler.Jacobian(), SAME_NONZERO_PATTERN));
  PetscCall(SetStaticState(assembler, lambda, lambda, nullptr));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode UnknownWeights(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, double length, Vec weights)
{
  PetscFunctionBeginUser;
  PetscCall(VecSet(weights, 1.0));
  const double rotation_weight = length * length;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l)
    for (int d = 3; d < 6; ++d) {
      const PetscInt row = map.node_dofs[map.local_nodes[l]][d];
      if (row >= 0) PetscCall(VecSetValue(weights, row, rotation_weight, INSERT_VALUES));
    }
  // Joint coordinates: translations first, then angles (a free rotation's three components too).
  for (const JointState &J : state.joints) {
    const Joint &joint = model.joints[J.joint];
    for (int c = joint.num_translations; c < JointNumCoordinates(J.geometry); ++c) {
      const PetscInt row = map.joint_dofs[J.joint][c];
      if (row >= 0) PetscCall(VecSetValue(weights, row, rotation_weight, INSERT_VALUES));
    }
  }
  // Relay nodes' rows are no unknowns of the path (DofMap): weight 0.
  for (PetscInt row : map.OwnedRelayRows()) PetscCall(VecSetValue(weights, row, 0.0, INSERT_VALUES));
  PetscCall(VecAssemblyBegin(weights));
  PetscCall(VecAssemblyEnd(weights));
  (void)comm;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode ModelLength(MPI_Comm comm, const Model &model, const DofMap &map, double *length)
{
  double local[6], global[6];
  PetscFunctionBeginUser;
  for (int i = 0; i < 3; ++i) local[i] = local[3 + i] = -INFINITY;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const Vec3 &x = model.nodes[map.local_nodes[l]].position;
    for (int i = 0; i < 3; ++i) local[i] = std::max(local[i], x(i)), local[3 + i] = std::max(local[3 + i], -x(i));
  }
  PetscCall(MPIU_Allreduce(local, global, 6, MPI_DOUBLE, MPI_MAX, comm));
  double squares = 0.0;
  for (int i = 0; i < 3; ++i)
    if (std::isfinite(global[i]) && std::isfinite(global[3 + i])) squares += (global[i] + global[3 + i]) * (global[i] + global[3 + i]);
  *length = squares > 0 ? std::sqrt(squares) : 1.0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode VecEntry(Vec v, PetscInt row, double *value)
{
  PetscInt first, last;
  double   local = 0.0;
  PetscFunctionBeginUser;
  PetscCall(VecGetOwnershipRange(v, &first, &last));
  if (row >= first && row < last) {
    const PetscScalar *values;
    PetscCall(VecGetArrayRead(v, &values));
    local = PetscRealPart(values[row - first]);
    PetscCall(VecRestoreArrayRead(v, &values));
  }
  PetscCall(MPIU_Allreduce(&local, value, 1, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)v)));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
