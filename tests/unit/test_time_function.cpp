// Load and motion functions of time, read from YAML and evaluated: every kind, the ends of a
// table, and the smooth ends of the cosine ramp; the closed-form derivatives against central
// differences and the integrals against Simpson's rule; sums and drives by rate.
#include "io/input_reader.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

using namespace msflex;

namespace {
const char *kModel = R"(
functions:
  - {name: c, type: constant, value: 2.5}
  - {name: l, type: linear, slope: 3, offset: -1}
  - {name: tab, type: table, points: [[0, 0], [1, 2], [3, -2]]}
  - {name: h, type: harmonic, amplitude: 2, frequency: 0.5, phase: 0.25, offset: 1}
  - {name: ramp, type: cosine_ramp, duration: 2, amplitude: 4}
  - {name: p, type: polynomial, coefficients: [1, -2, 0.5]}
  - {name: late_ramp, type: cosine_ramp, duration: 2, amplitude: -3, start: 0.5}
  - {name: early_ramp, type: cosine_ramp, duration: 0.45, amplitude: 2, start: -0.2}
  - {name: still, type: harmonic, amplitude: 2, frequency: 0, phase: 0.25, offset: 1}
  - {name: all, type: sum, terms: [l, tab, h, late_ramp, p]}
nodes:
  a: [0, 0, 0]
rigid_bodies:
  - {node: a, mass: 1, inertia: [1, 1, 1]}
analysis: {type: dynamic}
)";

const TimeFunction &Find(const Model &model, const std::string &name)
{
  for (const TimeFunction &f : model.functions)
    if (f.name == name) return f;
  throw std::runtime_error("no function " + name);
}
} // namespace

TEST(TimeFunction, EveryKindEvaluates)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadModelString(kModel, "functions.yaml", &model, &error)) << error.Format();
  EXPECT_DOUBLE_EQ(Find(model, "c").Evaluate(7.0), 2.5);
  EXPECT_DOUBLE_EQ(Find(model, "l").Evaluate(2.0), 5.0);
  const TimeFunction &table = Find(model, "tab");
  EXPECT_DOUBLE_EQ(table.Evaluate(-1.0), 0.0);
  EXPECT_DOUBLE_EQ(table.Evaluate(0.5), 1.0);
  EXPECT_DOUBLE_EQ(table.Evaluate(2.0), 0.0);
  EXPECT_DOUBLE_EQ(table.Evaluate(5.0), -2.0);
  EXPECT_NEAR(Find(model, "h").Evaluate(0.3), 1.0 + 2.0 * std::sin(2 * M_PI * 0.5 * 0.3 + 0.25), 1e-15);
  const TimeFunction &ramp = Find(model, "ramp");
  EXPECT_DOUBLE_EQ(ramp.Evaluate(-1.0), 0.0);
  EXPECT_NEAR(ramp.Evaluate(1.0), 2.0, 1e-15);
  EXPECT_DOUBLE_EQ(ramp.Evaluate(3.0), 4.0);
  // zero rate at both ends of the ramp
  EXPECT_NEAR((ramp.Evaluate(1e-6) - ramp.Evaluate(0.0)) / 1e-6, 0.0, 1e-5);
  EXPECT_NEAR((ramp.Evaluate(2.0) - ramp.Evaluate(2.0 - 1e-6)) / 1e-6, 0.0, 1e-5);
  EXPECT_NEAR(Find(model, "p").Evaluate(2.0), 1.0 - 4.0 + 2.0, 1e-15);
}

TEST(TimeFunction, CosineRampNeedsAPositiveDuration)
{
  Model             model;
  InputError        error;
  const std::string bad = std::string(kModel).replace(std::string(kModel).find("duration: 2"), 11, "duration: 0");
  EXPECT_FALSE(ReadModelString(bad, "bad.yaml", &model, &error));
  EXPECT_NE(error.message.find("duration"), std::string::npos) << error.Format();
  EXPECT_EQ(error.line, 7);
}

