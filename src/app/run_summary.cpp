#include "app/run_summary.hpp"

#include "core/format.hpp"

#include <petsclog.h>

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace msflex {

void RunSummary::Attempt(const StepOutcome &outcome)
{
  newton_all_ += outcome.newton_iterations + outcome.retried_newton_iterations;
  krylov_all_ += outcome.linear_iterations + outcome.retried_linear_iterations;
  if (outcome.converged) {
    ++accepted_;
    newton_accepted_ += outcome.newton_iterations;
  } else {
    ++rejected_[outcome.reason.empty() ? "corrector did not converge" : outcome.reason];
  }
}

void RunSummary::Energy(double energy_balance, double total_energy, double external_work, double dissipated)
{
  max_exchanged_ = std::max({max_exchanged_, std::fabs(external_work), std::fabs(dissipated)});
  if (!have_energy_) balance_first_ = energy_balance, first_total_ = total_energy;
  have_energy_  = true;
  balance_last_ = energy_balance;
  max_drift_    = std::max(max_drift_, std::fabs(energy_balance - balance_first_));
  max_growth_   = std::max(max_growth_, energy_balance - balance_first_);
  max_total_    = std::max(max_total_, std::fabs(total_energy));
}

PetscErrorCode RunSummary::Print(MPI_Comm comm, double wall_start, bool dynamic) const
{
  PetscStageLog stage_log;
  PetscFunctionBeginUser;
  // Wall time per stage: PETSc's stage clocks (exclusive: a nested stage stops its parent's), the
  // largest over the ranks; "other" is the rest of the run (the Main Stage, still running).
  PetscCall(PetscLogGetStageLog(&stage_log));
  const int           num_stages = stage_log->numStages;
  std::vector<double> local(num_stages + 2), largest(num_stages + 2);
  for (int i = 1; i < num_stages; ++i) local[i] = stage_log->stageInfo[i].perfInfo.time;
  local[0] = MPI_Wtime() - wall_start;
  struct rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  local[num_stages]     = (double)usage.ru_utime.tv_sec + 1e-6 * usage.ru_utime.tv_usec + (double)usage.ru_stime.tv_sec + 1e-6 * usage.ru_stime.tv_usec;
  local[num_stages + 1] = (double)usage.ru_maxrss * 1024.0; // Linux: kB
  PetscCall(MPIU_Allreduce(local.data(), largest.data(), num_stages + 2, MPI_DOUBLE, MPI_MAX, comm));
  double cpu_sum = 0.0, memory_sum = 0.0, mine[2] = {local[num_stages], local[num_stages + 1]}, sums[2];
  PetscCall(MPIU_Allreduce(mine, sums, 2, MPI_DOUBLE, MPI_SUM, comm));
  cpu_sum    = sums[0];
  memory_sum = sums[1];
  PetscMPIInt size;
  PetscCallMPI(MPI_Comm_size(comm, &size));

  std::string rejected;
  long long   num_rejected = 0;
  for (const auto &[reason, count] : rejected_) {
    rejected += Format("%s%d %s", rejected.empty() ? " (" : ", ", count, reason.c_str());
    num_rejected += count;
  }
  if (!rejected.empty()) rejected += ")";
  std::string stages;
  double      staged = 0.0;
  for (int i = 1; i < num_stages; ++i) {
    if (largest[i] <= 0.0) continue; // a stage this run never entered (e.g. PETSc's PCMPI)
    stages += Format("%s %s %.3g s", stages.empty() ? "" : ",", stage_log->stageInfo[i].name, largest[i]);
    staged += largest[i];
  }
  std::string text = "msflex: summary\n";
  text += Format("  steps              %lld accepted, %lld rejected%s\n", accepted_, num_rejected, rejected.c_str());
  text += Format("  Newton iterations  %lld in accepted steps, %lld in all attempts\n", newton_accepted_, newton_all_);
  text += Format("  Krylov iterations  %lld in all attempts\n", krylov_all_);
  if (reaction_solves_ > 0)
    text += Format("  reactions          from the consistent accelerations: %lld solves in %.3g s, %lld failed (-analysis_reactions scheme skips them)\n",
                   reaction_solves_, reaction_seconds_, reaction_failures_);
  if (tangents_reused_ > 0)
    text += Format("  tangents           %lld assembled and factored, %lld Newton iterations reused the last one (-analysis_jacobian_reuse)\n",
                   tangents_formed_, tangents_reused_);
  if (dynamic && have_energy_)
    text += Format("  energy drift       %.4g (energy_balance at the end minus at the start), %.3g of the largest total energy; largest |drift| %.3g of it\n",
                   balance_last_ - balance_first_, max_total_ > 0 ? (balance_last_ - balance_first_) / max_total_ : 0.0,
                   max_total_ > 0 ? max_drift_ / max_total_ : 0.0);
  // A mechanism that passes more energy through than it holds (a slow crank against a load)
  // reads its drift better against what went through.
  if (max_exchanged_ > max_total_)
    text += Format("                     %.3g of the largest external work or dissipation (%.4g J)\n", (balance_last_ - balance_first_) / max_exchanged_,
                   max_exchanged_);
  text += Format("  wall time          %.3g s:%s, other %.3g s%s\n", largest[0], stages.c_str(), std::max(0.0, largest[0] - staged),
                 size > 1 ? " (largest over the ranks)" : "");
  text += Format("  CPU time           %.3g s (user + system%s)\n", size > 1 ? cpu_sum : largest[num_stages], size > 1 ? ", all ranks" : "");
  text += Format("  peak memory        %.1f MiB%s\n", largest[num_stages + 1] / 1048576.0,
                 size > 1 ? Format(" on the largest rank, %.1f MiB on all ranks", memory_sum / 1048576.0).c_str() : "");
  PetscCall(PetscPrintf(comm, "%s", text.c_str()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
