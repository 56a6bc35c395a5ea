// The registries (analysis types, integrators, joint kinds) are the one place that names these
// choices: every registered name round-trips through its parser, is accepted by the input reader,
// and is documented (docs/input.md for analysis types and integrators, docs/joints.md for joint
// kinds); and the reader's messages list exactly the registered names.
#include "io/input_reader.hpp"
#include "model/analysis_types.hpp"
#include "model/joint_kinds.hpp"
#include "schemes/time_scheme.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

using namespace msflex;

namespace {

std::string ReadDoc(const std::string &name)
{
  std::ifstream     in(std::string(MSFLEX_DOCS_DIR) + "/" + name);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

const char *kBeam = R"(
sections:
  - {name: s, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5, rhoA: 1.0, rhoJ: [0.1, 0.05, 0.05]}
nodes: {a: [0, 0, 0], b: [1, 0, 0]}
beams:
  - {name: rod, section: s, from: a, to: b, elements: 2}
supports:
  - {nodes: a, fix: all}
)";

} // namespace

TEST(Registries, AnalysisTypesRoundTripAreReadAndDocumented)
{
  int                     count;
  const AnalysisTypeInfo *types = AnalysisTypes(&count);
  ASSERT_GE(count, 2);
  const std::string doc = ReadDoc("input.md");
  for (int i = 0; i < count; ++i) {
    AnalysisType parsed;
    ASSERT_TRUE(AnalysisTypeFromName(types[i].name, &parsed)) << types[i].name;
    EXPECT_EQ(parsed, types[i].type);
    EXPECT_STREQ(AnalysisTypeName(types[i].type), types[i].name);
    EXPECT_NE(doc.find(std::string("`") + types[i].name + "`"), std::string::npos) << types[i].name << " is not in docs/input.md";
    Model      model;
    InputError error;
    EXPECT_TRUE(ReadModelString(std::string(kBeam) + "analysis: {type: " + types[i].name + "}\n", "registry", &model, &error)) << error.Format();
    EXPECT_EQ(model.analysis.type, types[i].type);
  }
  AnalysisType unused;
  EXPECT_FALSE(AnalysisTypeFromName("modal", &unused));
}

TEST(Registries, IntegratorsRoundTripAreReadAndDocumented)
{
  int                   count;
  const IntegratorInfo *integrators = Integrators(&count);
  ASSERT_GE(count, 4);
  const std::string doc = ReadDoc("input.md");
  for (int i = 0; i < count; ++i) {
    TimeSchemeKind parsed;
    ASSERT_TRUE(TimeSchemeKindFromName(integrators[i].name, &parsed)) << integrators[i].name;
    EXPECT_EQ(parsed, integrators[i].kind);
    EXPECT_STREQ(TimeSchemeName(integrators[i].kind), integrators[i].name);
    EXPECT_NE(doc.find(std::string("`") + integrators[i].name + "`"), std::string::npos) << integrators[i].name << " is not in docs/input.md";
    Model      model;
    InputError error;
    EXPECT_TRUE(ReadModelString(std::string(kBeam) + "analysis: {type: dynamic, integrator: " + integrators[i].name + "}\n", "registry", &model, &error))
        << error.Format();
    EXPECT_EQ(model.analysis.integrator, integrators[i].kind);
  }
  Model      model;
  InputError error;
  EXPECT_FALSE(ReadModelString(std::string(kBeam) + "analysis: {type: dynamic, integrator: rk4}\n", "registry", &model, &error));
  EXPECT_NE(error.message.find("expected one of " + IntegratorNameList()), std::string::npos) << error.message;
}

TEST(Registries, PathControlsRoundTripAreReadAndDocumented)
{
  int                    count;
  const PathControlInfo *controls = PathControls(&count);
  ASSERT_GE(count, 3);
  const std::string doc = ReadDoc("input.md") + ReadDoc("stability.md");
  for (int i = 0; i < count; ++i) {
    PathControl parsed;
    ASSERT_TRUE(PathControlFromName(controls[i].name, &parsed)) << controls[i].name;
    EXPECT_EQ(parsed, controls[i].control);
    EXPECT_STREQ(PathControlName(controls[i].control), controls[i].name);
    EXPECT_NE(doc.find(std::string("`control: ") + controls[i].name + "`"), std::string::npos) << controls[i].name << " is not in docs/stability.md";
    const std::string target = controls[i].control == PathControl::Displacement ? ", control_node: b, control_dof: uy" : "";
    Model             model;
    InputError        error;
    EXPECT_TRUE(ReadModelString(std::string(kBeam) + "analysis: {control: " + controls[i].name + target + "}\n", "registry", &model, &error)) << error.Format();
    EXPECT_EQ(model.analysis.control, controls[i].control);
  }
  Model      model;
  InputError error;
  EXPECT_FALSE(ReadModelString(std::string(kBeam) + "analysis: {control: riks}\n", "registry", &model, &error));
  EXPECT_NE(error.message.find("expected one of " + PathControlNameList()), std::string::npos) << error.message;
}

TEST(Registries, JointKindsRoundTripAndAreDocumented)
{
  int                  count;
  const JointKindInfo *kinds = JointKinds(&count);
  ASSERT_GE(count, 13);
  const std::string doc = ReadDoc("joints.md");
  for (int i = 0; i < count; ++i) {
    const JointKindInfo *found = JointKindFind(kinds[i].name);
    ASSERT_NE(found, nullptr) << kinds[i].name;
    EXPECT_EQ(found->kind, kinds[i].kind);
    EXPECT_STREQ(JointKindName(kinds[i].kind), kinds[i].name);
    EXPECT_EQ(&JointKindInfoOf(kinds[i].kind), &kinds[i]);
    EXPECT_NE(doc.find(std::string("| `") + kinds[i].name + "` |"), std::string::npos) << kinds[i].name << " is not in the table of docs/joints.md";
    // The releases are consistent: a dependent translation needs exactly one rotation.
    if (kinds[i].dependence != JointDependence::None) EXPECT_EQ(kinds[i].num_rotations, 1) << kinds[i].name;
  }
  EXPECT_EQ(JointKindFind("hinge"), nullptr);
  Model             model;
  InputError        error;
  const std::string joint = "joints:\n  - {name: j, type: hinge, master: ground, slave: b}\n";
  EXPECT_FALSE(ReadModelString(std::string(kBeam) + joint, "registry", &model, &error));
  EXPECT_NE(error.message.find("expected one of " + JointKindNameList()), std::string::npos) << error.message;
}