namespace {
int Index(const Model &model, const std::string &name)
{
  for (size_t k = 0; k < model.functions.size(); ++k)
    if (model.functions[k].name == name) return (int)k;
  return -2;
}

// Composite Simpson's rule of f over [0, t] (the kinks of the table and the ramp cost it about
// h^2 times the jump in slope, h = t / 2n).
double Simpson(const std::function<double(double)> &f, double t, int n = 20000)
{
  const double h   = t / (2.0 * n);
  double       sum = f(0.0) + f(t);
  for (int k = 1; k < 2 * n; ++k) sum += (k % 2 ? 4.0 : 2.0) * f(k * h);
  return sum * h / 3.0;
}
} // namespace

// Away from the kinks (table at 0, 1, 3; ramps at 0, 2 and 0.5, 2.5) the closed-form first and
// second derivatives match central differences of the value and of the first derivative, and the
// integral from 0 matches Simpson's rule of the value, for every kind, the sum and the ramp f = t.
TEST(TimeFunction, DerivativesAndIntegralsAreTheClosedForms)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadModelString(kModel, "functions.yaml", &model, &error)) << error.Format();
  std::vector<int> functions{-1};
  for (size_t k = 0; k < model.functions.size(); ++k) functions.push_back((int)k);
  for (const int f : functions) {
    const std::string name = f < 0 ? "ramp f = t" : model.functions[f].name;
    for (const double t : {-0.7, 0.3, 1.4, 2.2, 2.8, 3.6, 4.9}) {
      const double h     = 1e-5;
      const double d1_fd = (FunctionValue(model, f, t + h) - FunctionValue(model, f, t - h)) / (2 * h);
      const double d2_fd = (FunctionDerivative(model, f, t + h, 1) - FunctionDerivative(model, f, t - h, 1)) / (2 * h);
      const double scale = 1.0 + std::abs(FunctionValue(model, f, t));
      EXPECT_NEAR(FunctionDerivative(model, f, t, 1), d1_fd, 1e-8 * scale) << name << " at t = " << t;
      EXPECT_NEAR(FunctionDerivative(model, f, t, 2), d2_fd, 1e-8 * scale) << name << " at t = " << t;
      const double quadrature = Simpson([&](double tau) { return FunctionValue(model, f, tau); }, t);
      EXPECT_NEAR(FunctionIntegral(model, f, t), quadrature, 1e-8 * scale) << name << " at t = " << t;
    }
  }
}

// At a kink the derivatives are those of the coming motion (from the right).
TEST(TimeFunction, DerivativesAtAKinkAreFromTheRight)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadModelString(kModel, "functions.yaml", &model, &error)) << error.Format();
  const int table = Index(model, "tab"), ramp = Index(model, "late_ramp");
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, 0.0, 1), 2.0);  // the segment [0, 1]
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, 1.0, 1), -2.0); // the segment [1, 3]
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, 3.0, 1), 0.0);  // constant after the last point
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, -1.0, 1), 0.0);
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, 2.0, 2), 0.0);
  // The ramp starts at rest with the acceleration A (pi/d)^2 / 2 and ends at rest.
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, ramp, 0.5, 1), 0.0);
  EXPECT_NEAR(FunctionDerivative(model, ramp, 0.5, 2), -3.0 * 0.5 * std::pow(M_PI / 2.0, 2), 1e-14);
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, ramp, 0.4, 2), 0.0);
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, ramp, 2.5, 1), 0.0);
  EXPECT_DOUBLE_EQ(FunctionValue(model, ramp, 2.5), -3.0);
  // Its integral: A (u - d/2) once it is done, u = t - start.
  EXPECT_NEAR(FunctionIntegral(model, ramp, 4.0), -3.0 * (3.5 - 1.0), 1e-14);
}

// At the end of a step the derivatives are those of the step's motion (from the left): a table
// that ends at the run's end keeps its last slope there (it read 0, and spin_up's last row had its
// root at rest), and a ramp's acceleration holds up to its end.
TEST(TimeFunction, DerivativesBeforeAKinkAreFromTheLeft)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadModelString(kModel, "functions.yaml", &model, &error)) << error.Format();
  const int table = Index(model, "tab"), ramp = Index(model, "late_ramp");
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, 1.0, 1, TimeSide::Before), 2.0);  // the segment [0, 1]
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, 3.0, 1, TimeSide::Before), -2.0); // the segment [1, 3]
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, 0.0, 1, TimeSide::Before), 0.0);  // constant before the first point
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, table, 2.0, 1, TimeSide::Before), -2.0); // inside a segment both sides agree
  // The ramp (start 0.5, duration 2): at rest before its start, its deceleration up to its end.
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, ramp, 0.5, 2, TimeSide::Before), 0.0);
  EXPECT_NEAR(FunctionDerivative(model, ramp, 2.5, 2, TimeSide::Before), 3.0 * 0.5 * std::pow(M_PI / 2.0, 2), 1e-14);
  EXPECT_NEAR(FunctionDerivative(model, ramp, 2.5, 1, TimeSide::Before), 0.0, 1e-14);
}

