#include "contributors/beam_damping_contributor.hpp"

#include "elements/beam_rates.hpp"

namespace msflex {

void BeamDampingContributor::Setup(const Model &model, const DofMap &map, const BeamContributor &beams)
{
  model_ = &model;
  map_   = &map;
  beams_ = &beams;
  damping_.clear();
  for (const Section &section : model.sections) damping_.push_back({section.damping_axial_shear, section.damping_torsion_bending});
  damped_.assign(map.local_elements.size(), 0);
  any_damped_ = false;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    damped_[k]  = model.sections[model.elements[map.local_elements[k]].section].Damped() ? 1 : 0;
    any_damped_ = any_damped_ || damped_[k];
  }
  for (auto *start : {&start_strain_, &start_curvature_, &start_strain_rate_, &start_curvature_rate_})
    start->assign(map.local_elements.size(), {Vec3::Zero(), Vec3::Zero()});
}

double BeamDampingContributor::LocalDampingRoundoffSquares() const
{
  double squares = 0.0;
  for (size_t k = 0; k < damped_.size(); ++k) {
    if (!damped_[k]) continue;
    const BeamSectionStiffness &c = damping_[model_->elements[map_->local_elements[k]].section];
    const double                L = beams_->References()[k].length;
    squares += c.axial_shear.squaredNorm() + c.torsion_bending.squaredNorm() / (L * L);
  }
  return squares;
}

bool BeamDampingContributor::Strains(const State &state, size_t k, bool start, Vec3 *strain, Vec3 *curvature) const
{
  Vec3 positions[kBeamMaxNodes], zero[kBeamMaxNodes], rate[kBeamMaxGauss], curvature_rate[kBeamMaxGauss];
  Mat3 triads[kBeamMaxNodes];
  if (start) beams_->StartConfiguration(state, k, positions, triads);
  else beams_->Configuration(state, k, positions, triads);
  for (Vec3 &v : zero) v.setZero();
  return BeamStrainRates(beams_->References()[k], positions, triads, zero, zero, strain, curvature, rate, curvature_rate) == BeamKernelStatus::Ok;
}

// A committed strain motion with the rate a step starts from (BeginStep).
static MotionState WithRate(MotionState motion, const Vec3 &rate)
{
  motion.velocity = rate;
  return motion;
}

// e'(t_n) of the strains at the last three step starts, second order (BDF2 with steps
// h1 = t_n - t_{n-1}, h0 = t_{n-1} - t_{n-2}, w = h1/h0):
//   e'_n = [(1 + 2w)/(1 + w) e_n - (1 + w) e_{n-1} + w^2/(1 + w) e_{n-2}] / h1.
static Vec3 StrainRateFromHistory(const Vec3 &e_n, const Vec3 &e_1, const Vec3 &e_2, double h1, double h0)
{
  const double w = h1 / h0;
  return ((1.0 + 2.0 * w) / (1.0 + w) * e_n - (1.0 + w) * e_1 + w * w / (1.0 + w) * e_2) / h1;
}

void BeamDampingContributor::BeginStep(const State &state)
{
  const StepEquations &eq = state.equations;
  if (!any_damped_ || !eq.Dynamic() || eq.Midpoint()) return;
  for (size_t k = 0; k < damped_.size(); ++k) {
    if (!damped_[k]) continue;
    const BeamStrainMotion &motion    = state.beam_strains[k];
    const bool              evaluable = Strains(state, k, true, start_strain_[k].data(), start_curvature_[k].data());
    const bool              history   = evaluable && motion.previous_count >= 2; // else the recursion's rate (Forces reports an element it cannot evaluate)
    for (int gp = 0; gp < kBeamMaxGauss; ++gp) {
      start_strain_rate_[k][gp]    = history ? StrainRateFromHistory(start_strain_[k][gp], motion.previous_strain[0][gp], motion.previous_strain[1][gp],
                                                                     motion.previous_steps[0], motion.previous_steps[1])
                                             : motion.strain[gp].velocity;
      start_curvature_rate_[k][gp] = history ? StrainRateFromHistory(start_curvature_[k][gp], motion.previous_curvature[0][gp],
                                                                     motion.previous_curvature[1][gp], motion.previous_steps[0], motion.previous_steps[1])
                                             : motion.curvature[gp].velocity;
    }
  }
}

