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
  beam_damping_.Setup(model, map, beams_);
  coordinate_forces_.Setup(model, map, state_);
  node_pair_forces_.Setup(model, map);
  bool damped = false;
  for (const Section &section : model.sections) damped = damped || section.Damped();
  // On every rank alike (the history's series and their collective sums depend on it), though a
  // rank's part of the model may hold no force element.
  int local = damped || !model.force_elements.empty() ? 1 : 0, any = 0;
  PetscCallMPI(MPI_Allreduce(&local, &any, 1, MPI_INT, MPI_MAX, comm));
  has_force_elements_or_damping_ = any != 0;
  // The order of evaluation, which is the order in which the contributions are summed: per
  // element the internal forces, the structural damping, the inertia, then the loads; per node
  // the inertia, then the loads; then the rigid bodies' and the force elements' blocks. The force
  // elements and the damping take part only where the model has them.
  contributors_ = {&beams_};
  if (!beam_damping_.Empty()) contributors_.push_back(&beam_damping_);
  contributors_.insert(contributors_.end(), {&inertia_, &loads_, &rigid_bodies_});
  if (!coordinate_forces_.Empty()) contributors_.push_back(&coordinate_forces_);
  if (!node_pair_forces_.Empty()) contributors_.push_back(&node_pair_forces_);
  PetscCall(assembler_.Setup(comm, model, map, std::move(pattern), contributors_, &beams_, &inertia_, &state_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MechanicalSystem::SpringEnergy(double *energy)
{
  double local = 0.0;
  PetscFunctionBeginUser;
  for (const ForceContributor *c : contributors_)
    if (c->StoresSpringEnergy()) c->AddStoredEnergy(state_, &local);
  PetscCall(MPIU_Allreduce(&local, energy, 1, MPI_DOUBLE, MPI_SUM, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

void MechanicalSystem::StartMotion()
{
  for (ForceContributor *c : contributors_) c->StartMotion(&state_);
}

void MechanicalSystem::CommitStep()
{
  for (ForceContributor *c : contributors_) c->CommitStep(&state_);
}

void MechanicalSystem::ForceElementHistory(bool with_names, std::vector<HistoryValue> *values) const
{
  for (const ForceContributor *c : contributors_) c->AddHistory(state_, with_names, values);
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

PetscErrorCode MechanicalSystem::StrainEnergy(double *strain_energy)
{
  double local = 0.0;
  PetscFunctionBeginUser;
  if (!assembler_.LastResidualStrainEnergy(&local))
    PetscCheck(beams_.StrainEnergy(state_, &local), PETSC_COMM_SELF, PETSC_ERR_PLIB, "an element cannot be evaluated in a converged state");
  PetscCall(MPIU_Allreduce(&local, strain_energy, 1, MPI_DOUBLE, MPI_SUM, comm_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MechanicalSystem::ElementResultsOf(const std::vector<int> &only, std::vector<msflex::ElementResults> *results)
{
  PetscFunctionBeginUser;
  PetscCheck(beams_.ResultsOf(state_, only, results), PETSC_COMM_SELF, PETSC_ERR_PLIB, "an element cannot be evaluated in a converged state");
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