TEST(TimeFunction, SumAddsItsTerms)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadModelString(kModel, "functions.yaml", &model, &error)) << error.Format();
  const int sum = Index(model, "all");
  for (const double t : {-0.5, 0.0, 0.7, 1.0, 2.6, 4.0})
    for (int order = -1; order <= 2; ++order) {
      double expected = 0.0;
      for (const char *term : {"l", "tab", "h", "late_ramp", "p"}) {
        const int f = Index(model, term);
        expected += order == -1 ? FunctionIntegral(model, f, t) : order == 0 ? FunctionValue(model, f, t) : FunctionDerivative(model, f, t, order);
      }
      const double got = order == -1 ? FunctionIntegral(model, sum, t) : order == 0 ? FunctionValue(model, sum, t) : FunctionDerivative(model, sum, t, order);
      EXPECT_NEAR(got, expected, 1e-13 * (1.0 + std::abs(expected))) << "t = " << t << ", order " << order;
    }
}

// A harmonic of frequency 0 is the constant offset + A sin(phase); its integral has no 1/w.
TEST(TimeFunction, HarmonicOfZeroFrequencyIntegrates)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadModelString(kModel, "functions.yaml", &model, &error)) << error.Format();
  const int    still    = Index(model, "still");
  const double constant = 1.0 + 2.0 * std::sin(0.25);
  EXPECT_NEAR(FunctionIntegral(model, still, 3.0), 3.0 * constant, 1e-14);
  EXPECT_DOUBLE_EQ(FunctionDerivative(model, still, 3.0, 1), 0.0);
}

// A ramp that started before 0: its integral is still taken from 0 (a drive by rate starts at q = 0).
TEST(TimeFunction, RampStartedBeforeZeroIntegratesFromZero)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadModelString(kModel, "functions.yaml", &model, &error)) << error.Format();
  const int ramp = Index(model, "early_ramp");
  EXPECT_DOUBLE_EQ(FunctionIntegral(model, ramp, 0.0), 0.0);
  // Done at t = 0.25: the integral from 0 is 2 (t - 0.25) plus the ramp's part over [0, 0.25].
  const double part = Simpson([&](double tau) { return FunctionValue(model, ramp, tau); }, 0.25);
  EXPECT_NEAR(FunctionIntegral(model, ramp, 1.0), 2.0 * 0.75 + part, 1e-12);
}

// A drive by rate: q' = rate f, so q = rate F and q'' = rate f'; a drive by value: q = value f.
TEST(TimeFunction, DriveByRateIntegratesTheFunction)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadModelString(kModel, "functions.yaml", &model, &error)) << error.Format();
  Joint joint;
  joint.drive_value    = 2.5;
  joint.drive_function = Index(model, "late_ramp");
  joint.drive_by_rate  = true;
  for (const double t : {0.0, 0.5, 1.3, 2.5, 7.0}) {
    EXPECT_DOUBLE_EQ(DriveCoordinate(model, joint, t, 0), 2.5 * FunctionIntegral(model, joint.drive_function, t));
    EXPECT_DOUBLE_EQ(DriveCoordinate(model, joint, t, 1), 2.5 * FunctionValue(model, joint.drive_function, t));
    EXPECT_DOUBLE_EQ(DriveCoordinate(model, joint, t, 2), 2.5 * FunctionDerivative(model, joint.drive_function, t, 1));
  }
  joint.drive_by_rate = false;
  EXPECT_DOUBLE_EQ(DriveCoordinate(model, joint, 1.3, 0), 2.5 * FunctionValue(model, joint.drive_function, 1.3));
  EXPECT_DOUBLE_EQ(DriveCoordinate(model, joint, 1.3, 2), 2.5 * FunctionDerivative(model, joint.drive_function, 1.3, 2));
}
