// Functions of (pseudo-)time, their derivatives and their integrals from 0, all in closed form:
//   constant   f = c                          F = c t
//   linear     f = o + s t                    F = o t + s t^2 / 2
//   harmonic   f = o + A sin(w t + p)         F = o t + A (cos p - cos(w t + p)) / w,  w = 2 pi nu
//   ramp       f = A (1 - cos(pi u / d)) / 2  G(u) = A (u - d sin(pi u / d) / pi) / 2 for u = t - start
//                                               in [0, d); A (u - d / 2) after, 0 before;
//                                               F = G(t - start) - G(-start)
//   polynomial f = sum c_k t^k                F = sum c_k t^(k+1) / (k + 1)
//   table      f piecewise linear             F piecewise quadratic (the trapezoidal rule per segment)
// F(t) = integral of f from 0 to t; derivatives at a kink are taken from the right.
#include "model/model.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

namespace {

// The table's integral from its first time to t (negative for t before it): f is values.front()
// before the first point and values.back() after the last.
double TableIntegralFromFirst(const TimeFunction &f, double t)
{
  const std::vector<double> &T = f.times, &V = f.values;
  if (t <= T.front()) return (t - T.front()) * V.front();
  double integral = 0.0;
  for (size_t i = 1; i < T.size(); ++i) {
    if (t <= T[i]) {
      const double s = (t - T[i - 1]) / (T[i] - T[i - 1]), value = (1.0 - s) * V[i - 1] + s * V[i];
      return integral + 0.5 * (t - T[i - 1]) * (V[i - 1] + value);
    }
    integral += 0.5 * (T[i] - T[i - 1]) * (V[i - 1] + V[i]);
  }
  return integral + (t - T.back()) * V.back();
}

double Table(const TimeFunction &f, double t, int order, TimeSide side)
{
  const std::vector<double> &T = f.times, &V = f.values;
  if (T.empty()) return 0.0;
  if (order == -1) return TableIntegralFromFirst(f, t) - TableIntegralFromFirst(f, 0.0);
  if (order == 2) return 0.0;
  // The segment holding t, [T[i-1], T[i]) after t or (T[i-1], T[i]] before it; before the first
  // point or beyond the last one, f is constant.
  const bool before = side == TimeSide::Before && order > 0;
  if (before ? t <= T.front() || t > T.back() : t < T.front() || t >= T.back()) return order == 0 ? (t < T.front() ? V.front() : V.back()) : 0.0;
  const size_t i     = (size_t)((before ? std::lower_bound(T.begin(), T.end(), t) : std::upper_bound(T.begin(), T.end(), t)) - T.begin());
  const double slope = (V[i] - V[i - 1]) / (T[i] - T[i - 1]);
  return order == 1 ? slope : V[i - 1] + slope * (t - T[i - 1]);
}

// The ramp's integral from its start to start + u.
double CosineRampIntegralFromStart(const TimeFunction &f, double u)
{
  const double d = f.duration, A = f.amplitude, k = M_PI / d;
  if (u <= 0.0) return 0.0;
  if (u >= d) return A * (u - 0.5 * d);
  return 0.5 * A * (u - std::sin(k * u) / k);
}

double CosineRamp(const TimeFunction &f, double t, int order, TimeSide side)
{
  const double u = t - f.start, d = f.duration, A = f.amplitude, k = M_PI / d;
  // From 0, not from the start, which may lie before 0.
  if (order == -1) return CosineRampIntegralFromStart(f, u) - CosineRampIntegralFromStart(f, -f.start);
  // The ramp holds [0, d) after t, (0, d] before it (its second derivative jumps at both ends).
  const bool before = side == TimeSide::Before && order > 0;
  if (before ? u <= 0.0 : u < 0.0) return 0.0;
  if (before ? u > d : u >= d) return order == 0 ? A : 0.0;
  switch (order) {
  case 0:
    return 0.5 * A * (1.0 - std::cos(k * u));
  case 1:
    return 0.5 * A * k * std::sin(k * u);
  default:
    return 0.5 * A * k * k * std::cos(k * u);
  }
}

double Harmonic(const TimeFunction &f, double t, int order)
{
  const double w = 2.0 * M_PI * f.frequency, angle = w * t + f.phase;
  switch (order) {
  case -1:
    // (cos p - cos(w t + p)) / w = 2 sin(w t / 2) sin(w t / 2 + p) / w, which tends to t sin p as w -> 0
    return f.offset * t + f.amplitude * (w == 0.0 ? t * std::sin(f.phase) : 2.0 * std::sin(0.5 * w * t) * std::sin(0.5 * w * t + f.phase) / w);
  case 0:
    return f.offset + f.amplitude * std::sin(angle);
  case 1:
    return f.amplitude * w * std::cos(angle);
  default:
    return -f.amplitude * w * w * std::sin(angle);
  }
}

double Polynomial(const TimeFunction &f, double t, int order)
{
  // Horner's rule on the coefficients of the integral or derivative: c_k t^k -> c_k t^(k+1)/(k+1),
  // k c_k t^(k-1), k (k-1) c_k t^(k-2).
  double value = 0.0;
  if (order == -1) {
    for (size_t k = f.values.size(); k-- > 0;) value = value * t + f.values[k] / (double)(k + 1);
    return value * t;
  }
  for (size_t k = f.values.size(); k-- > (size_t)order;) {
    double factor = 1.0;
    for (int m = 0; m < order; ++m) factor *= (double)(k - (size_t)m);
    value = value * t + factor * f.values[k];
  }
  return value;
}

// Function `index` of `functions` (-1: the ramp f(t) = t) at order -1 (integral from 0), 0, 1, 2.
double FunctionAt(const std::vector<TimeFunction> &functions, int index, double t, int order, TimeSide side = TimeSide::After)
{
  if (index < 0) return order == -1 ? 0.5 * t * t : order == 0 ? t : order == 1 ? 1.0 : 0.0;
  const TimeFunction &f = functions[index];
  if (f.kind != TimeFunction::Kind::Sum) return f.Evaluate(t, order, side);
  double sum = 0.0;
  for (const int term : f.terms) sum += FunctionAt(functions, term, t, order, side); // terms come before (the reader checks)
  return sum;
}

} // namespace

