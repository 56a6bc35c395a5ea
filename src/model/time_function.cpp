#include "model/model.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

double TimeFunction::Evaluate(double t) const
{
  switch (kind) {
  case Kind::Constant:
    return offset;
  case Kind::Linear:
    return offset + slope * t;
  case Kind::Harmonic:
    return offset + amplitude * std::sin(2.0 * M_PI * frequency * t + phase);
  case Kind::CosineRamp:
    if (t <= 0.0) return 0.0;
    if (t >= duration) return amplitude;
    return 0.5 * amplitude * (1.0 - std::cos(M_PI * t / duration));
  case Kind::Polynomial: {
    double value = 0.0;
    for (size_t k = values.size(); k-- > 0;) value = value * t + values[k]; // Horner
    return value;
  }
  case Kind::Table: {
    if (times.empty()) return 0.0;
    if (t <= times.front()) return values.front();
    if (t >= times.back()) return values.back();
    const auto   it = std::upper_bound(times.begin(), times.end(), t);
    const size_t i  = (size_t)(it - times.begin());
    const double s  = (t - times[i - 1]) / (times[i] - times[i - 1]);
    return (1.0 - s) * values[i - 1] + s * values[i];
  }
  }
  return 0.0;
}

double FunctionValue(const Model &model, int function, double t) { return function < 0 ? t : model.functions[function].Evaluate(t); }

double FunctionDerivative(const Model &model, int function, double t, int order)
{
  const double h  = 1e-4 * std::max(1.0, std::abs(t));
  const double f0 = FunctionValue(model, function, t), f1 = FunctionValue(model, function, t + h), f2 = FunctionValue(model, function, t + 2 * h);
  if (order == 1) return (-3.0 * f0 + 4.0 * f1 - f2) / (2.0 * h);
  const double f3 = FunctionValue(model, function, t + 3 * h);
  return (2.0 * f0 - 5.0 * f1 + 4.0 * f2 - f3) / (h * h);
}

} // namespace msflex
