// The end-of-run summary (docs/options.md, "Summary"): steps, rejections by reason, Newton and
// Krylov iterations, wall time per -log_view stage, CPU time, energy drift and peak memory,
// printed by rank 0 unless -quiet.
#pragma once

#include "integrators/integrator.hpp"

#include <petscsys.h>

#include <map>
#include <string>

namespace msflex {

class RunSummary {
public:
  // Every attempt at a step, converged or not.
  void Attempt(const StepOutcome &outcome);
  // Every history row of a dynamic analysis: energy_balance = total energy - external work +
  // dissipated energy, and the energy that went in and out (external work, dissipation).
  void Energy(double energy_balance, double total_energy, double external_work = 0.0, double dissipated = 0.0);
  // The largest growth of energy_balance above its first value, relative to the largest total
  // energy (0 when it never grew): an integrator that creates energy.
  double RelativeEnergyGrowth() const { return max_total_ > 0 ? max_growth_ / max_total_ : 0.0; }
  // That growth in J, and the total energy of the first row (the scale a reader knows: relative
  // to the largest total energy, a run whose energy blew up by 1e11 read "grew by 1 times").
  double EnergyGrowth() const { return max_growth_; }
  double InitialTotalEnergy() const { return first_total_; }
  // Tangents assembled and factored, and Newton iterations that reused one (modified Newton).
  void Tangents(long long formed, long long reused)
  {
    tangents_formed_ = formed;
    tangents_reused_ = reused;
  }
  // Dynamics with analysis.reactions consistent: the acceleration solves made for the reactions
  // and how many of them failed (the scheme's reactions were reported there).
  void ConsistentReactions(long long solves, long long failures, double seconds)
  {
    reaction_solves_   = solves;
    reaction_failures_ = failures;
    reaction_seconds_  = seconds;
  }
  // Collective: times and memory are reduced over the ranks. `wall_start`: MPI_Wtime at the start
  // of the run on this rank.
  PetscErrorCode Print(MPI_Comm comm, double wall_start, bool dynamic) const;

private:
  long long accepted_ = 0, newton_accepted_ = 0, newton_all_ = 0, krylov_all_ = 0, tangents_formed_ = 0, tangents_reused_ = 0, reaction_solves_ = 0,
            reaction_failures_                 = 0;
  double                     reaction_seconds_ = 0.0;
  std::map<std::string, int> rejected_; // by reason
  bool                       have_energy_   = false;
  double                     balance_first_ = 0.0, balance_last_ = 0.0, max_drift_ = 0.0, max_total_ = 0.0, max_growth_ = 0.0, first_total_ = 0.0;
  double                     max_exchanged_ = 0.0; // the largest |external work| or |dissipated energy|
};

} // namespace msflex
