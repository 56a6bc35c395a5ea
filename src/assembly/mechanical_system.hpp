// The mechanical system a rank holds: its State, the force contributors acting on it and the
// assembler that condenses and inserts them. Built on the rank's part of the model (or the whole
// model) from what only the whole model can give (the matrix pattern, nodal masses).
#pragma once

#include "assembly/assembler.hpp"
#include "contributors/beam_contributor.hpp"
#include "contributors/beam_damping_contributor.hpp"
#include "contributors/force_element_contributors.hpp"
#include "contributors/inertia_contributor.hpp"
#include "contributors/load_contributor.hpp"
#include "contributors/rigid_body_contributor.hpp"
#include "state/state.hpp"

#include <vector>

namespace msflex {

// What the set-up needs from the whole model before it is restricted to the rank's part: the
// exact matrix pattern of the owned rows and the nodal masses (both see elements assembled on
// other ranks). Not collective.
PetscErrorCode MechanicalSystemPrepare(const Model &whole_model, const DofMap &whole_map, MatrixPattern *pattern, NodalMass *nodal_mass);

class MechanicalSystem {
public:
  MechanicalSystem()                                    = default;
  MechanicalSystem(const MechanicalSystem &)            = delete;
  MechanicalSystem &operator=(const MechanicalSystem &) = delete;

  // The model and map must outlive the system. Collective.
  PetscErrorCode Setup(MPI_Comm comm, const Model &model, const DofMap &map, MatrixPattern pattern, NodalMass nodal_mass);

  Assembler             &GetAssembler() { return assembler_; }
  const Assembler       &GetAssembler() const { return assembler_; }
  State                 &GetState() { return state_; }
  const State           &GetState() const { return state_; }
  const BeamContributor &Beams() const { return beams_; }
  BeamContributor       &Beams() { return beams_; }
  // Kinetic energy and momenta of the start-of-step state (collective).
  PetscErrorCode Momenta(msflex::Momenta *momenta);
  // Element results and strain energy of the current configuration (collective).
  PetscErrorCode ElementResults(std::vector<msflex::ElementResults> *results, double *strain_energy);
  // The results of the local elements `only` alone, the others zero (not collective).
  PetscErrorCode ElementResultsOf(const std::vector<int> &only, std::vector<msflex::ElementResults> *results);
  // The strain energy alone (collective): on each rank what the last residual kept when the State
  // still holds its unknowns (Assembler::LastResidualStrainEnergy), else a pass over the elements.
  PetscErrorCode StrainEnergy(double *strain_energy);
  // Stored energy of the force elements' springs in the current configuration (collective).
  PetscErrorCode SpringEnergy(double *energy);
  // Whether the model has force elements or damped beams (their history series). Not collective:
  // the same on every rank.
  bool HasForceElementsOrDamping() const { return has_force_elements_or_damping_; }
  // The contributors' own motion: after the initial velocities (and accelerations), and at the
  // converged increments of a step before the state commits them.
  void StartMotion();
  void CommitStep();
  // History values of the force elements this rank evaluates (output/results.hpp gathers them),
  // named only `with_names`.
  void ForceElementHistory(bool with_names, std::vector<HistoryValue> *values) const;

private:
  MPI_Comm                        comm_ = MPI_COMM_NULL;
  State                           state_;
  BeamContributor                 beams_;
  InertiaContributor              inertia_;
  LoadContributor                 loads_;
  RigidBodyContributor            rigid_bodies_;
  BeamDampingContributor          beam_damping_;
  CoordinateForceContributor      coordinate_forces_;
  NodePairForceContributor        node_pair_forces_;
  std::vector<ForceContributor *> contributors_; // in the order of evaluation
  bool                            has_force_elements_or_damping_ = false;
  Assembler                       assembler_;
};

} // namespace msflex
