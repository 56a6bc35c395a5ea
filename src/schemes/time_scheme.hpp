// Time-stepping schemes as coefficients handed to the kernels (the kernels never hard-code a
// scheme). Two families:
//
// Newmark family (newmark, genalpha; Arnold & Brüls 2007 on the Lie group, Simo & Vu-Quoc 1988
// for Newmark): with the increment Delta over the step (u for translations, the material
// incremental rotation Theta = Lambda_n^T omega for rotations), pseudo-acceleration a, velocity v
// and true acceleration vdot,
//   a_{n+1}    = (Delta - dt v_n - dt^2 (1/2 - beta) a_n) / (beta dt^2)
//   v_{n+1}    = v_n + dt ((1 - gamma) a_n + gamma a_{n+1})
//   vdot_{n+1} = ((1 - alpha_m) a_{n+1} + alpha_m a_n - alpha_f vdot_n) / (1 - alpha_f)
// and the equations of motion hold at t_{n+1}. Newmark (beta = 1/4, gamma = 1/2) is the case
// alpha_m = alpha_f = 0; genalpha takes alpha_m = (2 rho - 1)/(rho + 1), alpha_f = rho/(rho + 1),
// gamma = 1/2 + alpha_f - alpha_m, beta = (gamma + 1/2)^2 / 4 from the spectral radius rho.
//
// Mid-point family (mc, em; Muñoz, Jelenić & Crisfield 2003 §4): translations
// x_{n+1} - x_n = dt (v_n + v_{n+1})/2, rotations Lambda_{n+1} = cay(alpha) Lambda_n with the
// tangent-scaled increment alpha = Lambda_n dt (W_n + W_{n+1})/2, and the balance of momenta
// (p_{n+1} - p_n)/dt = mid-point forces. Virtual work is taken with the test vector (u, alpha),
// so that kinetic energy changes by exactly u.F + alpha.M over a step.
#pragma once

#include "math/rotation.hpp"

#include <string>

namespace msflex {

enum class TimeSchemeKind { Newmark, GeneralizedAlpha, MomentumConserving, EnergyMomentum };

// The energy-momentum scheme's correction vector (eq. 18-19): from the whole stress difference
// (N_d, M_d) of a step (Resultants, msflex's default) or from the force resultants alone (N_d, 0)
// as the paper writes it (Forces); docs/dynamics.md compares them.
enum class EnergyCorrection { Resultants, Forces };
// Parses "resultants" or "forces"; false for anything else.
bool        EnergyCorrectionFromName(const std::string &name, EnergyCorrection *correction);
const char *EnergyCorrectionName(EnergyCorrection correction);

// mc and em: the mid-point family (see above).
inline bool IsMidpointScheme(TimeSchemeKind kind) { return kind == TimeSchemeKind::MomentumConserving || kind == TimeSchemeKind::EnergyMomentum; }

struct TimeScheme {
  TimeSchemeKind   kind = TimeSchemeKind::Newmark;
  double           dt   = 0.0;
  double           beta = 0.25, gamma = 0.5, alpha_m = 0.0, alpha_f = 0.0; // Newmark family only
  EnergyCorrection energy_correction = EnergyCorrection::Resultants;       // em only

  bool Midpoint() const { return IsMidpointScheme(kind); }
  // d(inertial acceleration)/d(increment): vdot_{n+1} for the Newmark family, (v_{n+1} - v_n)/dt
  // for the mid-point family.
  double InertiaCoefficient() const;
  // d v_{n+1} / d(increment).
  double VelocityCoefficient() const;
};

// The registry of integrators: the one place that names them, read by the input reader, the
// options, -help and the documentation test.
struct IntegratorInfo {
  const char    *name;
  TimeSchemeKind kind;
  const char    *description;
};
const IntegratorInfo *Integrators(int *count);
// Parses a registered name; false for anything else.
bool        TimeSchemeKindFromName(const std::string &name, TimeSchemeKind *kind);
const char *TimeSchemeName(TimeSchemeKind kind);
// "newmark, genalpha, mc, em": the registered names, for messages.
std::string IntegratorNameList();
TimeScheme  MakeTimeScheme(TimeSchemeKind kind, double spectral_radius, double dt);

// Kinematic state of one vector DOF group (translation, or rotation in the material frame) at the
// start of a step, and the values at the end that a given increment implies.
struct MotionState {
  Vec3 velocity            = Vec3::Zero();
  Vec3 acceleration        = Vec3::Zero(); // true acceleration vdot
  Vec3 pseudo_acceleration = Vec3::Zero(); // the Newmark family's a
};
struct MotionUpdate {
  Vec3 velocity            = Vec3::Zero(); // v_{n+1}
  Vec3 acceleration        = Vec3::Zero(); // vdot_{n+1} (Newmark family) or (v_{n+1} - v_n)/dt (mid-point)
  Vec3 pseudo_acceleration = Vec3::Zero(); // a_{n+1} (Newmark family), equal to acceleration for the mid-point family
};
// For the mid-point family `increment` is u, or the material tangent-scaled increment
// theta = Lambda_n^T alpha for rotations (then theta = dt (W_n + W_{n+1})/2).
MotionUpdate AdvanceMotion(const TimeScheme &scheme, const MotionState &start, const Vec3 &increment);

// a = 2 tan(|omega|/2) omega/|omega| and its derivative d a / d omega.
void TangentScaledIncrement(const Vec3 &omega, Vec3 *alpha, Mat3 *dalpha_domega);
// The same from the rotation series c1 = sin(t)/t and c2 = (1 - cos t)/t^2 at x = t^2 = |omega|^2,
// which the node update has already evaluated (math/rotation.hpp): tan(t/2) = t c2/c1, so the
// factor 2 tan(t/2)/t is 2 c2/c1 without a call of tan (the node update runs per node and iterate).
void TangentScaledIncrement(const Vec3 &omega, double c1, double c2, Vec3 *alpha, Mat3 *dalpha_domega);

} // namespace msflex
