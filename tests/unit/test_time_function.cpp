// Load and motion functions of time, read from YAML and evaluated: every kind, the ends of a
// table, and the smooth ends of the cosine ramp.
#include "io/input_reader.hpp"

#include <gtest/gtest.h>

#include <cmath>

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