bool BeamDampingContributor::StartForces(const State &state, size_t k, double *force) const
{
  // C_d edot_n at the start state: the stress C_d (e - (e_n - edot_n)) at e = e_n, with edot_n the
  // committed strain rates (State::beam_strains, not yet advanced within the step).
  const BeamElement          &element = model_->elements[map_->local_elements[k]];
  const BeamSectionStiffness &C       = damping_[element.section];
  const BeamElementReference &ref     = beams_->References()[k];
  const BeamStrainMotion     &motion  = state.beam_strains[k];
  BeamElementReference        shifted = ref;
  Vec3                        positions[kBeamMaxNodes], strain[kBeamMaxGauss], curvature[kBeamMaxGauss];
  Mat3                        triads[kBeamMaxNodes];
  beams_->StartConfiguration(state, k, positions, triads);
  // A step of the Newmark family has the start strains from BeginStep; the initial accelerations
  // (no such step) evaluate them here.
  const StepEquations &eq    = state.equations;
  const bool           known = eq.NewmarkFamily();
  if (!known && !Strains(state, k, true, strain, curvature)) return false;
  // The committed rates, not the step's start rates (BeginStep): this is the force that held the
  // equations at t_n, so that the trapezoidal sum of the damping's work keeps the Newmark energy
  // identity (linear regime: T + V + that sum constant to round-off).
  const Vec3 *e_n = known ? start_strain_[k].data() : strain, *k_n = known ? start_curvature_[k].data() : curvature;
  // The mid-point schemes keep no strain motion (their damping takes e_{n+1} - e_n): in the
  // initial-acceleration problem of their consistent reactions after a step, the rates are the
  // BDF2 derivative of the strains at this and the last two step starts (the history CommitStep
  // keeps for them too), or the last step's difference after one step. Not the rates of the nodes'
  // velocities: the mid-point velocity recursion v_{n+1} = 2 u/dt - v_n does not damp the mode -1
  // of a stiff damped strain, and neither choice leaves the error of the initial rates (a damped
  // cantilever's root reaction was 3.6 N off at every step size).
  Vec3 rate[kBeamMaxGauss], curvature_rate[kBeamMaxGauss];
  for (int gp = 0; gp < kBeamMaxGauss; ++gp) rate[gp] = motion.strain[gp].velocity, curvature_rate[gp] = motion.curvature[gp].velocity;
  if (IsMidpointScheme(model_->analysis.integrator) && eq.InitialAcceleration() && motion.previous_count > 0) {
    for (int gp = 0; gp < ref.num_gauss; ++gp) {
      const Vec3 &e_0 = motion.previous_strain[0][gp], &k_0 = motion.previous_curvature[0][gp];
      if (motion.previous_count >= 2) {
        rate[gp]           = StrainRateFromHistory(e_n[gp], e_0, motion.previous_strain[1][gp], motion.previous_steps[0], motion.previous_steps[1]);
        curvature_rate[gp] = StrainRateFromHistory(k_n[gp], k_0, motion.previous_curvature[1][gp], motion.previous_steps[0], motion.previous_steps[1]);
      } else {
        // After the first step: the trapezoidal rate from the initial one (the motion's rate,
        // which the mid-point schemes keep from t = 0), second order; the difference alone lagged
        // by half a step (13 % of a kicked beam's first-row reaction).
        rate[gp]           = 2.0 * (e_n[gp] - e_0) / motion.previous_steps[0] - motion.strain[gp].velocity;
        curvature_rate[gp] = 2.0 * (k_n[gp] - k_0) / motion.previous_steps[0] - motion.curvature[gp].velocity;
      }
    }
  }
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    shifted.strain0[gp] += e_n[gp] - rate[gp];
    shifted.curvature0[gp] += k_n[gp] - curvature_rate[gp];
  }
  return BeamInternalForces(shifted, C, positions, triads, force, nullptr, nullptr, nullptr) == BeamKernelStatus::Ok;
}

