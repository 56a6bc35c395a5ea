#include "schemes/time_scheme.hpp"

#include <cmath>

namespace msflex {

namespace {
const IntegratorInfo kIntegrators[] = {
    {"newmark", TimeSchemeKind::Newmark, "trapezoidal Newmark on SO(3) (beta = 1/4, gamma = 1/2); conserves neither energy nor momenta in general"},
    {"genalpha", TimeSchemeKind::GeneralizedAlpha, "Lie-group generalized-alpha with spectral radius rho_infinity (spectral_radius): damps high frequencies"},
    {"mc", TimeSchemeKind::MomentumConserving, "mid-point momentum-conserving scheme (eq. 17): conserves linear and angular momentum"},
    {"em", TimeSchemeKind::EnergyMomentum, "energy-momentum scheme (eq. 18-20): conserves energy and momenta, with joints in place"},
};
} // namespace

const IntegratorInfo *Integrators(int *count)
{
  *count = (int)(sizeof(kIntegrators) / sizeof(kIntegrators[0]));
  return kIntegrators;
}

bool TimeSchemeKindFromName(const std::string &name, TimeSchemeKind *kind)
{
  for (const IntegratorInfo &info : kIntegrators)
    if (name == info.name) {
      *kind = info.kind;
      return true;
    }
  return false;
}

const char *TimeSchemeName(TimeSchemeKind kind)
{
  for (const IntegratorInfo &info : kIntegrators)
    if (info.kind == kind) return info.name;
  return "?";
}

std::string IntegratorNameList()
{
  std::string list;
  for (const IntegratorInfo &info : kIntegrators) list += (list.empty() ? "" : ", ") + std::string(info.name);
  return list;
}

bool EnergyCorrectionFromName(const std::string &name, EnergyCorrection *correction)
{
  if (name == "resultants") *correction = EnergyCorrection::Resultants;
  else if (name == "forces") *correction = EnergyCorrection::Forces;
  else return false;
  return true;
}

const char *EnergyCorrectionName(EnergyCorrection correction) { return correction == EnergyCorrection::Forces ? "forces" : "resultants"; }

TimeScheme MakeTimeScheme(TimeSchemeKind kind, double spectral_radius, double dt)
{
  TimeScheme s;
  s.kind = kind;
  s.dt   = dt;
  if (kind == TimeSchemeKind::GeneralizedAlpha) {
    const double rho = spectral_radius;
    s.alpha_m        = (2.0 * rho - 1.0) / (rho + 1.0);
    s.alpha_f        = rho / (rho + 1.0);
    s.gamma          = 0.5 + s.alpha_f - s.alpha_m;
    s.beta           = 0.25 * (s.gamma + 0.5) * (s.gamma + 0.5);
  }
  return s;
}

double TimeScheme::InertiaCoefficient() const
{
  if (Midpoint()) return 2.0 / (dt * dt);
  return (1.0 - alpha_m) / ((1.0 - alpha_f) * beta * dt * dt);
}

double TimeScheme::VelocityCoefficient() const
{
  if (Midpoint()) return 2.0 / dt;
  return gamma / (beta * dt);
}

MotionUpdate AdvanceMotion(const TimeScheme &s, const MotionState &start, const Vec3 &increment)
{
  MotionUpdate next;
  const double dt = s.dt;
  if (s.Midpoint()) {
    next.velocity            = 2.0 * increment / dt - start.velocity;
    next.acceleration        = (next.velocity - start.velocity) / dt;
    next.pseudo_acceleration = next.acceleration;
    return next;
  }
  next.pseudo_acceleration = (increment - dt * start.velocity - dt * dt * (0.5 - s.beta) * start.pseudo_acceleration) / (s.beta * dt * dt);
  next.velocity            = start.velocity + dt * ((1.0 - s.gamma) * start.pseudo_acceleration + s.gamma * next.pseudo_acceleration);
  next.acceleration =
      ((1.0 - s.alpha_m) * next.pseudo_acceleration + s.alpha_m * start.pseudo_acceleration - s.alpha_f * start.acceleration) / (1.0 - s.alpha_f);
  return next;
}

namespace {
// Below this angle f and f'/t come from their Taylor series: the closed form of f'/t cancels.
constexpr double kScaledSeriesAngle = 1e-3;

// f(t) = 2 tan(t/2)/t, alpha = f omega, d alpha = f I + (f'(t)/t) omega omega^T, with
// f'(t) = (sec^2(t/2) - f)/t and sec^2(t/2) = 1 + tan^2(t/2) = 1 + x f^2/4 (x = t^2).
void ScaledIncrementFrom(const Vec3 &omega, double x, double f, Vec3 *alpha, Mat3 *dalpha_domega)
{
  double fprime_over_t;
  if (x < kScaledSeriesAngle * kScaledSeriesAngle) {
    f             = 1.0 + x / 12.0 + x * x / 120.0 + x * x * x * 17.0 / 20160.0;
    fprime_over_t = 1.0 / 6.0 + x / 30.0 + x * x * 17.0 / 3360.0;
  } else {
    fprime_over_t = (1.0 + 0.25 * x * f * f - f) / x;
  }
  *alpha = f * omega;
  if (dalpha_domega) {
    Mat3 &d = *dalpha_domega;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) d(i, j) = fprime_over_t * omega(i) * omega(j);
    d(0, 0) += f, d(1, 1) += f, d(2, 2) += f;
  }
}
} // namespace

void TangentScaledIncrement(const Vec3 &omega, Vec3 *alpha, Mat3 *dalpha_domega)
{
  const double x    = omega.squaredNorm();
  const double half = 0.5 * std::sqrt(x);
  const double f    = x < kScaledSeriesAngle * kScaledSeriesAngle ? 1.0 : std::tan(half) / half;
  ScaledIncrementFrom(omega, x, f, alpha, dalpha_domega);
}

void TangentScaledIncrement(const Vec3 &omega, double c1, double c2, Vec3 *alpha, Mat3 *dalpha_domega)
{
  ScaledIncrementFrom(omega, omega.squaredNorm(), 2.0 * c2 / c1, alpha, dalpha_domega);
}

} // namespace msflex
