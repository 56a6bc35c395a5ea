// Structural damping of the beams: viscous section forces on the strain rates,
//   (N_d, M_d) = C_d (Gammadot, Kdot),   C_d = diag(damping of the section)
// acting through the same strain operator as the elastic forces (elements/beam.hpp), so that their
// virtual work is the dissipation C_d edot . edot integrated over the element.
//
// Per scheme:
//  - Newmark family: the strains of each Gauss point are advanced with the scheme's own update,
//    as one more "displacement" of the scheme (State::beam_strains): edot_{n+1} = c_v (e_{n+1} - e_n)
//    + edot* (edot* from the history), so the damping stress is c_v C_d (e - e~) with the shifted
//    reference strain e~ = e_n - edot*/c_v: the internal-force kernel itself with the section
//    stiffness c_v C_d gives the force and its exact tangent. The start values are the exact strain
//    rates of the initial velocities and the strain accelerations of the initial motion
//    (elements/beam_rates.hpp). From the third step on, a step starts from the second-order
//    derivative of the strains at the last three step starts (BDF2, State::beam_strains' history)
//    instead of the rate the recursion carried: the recursion of a strain (trapezoidal:
//    edot_{n+1} = 2 (e_{n+1} - e_n)/dt - edot_n) has the mode edot_{n+1} = -edot_n, which no
//    equation holds, and on a spinning beam, whose operator turns from step to step, the damping
//    forces of that mode fed energy in until the run blew up (a beam spinning at 10 rad/s about a
//    hinge, damping_time 2 ms: kinetic energy 16.7 -> 1070 J in 2 s under newmark). A rate from
//    the strains alone is zero for any rigid motion (rates from the nodes' velocities were not:
//    a driven node's exact rate beside its neighbours' algorithmic ones made a damping moment
//    that did work against the drive), and with Newmark's trapezoidal rule the scheme is stable
//    for every omega dt and damping ratio (spectral radius <= 1, checked on the linear oscillator).
//  - mid-point family: the stress C_d (e_{n+1} - e_n)/dt through the mid-point map, i.e. the
//    correction vector of the mid-point kernel with the section C_d / dt; its work over (u, alpha)
//    is the step's dissipation, which the energy balance counts.
//  - initial-acceleration problem: C_d edot_0 at the start state (no tangent).
// The step's dissipation: mid-point family, the damping force of the step's equations times the
// increments (exact); Newmark family, the trapezoidal rule, the mean of the start state's damping
// force C_d edot_n and the end's times the increments (as for the force elements and the loads).
// The tangent of the mid-point form is the end-point one of the stress C_d (e - e_n)/dt (exact
// once the mid-point kernel's tangent is available to it).
#pragma once

#include "contributors/beam_contributor.hpp"

#include <array>
#include <vector>

namespace msflex {

class BeamDampingContributor : public ForceContributor {
public:
  void        Setup(const Model &model, const DofMap &map, const BeamContributor &beams);
  const char *Name() const override { return "beam structural damping"; }
  bool        Empty() const { return !any_damped_; }

  void BeginStep(const State &state) override;
  bool ActsOnElements() const override { return any_damped_; }
  void AddElement(const State &state, size_t k, ElementContribution *out) override;
  void AddStepDissipation(const State &state, double *dissipation) const override;
  // C_d's strain terms and its curvature terms over the element length (as the stiffness's).
  double LocalDampingRoundoffSquares() const override;
  void   StartMotion(State *state) override;
  void   CommitStep(State *state) override;

private:
  // The damping forces of local element k (6 per node) and, on request, their tangent; false when
  // the element cannot be evaluated.
  bool Forces(const State &state, size_t k, double *force, double *tangent) const;
  // The damping forces of local element k at the start of the step (start configuration, C_d edot_n
  // with edot_n the committed strain rates; no tangent): the initial-acceleration problem's, and the
  // start point of the Newmark family's trapezoidal dissipation. False when not evaluable.
  bool StartForces(const State &state, size_t k, double *force) const;
  // Strains and curvatures of local element k at the Gauss points of its current (or start) configuration.
  bool Strains(const State &state, size_t k, bool start, Vec3 *strain, Vec3 *curvature) const;

  const Model                      *model_      = nullptr;
  const DofMap                     *map_        = nullptr;
  const BeamContributor            *beams_      = nullptr;
  bool                              any_damped_ = false;
  std::vector<char>                 damped_;  // per local element
  std::vector<BeamSectionStiffness> damping_; // per section: C_d
  // Newmark family, per local element and Gauss point: the strains at the start of the step and
  // the rates the step starts from (BeginStep).
  std::vector<std::array<Vec3, 2>> start_strain_, start_curvature_, start_strain_rate_, start_curvature_rate_;
};

} // namespace msflex
