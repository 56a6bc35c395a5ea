#include "assembly/mechanical_system.hpp"

namespace msflex {

PetscErrorCode MechanicalSystemPrepare(const Model &whole_model, const DofMap &whole_map, MatrixPattern *pattern, NodalMass *nodal_mass)
{
  PetscFunctionBeginUser;
  PetscCall(DofMapPreallocation(whole_map, whole_model, &pattern->diagonal_nonzeros, &pattern->off_diagonal_nonzeros, &pattern->row_start, &pattern->columns));
  PetscCall(NodalMassCreate(whole_model, whole_map, nodal_mass));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MechanicalSystem::Setup(MPI_Comm comm, const Model &model, const DofMap &map, MatrixPattern pattern, NodalMass nodal_mass)
{
  PetscFunctionBeginUser;
  comm_ = comm;
  StateCreate(model, map, &state_);
  PetscCall(beams_.Setup(model, map));
  inertia_.Setup(model, map, beams_, std::move(nodal_mass));
  loads_.Setup(model, map, beams_);
  rigid_bodies_.Setup(model, map);
  // The order of evaluation, which is the order in which the contributions are summed: per
  // element the internal forces, the inertia, then the loads; per node the inertia, then the
  // loads; then the rigid bodies' blocks.
  PetscCall(assembler_.Setup(comm, model, map, std::move(pattern), {&beams_, &inertia_, &loads_, &rigid_bodies_}, &beams_, &inertia_, &state_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MechanicalSystem::Momenta(msflex::Momenta *momenta)
{
  msflex::Momenta local;
  double          sums[7], global[7];
  PetscFunctionBeginUser;
  inertia_.AddMomenta(state_, &local);
  rigid_bodies_.AddMomenta(state_, &local);
  sums[0] = local.kinetic_energy;
  for (int i = 0; i < 3; ++i) sums[1 + i] = local.linear_momentum(i), sums[4 + i] = local.angular_momentum(i);
  PetscCall(MPIU_Allreduce(sums, global, 7, MPI_DOUBLE, MPI_SUM, comm_));
  momenta->kinetic_energy   = global[0];
  momenta->linear_momentum  = Vec3(global[1], global[2], global[3]);
  momenta->angular_momentum = Vec3(global[4], global[5], global[6]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MechanicalSystem::ElementResults(std::vector<msflex::ElementResults> *results, double *strain_energy)
{
  double local;
  PetscFunctionBeginUser;
  PetscCheck(beams_.Results(state_, results, &local), PETSC_COMM_SELF, PETSC_ERR_PLIB, "an element cannot be evaluated in a converged state");
  PetscCall(MPIU_Allreduce(&local, strain_energy, 1, MPI_DOUBLE, MPI_SUM, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
