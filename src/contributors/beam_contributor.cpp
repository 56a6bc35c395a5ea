#include "contributors/beam_contributor.hpp"

#include "core/errors.hpp"

#include <cmath>

namespace msflex {

PetscErrorCode BeamElementReferenceOf(const Model &model, int e, BeamElementReference *ref)
{
  const BeamElement &element = model.elements[e];
  Vec3               positions[kBeamMaxNodes];
  PetscFunctionBeginUser;
  for (int a = 0; a <= element.order; ++a) positions[a] = model.nodes[element.nodes[a]].position;
  const BeamKernelStatus status = BeamElementSetup(element.order + 1, positions, element.reference_triads.data(), ref);
  const Beam            &beam   = model.beams[element.beam];
  MSFLEX_INPUT_CHECK(status == BeamKernelStatus::Ok, beam.mark, "beam '%s': an element is degenerate (zero length or reference triads turning by pi or more)",
                     beam.name.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode BeamContributor::Setup(const Model &model, const DofMap &map)
{
  PetscFunctionBeginUser;
  model_ = &model;
  map_   = &map;
  sections_.clear();
  for (const Section &s : model.sections) sections_.push_back({Vec3(s.EA, s.GA2, s.GA3), Vec3(s.GJ, s.EI2, s.EI3)});
  references_.resize(map.local_elements.size());
  for (size_t k = 0; k < map.local_elements.size(); ++k) PetscCall(BeamElementReferenceOf(model, map.local_elements[k], &references_[k]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

void BeamContributor::Configuration(const State &state, size_t k, Vec3 *positions, Mat3 *triads) const
{
  const BeamElement &element = model_->elements[map_->local_elements[k]];
  for (int a = 0; a <= element.order; ++a) {
    const NodeState &s = state.nodes[map_->node_to_local[element.nodes[a]]];
    positions[a]       = s.position;
    triads[a]          = s.rotation * element.reference_triads[a];
  }
}

void BeamContributor::StartConfiguration(const State &state, size_t k, Vec3 *positions, Mat3 *triads) const
{
  const BeamElement &element = model_->elements[map_->local_elements[k]];
  for (int a = 0; a <= element.order; ++a) {
    const NodeState &s = state.nodes[map_->node_to_local[element.nodes[a]]];
    positions[a]       = s.position_start;
    triads[a]          = QuaternionToMatrix(s.rotation_start) * element.reference_triads[a];
  }
}

void BeamContributor::BeginStep(const State &state)
{
  midpoint_start_.clear();
  midpoint_start_ok_.clear();
  if (!state.equations.Midpoint()) return;
  midpoint_start_.resize(references_.size());
  midpoint_start_ok_.assign(references_.size(), 0);
  for (size_t k = 0; k < references_.size(); ++k) {
    Vec3 positions[kBeamMaxNodes];
    Mat3 triads[kBeamMaxNodes];
    StartConfiguration(state, k, positions, triads);
    midpoint_start_ok_[k] = BeamMidpointStartState(references_[k], positions, triads, &midpoint_start_[k]) == BeamKernelStatus::Ok;
  }
  if (!(state.equations.Dynamic() && state.equations.scheme.kind == TimeSchemeKind::EnergyMomentum)) return;
  if (kept_.size() != references_.size()) {
    kept_.assign(references_.size(), KeptMidpoint());
    size_t two = 0, three = 0;
    for (size_t k = 0; k < references_.size(); ++k) kept_[k].slot = references_[k].num_nodes == 2 ? (int)two++ : (int)three++;
    kept_two_.resize(two);
    kept_three_.resize(three);
  }
  for (KeptMidpoint &kept : kept_) kept.key = -1;
}

namespace {
// sum += K and Ktp = K^T p for a row-major ND x ND matrix K, in one sweep over K (the size fixed at
// compile time, so that K^T p accumulates in registers: with a run-time size GCC kept it in memory
// and every row waited for the last row's stores; with the pointers free to alias each other it
// kept it scalar, reloading p[i] after every store into sum).
template <int ND> void AddWithTransposeProduct(const double *__restrict K, const double *__restrict p, double *__restrict sum, double *__restrict Ktp)
{
  double accumulated[ND] = {};
  for (int i = 0; i < ND; ++i)
    for (int j = 0; j < ND; ++j) accumulated[j] += K[i * ND + j] * p[i], sum[i * ND + j] += K[i * ND + j];
  for (int j = 0; j < ND; ++j) Ktp[j] = accumulated[j];
}
} // namespace

// Statics and the Newmark family: r and K at t_{n+1}. Mid-point family: the mid-point forces
// F_mc and em's correction F_corr with the pieces of beta (eq. 17-20) and their exact tangents
// (elements/beam.hpp); for em also the gradients of beta's numerator and denominator:
//   W = sum_a u_a.f_a + alpha_a.m_a,  d alpha = S(alpha) d theta,  S(a) = I - hat(a)/2 + a a^T/4,
//   grad W = (f_a, S(alpha_a)^T m_a)_a + K^T p,  p = (u_a, alpha_a)_a,
//   grad(Pi_{n+1} - Pi_n - W_mc) = r_{n+1} - grad W_mc,   grad W_corr.
// Initial-acceleration problem: the start state's forces, which balance inertia and loads; no
// tangent (the unknowns are accelerations).
void BeamContributor::AddElement(const State &state, size_t k, ElementContribution *out)
{
  const BeamElement          &element = model_->elements[map_->local_elements[k]];
  const BeamElementReference &ref     = references_[k];
  const BeamSectionStiffness &section = sections_[element.section];
  const StepEquations        &eq      = state.equations;
  const int                   n = element.order + 1, nd = 6 * n;
  Vec3                        positions[kBeamMaxNodes];
  Mat3                        triads[kBeamMaxNodes];
  const bool                  end_tangent = out->want_tangent && !eq.InitialAcceleration();
  if (eq.Midpoint()) {
    double  force_here[kBeamMaxDofs];
    double *force = force_here;
    Vec3    positions_start[kBeamMaxNodes];
    Mat3    triads_start[kBeamMaxNodes];
    double  correction_here[kBeamMaxDofs], end_residual_here[kBeamMaxDofs], energy_start, energy_end, K_mc[kBeamMaxDofs * kBeamMaxDofs],
        K_corr[kBeamMaxDofs * kBeamMaxDofs];
    // F_corr only where beta weights it (em); mc's kernel skips it.
    const bool    em         = eq.scheme.kind == TimeSchemeKind::EnergyMomentum;
    double       *correction = em ? correction_here : nullptr, *end_residual = end_residual_here;
    const bool    energy_terms = out->want_energy_terms;
    const double *beta         = end_tangent ? out->combined_beta : nullptr; // K_mc + beta K_corr at once
    const bool    K_corr_apart = energy_terms && !beta;
    // The step's start from BeginStep (without it, or where the kernel could not evaluate it there,
    // from the State, so that the kernel reports the failure).
    const BeamMidpointStart *start = k < midpoint_start_ok_.size() && midpoint_start_ok_[k] ? &midpoint_start_[k] : nullptr;
    // em: a residual evaluation keeps what the tangent at the same unknowns needs (kept_), a tangent
    // evaluation with beta known takes it from there when it was kept at these unknowns.
    KeptMidpoint    *kept   = k < kept_.size() && out->iterate_key >= 0 && !eq.InitialAcceleration() ? &kept_[k] : nullptr;
    const bool       reuse  = kept && beta && kept->key == out->iterate_key;
    const bool       keep   = kept && !out->want_tangent && start;
    BeamKernelStatus status = BeamKernelStatus::Ok;
    if (reuse || keep) {
      auto forces_of = [&](auto &record) { force = record.force, correction = record.correction, end_residual = record.end_residual; };
      if (n == 2) forces_of(kept_two_[kept->slot]);
      else forces_of(kept_three_[kept->slot]);
    }
    if (reuse) {
      energy_start = kept->energy_start, energy_end = kept->energy_end;
      if (n == 2) BeamMidpointTangentOfIterate<2>(ref, section, kept_two_[kept->slot].iterate, eq.scheme.energy_correction, beta, K_mc, nullptr);
      else BeamMidpointTangentOfIterate<3>(ref, section, kept_three_[kept->slot].iterate, eq.scheme.energy_correction, beta, K_mc, nullptr);
    } else if (keep) {
      Configuration(state, k, positions, triads);
      kept->key = -1;
      status    = n == 2 ? BeamMidpointResidualKeeping<2>(ref, section, *start, positions, triads, force, correction, end_residual, &energy_start, &energy_end,
                                                       eq.scheme.energy_correction, &kept_two_[kept->slot].iterate)
                         : BeamMidpointResidualKeeping<3>(ref, section, *start, positions, triads, force, correction, end_residual, &energy_start, &energy_end,
                                                       eq.scheme.energy_correction, &kept_three_[kept->slot].iterate);
      if (status == BeamKernelStatus::Ok) kept->energy_start = energy_start, kept->energy_end = energy_end, kept->key = out->iterate_key;
    } else {
      Configuration(state, k, positions, triads);
      if (!start) StartConfiguration(state, k, positions_start, triads_start);
      status = BeamMidpointInternalForces(ref, section, positions_start, triads_start, positions, triads, force, correction, end_tangent ? K_mc : nullptr,
                                          K_corr_apart ? K_corr : nullptr, energy_terms ? end_residual : nullptr, &energy_start, &energy_end,
                                          eq.scheme.energy_correction, beta, start);
    }
    if (status != BeamKernelStatus::Ok) {
      out->evaluable = false;
      return;
    }
    double work = 0.0;
    Vec3   u[kBeamMaxNodes], alpha[kBeamMaxNodes];
    for (int a = 0; a < n; ++a) {
      const NodeState &s     = state.nodes[map_->node_to_local[element.nodes[a]]];
      u[a]                   = s.displacement_increment;
      alpha[a]               = s.tangent_scaled_increment;
      const double node_work = u[a].dot(Vec3(&force[6 * a])) + alpha[a].dot(Vec3(&force[6 * a + 3]));
      work += node_work;
      // The rounding of the work is that of |u| |f|, not of u . f: the forces carry rounding of
      // their magnitude in every direction, and on a beam spinning steadily the increments run
      // across the tension, where u . f ~ 0.
      out->work_scale += u[a].norm() * Vec3(&force[6 * a]).norm() + alpha[a].norm() * Vec3(&force[6 * a + 3]).norm();
      if (correction) out->correction_work += u[a].dot(Vec3(&correction[6 * a])) + alpha[a].dot(Vec3(&correction[6 * a + 3]));
    }
    out->work_mismatch += (energy_end - energy_start) - work;
    out->work_scale += std::abs(energy_start) + std::abs(energy_end); // the difference's rounding
    out->strain_energy += energy_end;
    for (int i = 0; i < nd; ++i) out->residual[i] += force[i];
    if (correction)
      for (int i = 0; i < nd; ++i) out->correction[i] += correction[i];
    if (!(energy_terms && end_tangent)) { // (em's energy terms come with its tangent only)
      if (end_tangent)
        for (int i = 0; i < nd * nd; ++i) out->tangent[i] += K_mc[i];
      return;
    }
    // S(alpha)^T m = m + alpha x m / 2 + alpha (alpha.m) / 4, S(a) = I - hat(a)/2 + a a^T/4
    auto S_transpose_times = [](const Vec3 &a, const Vec3 &m) -> Vec3 { return m + 0.5 * a.cross(m) + (0.25 * a.dot(m)) * a; };
    for (int a = 0; a < n; ++a) {
      const Vec3 m_mc = S_transpose_times(alpha[a], Vec3(&force[6 * a + 3])), m_corr = S_transpose_times(alpha[a], Vec3(&correction[6 * a + 3]));
      for (int i = 0; i < 3; ++i) {
        out->mismatch_gradient[6 * a + i] += end_residual[6 * a + i] - force[6 * a + i];
        out->mismatch_gradient[6 * a + 3 + i] += end_residual[6 * a + 3 + i] - m_mc(i);
        out->correction_work_gradient[6 * a + i] += correction[6 * a + i];
        out->correction_work_gradient[6 * a + 3 + i] += m_corr(i);
      }
    }
    // K^T p, row by row of K, in the same sweep that adds K into the element's tangent (with beta
    // given, K_mc holds K_mc + beta K_corr and K_corr^T p is in it: grad M - beta grad C needs only
    // the sum).
    double p[kBeamMaxDofs], mc[kBeamMaxDofs] = {}, corr[kBeamMaxDofs] = {};
    for (int a = 0; a < n; ++a)
      for (int i = 0; i < 3; ++i) p[6 * a + i] = u[a](i), p[6 * a + 3 + i] = alpha[a](i);
    auto add_and_multiply = n == 2 ? AddWithTransposeProduct<12> : AddWithTransposeProduct<18>;
    add_and_multiply(K_mc, p, out->tangent, mc);
    if (K_corr_apart) add_and_multiply(K_corr, p, out->tangent_correction, corr);
    for (int j = 0; j < nd; ++j) {
      out->mismatch_gradient[j] -= mc[j];
      out->correction_work_gradient[j] += corr[j];
    }
    return;
  }
  double energy = 0.0;
  Configuration(state, k, positions, triads);
  if (BeamAddInternalForces(ref, section, positions, triads, out->residual, end_tangent ? out->tangent : nullptr, &energy) != BeamKernelStatus::Ok) {
    out->evaluable = false;
    return;
  }
  out->strain_energy += energy;
}

void BeamContributor::AddStoredEnergy(const State &state, double *energy) const
{
  double strain_energy = 0.0;
  StrainEnergy(state, &strain_energy);
  *energy += strain_energy;
}

bool BeamContributor::EndPointForces(const State &state, size_t k, double *energy, BeamGaussResults *gauss) const
{
  const BeamElement &element = model_->elements[map_->local_elements[k]];
  Vec3               positions[kBeamMaxNodes];
  Mat3               triads[kBeamMaxNodes];
  double             unused_residual[kBeamMaxDofs];
  Configuration(state, k, positions, triads);
  return BeamInternalForces(references_[k], sections_[element.section], positions, triads, unused_residual, nullptr, energy, gauss) == BeamKernelStatus::Ok;
}

bool BeamContributor::StrainEnergy(const State &state, double *strain_energy) const
{
  bool all_ok    = true;
  *strain_energy = 0.0;
  for (size_t k = 0; k < references_.size(); ++k) {
    double energy = 0.0;
    if (!EndPointForces(state, k, &energy, nullptr)) {
      all_ok = false;
      continue;
    }
    *strain_energy += energy;
  }
  return all_ok;
}

bool BeamContributor::ElementResultOf(const State &state, size_t k, ElementResults *out, double *energy) const
{
  BeamGaussResults gauss;
  *out    = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  *energy = 0.0;
  if (!EndPointForces(state, k, energy, &gauss)) return false;
  // Means over the Gauss points.
  const int ng = references_[k].num_gauss;
  for (int g = 0; g < ng; ++g) {
    out->strain += gauss.strain[g] / ng;
    out->curvature += gauss.curvature[g] / ng;
    out->force += gauss.force[g] / ng;
    out->moment += gauss.moment[g] / ng;
  }
  return true;
}

bool BeamContributor::Results(const State &state, std::vector<ElementResults> *results, double *strain_energy) const
{
  bool all_ok    = true;
  *strain_energy = 0.0;
  results->resize(references_.size());
  for (size_t k = 0; k < references_.size(); ++k) {
    double energy = 0.0;
    if (ElementResultOf(state, k, &(*results)[k], &energy)) *strain_energy += energy;
    else all_ok = false;
  }
  return all_ok;
}

bool BeamContributor::ResultsOf(const State &state, const std::vector<int> &only, std::vector<ElementResults> *results) const
{
  bool all_ok = true;
  results->assign(references_.size(), {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()});
  for (const int k : only) {
    double energy;
    if (!ElementResultOf(state, (size_t)k, &(*results)[(size_t)k], &energy)) all_ok = false;
  }
  return all_ok;
}

bool BeamContributor::EndPointTangent(const State &state, size_t k, double *residual, double *tangent) const
{
  const BeamElement &element = model_->elements[map_->local_elements[k]];
  Vec3               positions[kBeamMaxNodes];
  Mat3               triads[kBeamMaxNodes];
  Configuration(state, k, positions, triads);
  return BeamInternalForces(references_[k], sections_[element.section], positions, triads, residual, tangent, nullptr, nullptr) == BeamKernelStatus::Ok;
}

bool BeamContributor::GaussStrainsOf(const State &state, std::vector<GaussStrains> *strains) const
{
  bool         all_ok = true;
  GaussStrains zero;
  for (int g = 0; g < kBeamMaxGauss; ++g) zero.strain[g].setZero(), zero.curvature[g].setZero();
  strains->assign(references_.size(), zero);
  for (size_t k = 0; k < references_.size(); ++k) {
    const BeamElement &element = model_->elements[map_->local_elements[k]];
    Vec3               positions[kBeamMaxNodes];
    Mat3               triads[kBeamMaxNodes];
    double             r[kBeamMaxDofs];
    BeamGaussResults   gauss;
    Configuration(state, k, positions, triads);
    if (BeamInternalForces(references_[k], sections_[element.section], positions, triads, r, nullptr, nullptr, &gauss) != BeamKernelStatus::Ok) {
      all_ok = false;
      continue;
    }
    for (int g = 0; g < references_[k].num_gauss; ++g) (*strains)[k].strain[g] = gauss.strain[g], (*strains)[k].curvature[g] = gauss.curvature[g];
  }
  return all_ok;
}

void BeamContributor::AddPrestrain(const std::vector<GaussStrains> &prestrain)
{
  if (unstrained_references_.empty()) unstrained_references_ = references_;
  for (size_t k = 0; k < references_.size(); ++k)
    for (int g = 0; g < references_[k].num_gauss; ++g) {
      references_[k].strain0[g] -= prestrain[k].strain[g];
      references_[k].curvature0[g] -= prestrain[k].curvature[g];
    }
}

void BeamContributor::ClearPrestrain()
{
  if (unstrained_references_.empty()) return;
  references_.swap(unstrained_references_);
  unstrained_references_.clear();
}

double BeamContributor::LocalStiffnessSquares() const
{
  double squares = 0.0;
  for (size_t k = 0; k < references_.size(); ++k) {
    const BeamSectionStiffness &c = sections_[model_->elements[map_->local_elements[k]].section];
    const double                L = references_[k].length;
    squares += c.axial_shear.squaredNorm() + c.torsion_bending.squaredNorm() / (L * L);
  }
  return squares;
}

} // namespace msflex