double TimeFunction::Evaluate(double t, int order, TimeSide side) const
{
  switch (kind) {
  case Kind::Constant:
    return order == -1 ? offset * t : order == 0 ? offset : 0.0;
  case Kind::Linear:
    return order == -1 ? (offset + 0.5 * slope * t) * t : order == 0 ? offset + slope * t : order == 1 ? slope : 0.0;
  case Kind::Harmonic:
    return Harmonic(*this, t, order);
  case Kind::CosineRamp:
    return CosineRamp(*this, t, order, side);
  case Kind::Polynomial:
    return Polynomial(*this, t, order);
  case Kind::Table:
    return Table(*this, t, order, side);
  case Kind::Sum:
    break; // needs the other functions: FunctionAt
  }
  return std::nan("");
}

double FunctionValue(const Model &model, int function, double t) { return FunctionAt(model.functions, function, t, 0); }

double FunctionDerivative(const Model &model, int function, double t, int order, TimeSide side)
{
  return FunctionAt(model.functions, function, t, order, side);
}

double FunctionIntegral(const Model &model, int function, double t) { return FunctionAt(model.functions, function, t, -1); }

double PrescribedMotion(const Model &model, int function, bool by_rate, double t, int order, TimeSide side)
{
  return FunctionAt(model.functions, function, t, by_rate ? order - 1 : order, side);
}

double DriveCoordinate(const Model &model, const Joint &joint, double t, int order, TimeSide side)
{
  return joint.drive_value * PrescribedMotion(model, joint.drive_function, joint.drive_by_rate, t, order, side);
}

} // namespace msflex