bool BeamDampingContributor::Forces(const State &state, size_t k, double *force, double *tangent) const
{
  const StepEquations        &eq      = state.equations;
  const BeamElement          &element = model_->elements[map_->local_elements[k]];
  const BeamSectionStiffness &C       = damping_[element.section];
  const BeamElementReference &ref     = beams_->References()[k];
  Vec3                        positions[kBeamMaxNodes];
  Mat3                        triads[kBeamMaxNodes];
  if (eq.Midpoint()) {
    Vec3   positions_start[kBeamMaxNodes];
    Mat3   triads_start[kBeamMaxNodes];
    double force_mc[kBeamMaxDofs], energy_start, energy_end;
    beams_->StartConfiguration(state, k, positions_start, triads_start);
    beams_->Configuration(state, k, positions, triads);
    const double               dt = eq.scheme.dt;
    const BeamSectionStiffness scaled{C.axial_shear / dt, C.torsion_bending / dt};
    // The damping force is the kernel's correction vector with C_d/dt: T*^T D^T C_d (e_{n+1} - e_n)/dt,
    // and its exact tangent is K_corr.
    return BeamMidpointInternalForces(ref, scaled, positions_start, triads_start, positions, triads, force_mc, force, nullptr, tangent, nullptr, &energy_start,
                                      &energy_end) == BeamKernelStatus::Ok;
  }
  if (eq.InitialAcceleration()) return StartForces(state, k, force);
  // edot_{n+1} = c_v (e_{n+1} - e_n) + edot*: the stress c_v C_d (e - (e_n - edot*/c_v)).
  BeamElementReference shifted = ref;
  beams_->Configuration(state, k, positions, triads);
  const double               cv = eq.scheme.VelocityCoefficient();
  const BeamSectionStiffness section{cv * C.axial_shear, cv * C.torsion_bending};
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    const Vec3 strain_rate    = AdvanceMotion(eq.scheme, WithRate(state.beam_strains[k].strain[gp], start_strain_rate_[k][gp]), Vec3::Zero()).velocity;
    const Vec3 curvature_rate = AdvanceMotion(eq.scheme, WithRate(state.beam_strains[k].curvature[gp], start_curvature_rate_[k][gp]), Vec3::Zero()).velocity;
    shifted.strain0[gp] += start_strain_[k][gp] - strain_rate / cv;
    shifted.curvature0[gp] += start_curvature_[k][gp] - curvature_rate / cv;
  }
  return BeamInternalForces(shifted, section, positions, triads, force, tangent, nullptr, nullptr) == BeamKernelStatus::Ok;
}

void BeamDampingContributor::AddElement(const State &state, size_t k, ElementContribution *out)
{
  if (!damped_[k] || !state.equations.Inertial()) return;
  double     force[kBeamMaxDofs], K[kBeamMaxDofs * kBeamMaxDofs];
  const bool tangent = out->want_tangent && !state.equations.InitialAcceleration();
  if (!Forces(state, k, force, tangent ? K : nullptr)) {
    out->evaluable = false;
    return;
  }
  const int nd = 6 * out->num_nodes;
  for (int i = 0; i < nd; ++i) out->residual[i] += force[i];
  if (tangent)
    for (int i = 0; i < nd * nd; ++i) out->tangent[i] += K[i];
}

// Mid-point family: the damping force of the step's equations times the increments (exact).
// Newmark family: the trapezoidal rule, the mean of the start state's damping force and the end's
// times the same increments, as for the force elements' dampers and the loads.
void BeamDampingContributor::AddStepDissipation(const State &state, double *dissipation) const
{
  const StepEquations &eq = state.equations;
  if (!eq.Dynamic()) return;
  const bool trapezoidal = eq.NewmarkFamily();
  for (size_t k = 0; k < damped_.size(); ++k) {
    if (!damped_[k]) continue;
    double force[kBeamMaxDofs], start[kBeamMaxDofs];
    if (!Forces(state, k, force, nullptr)) continue;
    const BeamElement &element = model_->elements[map_->local_elements[k]];
    const int          nd      = 6 * (element.order + 1);
    if (trapezoidal && StartForces(state, k, start))
      for (int i = 0; i < nd; ++i) force[i] = 0.5 * (start[i] + force[i]);
    for (int a = 0; a <= element.order; ++a) {
      const NodeState &s = state.nodes[map_->node_to_local[element.nodes[a]]];
      *dissipation += s.displacement_increment.dot(Vec3(&force[6 * a])) + NodeTangentScaledIncrement(eq, s).dot(Vec3(&force[6 * a + 3]));
    }
  }
}

