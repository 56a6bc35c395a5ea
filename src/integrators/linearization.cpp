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

PetscErrorCode GeometricStiffness(MechanicalSystem &system, const Model &model, double lambda, Vec direction, double eps, Mat K_sigma)
{
  Assembler  &assembler = system.GetAssembler();
  State      &state     = system.GetState();
  const State committed = state;
  Vec         x;
  PetscBool   ok;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(direction, &x));
  for (int side = 0; side < 2; ++side) {
    const double s = side == 0 ? eps : -eps;
    // The perturbed state becomes the start of a step, so the tangent about it has omega = 0.
    PetscCall(VecCopy(direction, x));
    PetscCall(VecScale(x, s));
    PetscCall(SetStaticState(assembler, lambda, lambda + s, x));
    StateCommitStep(model, &state);
    PetscCall(SetStaticState(assembler, lambda + s, lambda + s, nullptr));
    PetscCall(assembler.AssembleJacobian(assembler.Jacobian(), &ok));
    state = committed;
    if (side == 0) PetscCall(CopyAssembled(assembler, ok, K_sigma, "geometric stiffness"));
    else {
      PetscBool all_ok;
      PetscCall(MPIU_Allreduce(&ok, &all_ok, 1, MPIU_BOOL, MPI_LAND, PetscObjectComm((PetscObject)K_sigma)));
      PetscCheck(all_ok, PetscObjectComm((PetscObject)K_sigma), PETSC_ERR_PLIB, "an element cannot be evaluated at the state of the geometric stiffness");
      PetscCall(MatAXPY(K_sigma, -1.0, assembler.Jacobian(), SAME_NONZERO_PATTERN));
    }
  }
  PetscCall(MatScale(K_sigma, 0.5 / eps));
  PetscCall(VecDestroy(&x));
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