void BeamDampingContributor::StartMotion(State *state)
{
  if (!any_damped_ || model_->analysis.type != AnalysisType::Dynamic) return;
  for (size_t k = 0; k < damped_.size(); ++k) {
    if (!damped_[k]) continue;
    const BeamElement &element = model_->elements[map_->local_elements[k]];
    Vec3               positions[kBeamMaxNodes], v[kBeamMaxNodes], w[kBeamMaxNodes], a[kBeamMaxNodes], wdot[kBeamMaxNodes];
    Mat3               triads[kBeamMaxNodes];
    beams_->StartConfiguration(*state, k, positions, triads);
    for (int n = 0; n <= element.order; ++n) {
      const NodeState &s = state->nodes[map_->node_to_local[element.nodes[n]]];
      const Mat3       R = QuaternionToMatrix(s.rotation_start);
      v[n] = s.translation_motion.velocity, w[n] = R * s.rotation_motion.velocity;
      a[n] = s.translation_motion.acceleration, wdot[n] = R * s.rotation_motion.acceleration; // d(R W)/dt = R Wdot + w x w
    }
    Vec3              strain[kBeamMaxGauss], curvature[kBeamMaxGauss], rate[kBeamMaxGauss], curvature_rate[kBeamMaxGauss];
    Vec3              acceleration[kBeamMaxGauss], curvature_acceleration[kBeamMaxGauss];
    BeamStrainMotion &motion = state->beam_strains[k];
    motion.previous_count    = 0; // the motion starts here
    if (BeamStrainRates(beams_->References()[k], positions, triads, v, w, strain, curvature, rate, curvature_rate) != BeamKernelStatus::Ok ||
        BeamStrainAccelerations(beams_->References()[k], positions, triads, v, w, a, wdot, acceleration, curvature_acceleration) != BeamKernelStatus::Ok)
      continue;
    for (int gp = 0; gp < beams_->References()[k].num_gauss; ++gp) {
      motion.strain[gp]    = {rate[gp], acceleration[gp], acceleration[gp]};
      motion.curvature[gp] = {curvature_rate[gp], curvature_acceleration[gp], curvature_acceleration[gp]};
    }
  }
}

void BeamDampingContributor::CommitStep(State *state)
{
  // Only the Newmark family carries the strains' motion (the mid-point schemes' damping takes
  // e_{n+1} - e_n alone, and they keep the strains' history for the consistent reactions); the
  // start strains are BeginStep's.
  const StepEquations &eq = state->equations;
  if (!any_damped_ || !eq.Dynamic()) return;
  if (eq.Midpoint()) {
    // The strains at the step's start join the history alone (the consistent reactions' rates,
    // StartForces).
    for (size_t k = 0; k < damped_.size(); ++k) {
      Vec3 e_n[kBeamMaxGauss], k_n[kBeamMaxGauss];
      if (!damped_[k] || !Strains(*state, k, true, e_n, k_n)) continue;
      BeamStrainMotion &motion = state->beam_strains[k];
      for (int gp = 0; gp < beams_->References()[k].num_gauss; ++gp) {
        motion.previous_strain[1][gp] = motion.previous_strain[0][gp], motion.previous_strain[0][gp] = e_n[gp];
        motion.previous_curvature[1][gp] = motion.previous_curvature[0][gp], motion.previous_curvature[0][gp] = k_n[gp];
      }
      motion.previous_steps[1] = motion.previous_steps[0], motion.previous_steps[0] = eq.scheme.dt;
      motion.previous_count = std::min(motion.previous_count + 1, 2);
    }
    return;
  }
  for (size_t k = 0; k < damped_.size(); ++k) {
    if (!damped_[k]) continue;
    Vec3 strain[kBeamMaxGauss], curvature[kBeamMaxGauss];
    if (!Strains(*state, k, false, strain, curvature)) continue;
    BeamStrainMotion &motion = state->beam_strains[k];
    for (int gp = 0; gp < beams_->References()[k].num_gauss; ++gp) {
      const Vec3        &e_n = start_strain_[k][gp], &k_n = start_curvature_[k][gp];
      const MotionUpdate s = AdvanceMotion(eq.scheme, WithRate(motion.strain[gp], start_strain_rate_[k][gp]), strain[gp] - e_n);
      const MotionUpdate c = AdvanceMotion(eq.scheme, WithRate(motion.curvature[gp], start_curvature_rate_[k][gp]), curvature[gp] - k_n);
      motion.strain[gp]    = {s.velocity, s.acceleration, s.pseudo_acceleration};
      motion.curvature[gp] = {c.velocity, c.acceleration, c.pseudo_acceleration};
      // The step's start strains join the history of the next steps' start rates.
      motion.previous_strain[1][gp] = motion.previous_strain[0][gp], motion.previous_strain[0][gp] = e_n;
      motion.previous_curvature[1][gp] = motion.previous_curvature[0][gp], motion.previous_curvature[0][gp] = k_n;
    }
    motion.previous_steps[1] = motion.previous_steps[0], motion.previous_steps[0] = eq.scheme.dt;
    motion.previous_count = std::min(motion.previous_count + 1, 2);
  }
}

} // namespace msflex
