// Tests of the YAML model reader: expansion of valid models, HDF5 mesh files, and the bad-input corpus in
// tests/bad_input/ (each file states the expected message and line in its first two lines).
#include "io/input_reader.hpp"
#include "joints/joint_kinematics.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#ifndef MSFLEX_BAD_INPUT_DIR
#error "MSFLEX_BAD_INPUT_DIR must name the tests/bad_input directory"
#endif

namespace msflex {
namespace {

constexpr double kTolerance = 1e-12;

Model ReadValid(const std::string &text)
{
  Model      model;
  InputError error;
  EXPECT_TRUE(ReadModelString(text, "valid.yaml", &model, &error)) << error.Format();
  return model;
}

InputError ReadInvalid(const std::string &text)
{
  Model      model;
  InputError error;
  EXPECT_FALSE(ReadModelString(text, "invalid.yaml", &model, &error));
  return error;
}

int NodeIndex(const Model &model, const std::string &name)
{
  for (size_t index = 0; index < model.nodes.size(); ++index)
    if (model.nodes[index].name == name) return static_cast<int>(index);
  ADD_FAILURE() << "no node " << name;
  return -1;
}

void ExpectOrthonormal(const Mat3 &triad)
{
  EXPECT_LT((triad.transpose() * triad - Mat3::Identity()).norm(), 1e-12);
  EXPECT_NEAR(triad.determinant(), 1.0, 1e-12);
}

const char *const kFullModel = R"(title: Everything once
functions:
  - {name: ramp2, type: linear, slope: 2, offset: 0.5}
  - {name: hold, type: constant, value: 3}
  - {name: cycle, type: table, points: [[0, 0], [1, 1], [2, 0]]}
  - {name: shake, type: harmonic, amplitude: 2, frequency: 0.5}
sections:
  - {name: steel, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5, rhoA: 7.8, rhoJ: [0.1, 0.05, 0.05]}
nodes:
  root: [0, 0, 0]
  tip: [10, 0, 0]
beams:
  - {name: arm, section: steel, from: root, to: tip, elements: 4}
sets:
  ends: [root, tip, root]
  everything: [arm]
supports:
  - {nodes: root, fix: all}
  - nodes: [tip]
    prescribe: {ux: 0.5, rz: 1.0}
    function: cycle
loads:
  - {nodes: ends, force: [0, 0, 600], follower: true, function: shake}
  - {gravity: [0, 0, -9.81]}
  - {beams: arm, distributed: [0, 0, -10], function: hold}
probes:
  - {name: middle, node: arm.2}
analysis:
  end_time: 2.0
  initial_step: 0.05
  min_step: 1.0e-4
  output_times: [0.5, 2.0]
output:
  every: 3
)";

TEST(InputReader, FullModelIsReadCompletely)
{
  const Model model = ReadValid(kFullModel);
  EXPECT_EQ(model.input_file, "valid.yaml");
  EXPECT_EQ(model.input_text, kFullModel);

  ASSERT_EQ(model.functions.size(), 4u);
  EXPECT_EQ(model.functions[0].kind, TimeFunction::Kind::Linear);
  EXPECT_DOUBLE_EQ(model.functions[0].Evaluate(1.0), 2.5);
  EXPECT_EQ(model.functions[1].kind, TimeFunction::Kind::Constant);
  EXPECT_DOUBLE_EQ(model.functions[1].Evaluate(7.0), 3.0);
  EXPECT_EQ(model.functions[2].kind, TimeFunction::Kind::Table);
  EXPECT_DOUBLE_EQ(model.functions[2].Evaluate(1.5), 0.5);
  EXPECT_EQ(model.functions[3].kind, TimeFunction::Kind::Harmonic);
  EXPECT_NEAR(model.functions[3].Evaluate(0.5), 2.0, 1e-12);

  ASSERT_EQ(model.sections.size(), 1u);
  EXPECT_DOUBLE_EQ(model.sections[0].GA2, 4.0e6);
  EXPECT_DOUBLE_EQ(model.sections[0].rhoA, 7.8);
  EXPECT_DOUBLE_EQ(model.sections[0].rhoJ(1), 0.05);

  // 2 named nodes + 3 interior nodes, 4 two-node elements.
  ASSERT_EQ(model.nodes.size(), 5u);
  ASSERT_EQ(model.elements.size(), 4u);
  ASSERT_EQ(model.beams.size(), 1u);
  EXPECT_EQ(model.beams[0].nodes, (std::vector<int>{0, 2, 3, 4, 1}));
  EXPECT_EQ(model.nodes[3].name, "arm.2");
  EXPECT_LT((model.nodes[3].position - Vec3(5, 0, 0)).norm(), kTolerance);
  EXPECT_EQ(model.nodes[3].mark.line, 13);
  EXPECT_EQ(model.elements[1].nodes, (std::array<int, 3>{{2, 3, -1}}));
  EXPECT_EQ(model.elements[1].beam, 0);

  ASSERT_EQ(model.node_sets.size(), 2u);
  EXPECT_EQ(model.node_sets[0].nodes, (std::vector<int>{0, 1}));
  EXPECT_EQ(model.node_sets[1].nodes, model.beams[0].nodes);

  ASSERT_EQ(model.supports.size(), 2u);
  for (Support::Kind kind : model.supports[0].kind) EXPECT_EQ(kind, Support::Kind::Fixed);
  EXPECT_EQ(model.supports[0].function, -1);
  EXPECT_EQ(model.supports[1].nodes, (std::vector<int>{1}));
  EXPECT_EQ(model.supports[1].kind[DOF_UX], Support::Kind::Prescribed);
  EXPECT_EQ(model.supports[1].kind[DOF_UY], Support::Kind::Free);
  EXPECT_DOUBLE_EQ(model.supports[1].values[DOF_RZ], 1.0);
  EXPECT_EQ(model.supports[1].function, 2);
  EXPECT_EQ(model.supports[1].mark.line, 19);

  ASSERT_EQ(model.nodal_loads.size(), 1u);
  EXPECT_EQ(model.nodal_loads[0].nodes, (std::vector<int>{0, 1}));
  EXPECT_TRUE(model.nodal_loads[0].follower);
  EXPECT_DOUBLE_EQ(model.nodal_loads[0].force(2), 600.0);
  EXPECT_EQ(model.nodal_loads[0].function, 3);
  ASSERT_EQ(model.distributed_loads.size(), 2u);
  EXPECT_TRUE(model.distributed_loads[0].gravity);
  EXPECT_EQ(model.distributed_loads[0].elements, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(model.distributed_loads[0].function, -1);
  EXPECT_FALSE(model.distributed_loads[1].gravity);
  EXPECT_DOUBLE_EQ(model.distributed_loads[1].force_per_length(2), -10.0);
  EXPECT_EQ(model.distributed_loads[1].function, 1);

  ASSERT_EQ(model.probes.size(), 1u);
  EXPECT_EQ(model.probes[0].node, 3);

  EXPECT_DOUBLE_EQ(model.analysis.end_time, 2.0);
  EXPECT_DOUBLE_EQ(model.analysis.min_step, 1.0e-4);
  EXPECT_DOUBLE_EQ(model.analysis.max_step, 1.0);
  EXPECT_EQ(model.analysis.max_newton_iterations, 25);
  EXPECT_EQ(model.analysis.output_times, (std::vector<double>{0.5, 2.0}));
  EXPECT_EQ(model.output.file, "valid.h5");
  EXPECT_EQ(model.output.every, 3);
}

const char *const kLineHead = R"(sections:
  - {name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}
nodes:
  a: [1, 2, 3]
  b: [1, 2, 7]
supports:
  - {nodes: a, fix: all}
beams:
)";

TEST(InputReader, LineBeamTriadsFollowOrientationRollAndTwist)
{
  const Model model =
      ReadValid(std::string(kLineHead) + "  - {name: line, section: s, from: a, to: b, elements: 2, orientation: [1, 1, 0], roll: 0.3, twist: 0.4}\n");
  ASSERT_EQ(model.elements.size(), 2u);
  const Vec3 t1 = Vec3::UnitZ();
  const Vec3 t2 = Vec3(1, 1, 0).normalized();
  for (int element = 0; element < 2; ++element)
    for (int a = 0; a < 2; ++a) {
      const Mat3  &triad = model.elements[element].reference_triads[a];
      const double angle = 0.3 + 0.4 * 0.5 * (element + a); // fraction s/L = (element + a) / 2
      ExpectOrthonormal(triad);
      EXPECT_LT((triad.col(0) - t1).norm(), kTolerance);
      EXPECT_LT((triad.col(1) - (std::cos(angle) * t2 + std::sin(angle) * t1.cross(t2))).norm(), kTolerance);
    }
}

TEST(InputReader, DefaultOrientationAvoidsVerticalAxis)
{
  const std::string head  = R"(sections:
  - {name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}
nodes: {a: [0, 0, 0], b: [0, 3, 0], c: [4, 0, 0]}
supports: [{nodes: a, fix: all}]
beams:
  - {name: up, section: s, from: a, to: b, elements: 1}
  - {name: along, section: s, from: a, to: c, elements: 1}
)";
  const Model       model = ReadValid(head);
  EXPECT_LT((model.elements[0].reference_triads[0].col(1) - Vec3(-1, 0, 0)).norm(), kTolerance);
  EXPECT_LT((model.elements[1].reference_triads[0].col(1) - Vec3(0, 1, 0)).norm(), kTolerance);
  EXPECT_LT((model.elements[1].reference_triads[1].col(2) - Vec3(0, 0, 1)).norm(), kTolerance);
}

TEST(InputReader, OrderTwoPutsMiddleNodeInTheMiddle)
{
  const Model model = ReadValid(std::string(kLineHead) + "  - {name: quad, section: s, from: a, to: b, elements: 3, order: 2}\n");
  // 3 elements of order 2: 7 nodes along the beam, 5 of them generated.
  ASSERT_EQ(model.nodes.size(), 7u);
  ASSERT_EQ(model.elements.size(), 3u);
  EXPECT_EQ(model.beams[0].order, 2);
  for (const BeamElement &element : model.elements) {
    EXPECT_EQ(element.order, 2);
    for (int node : element.nodes) ASSERT_GE(node, 0);
    const Vec3 midpoint = 0.5 * (model.nodes[element.nodes[0]].position + model.nodes[element.nodes[2]].position);
    EXPECT_LT((model.nodes[element.nodes[1]].position - midpoint).norm(), kTolerance);
  }
  EXPECT_EQ(model.elements[0].nodes[0], NodeIndex(model, "a"));
  EXPECT_EQ(model.elements[2].nodes[2], NodeIndex(model, "b"));
  EXPECT_EQ(model.elements[1].nodes[1], NodeIndex(model, "quad.3"));
}

TEST(InputReader, ArcNodesAndTriads)
{
  const double      radius = 100.0;
  const std::string text   = R"(sections:
  - {name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}
nodes:
  start: [0, 0, 0]
  end: [100, 100, 0]
beams:
  - name: bend
    section: s
    from: start
    to: end
    elements: 8
    order: 2
    arc: {center: [0, 100, 0]}
supports:
  - {nodes: start, fix: all}
)";
  const Model       model  = ReadValid(text);
  const Vec3        center(0, 100, 0);
  ASSERT_EQ(model.nodes.size(), 17u);
  ASSERT_EQ(model.elements.size(), 8u);
  const std::vector<int> &chain = model.beams[0].nodes;
  ASSERT_EQ(chain.size(), 17u);
  for (size_t k = 0; k < chain.size(); ++k) {
    // The default normal (from - c) x (to - c) is +z: a quarter circle counter-clockwise about z.
    const double angle    = 0.5 * M_PI * static_cast<double>(k) / 16.0;
    const Vec3   expected = center + radius * Vec3(std::sin(angle), -std::cos(angle), 0.0);
    EXPECT_LT((model.nodes[chain[k]].position - expected).norm(), 1e-9) << "node " << k;
  }
  for (const BeamElement &element : model.elements)
    for (int a = 0; a < 3; ++a) {
      const Mat3 &triad    = element.reference_triads[a];
      const Vec3 &position = model.nodes[element.nodes[a]].position;
      ExpectOrthonormal(triad);
      const Vec3 to_center = (center - position).normalized();
      EXPECT_LT((triad.col(1) - to_center).norm(), 1e-12);
      EXPECT_LT((triad.col(0) - Vec3::UnitZ().cross(-to_center)).norm(), 1e-12); // tangent, direction of travel
      EXPECT_LT((triad.col(2) - triad.col(0).cross(triad.col(1))).norm(), 1e-12);
      EXPECT_LT((triad.col(2) - Vec3::UnitZ()).norm(), 1e-12);
    }
}

TEST(InputReader, ArcWithNormalRunsTheLongWay)
{
  // Counter-clockwise about -z from (0, 0) to (100, 100) around (0, 100) is three quarters of a turn.
  const std::string text  = R"(sections:
  - {name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}
nodes: {start: [0, 0, 0], end: [100, 100, 0]}
beams:
  - {name: loop, section: s, from: start, to: end, elements: 3, arc: {center: [0, 100, 0], normal: [0, 0, -1]}}
supports: [{nodes: [start, end], fix: all}]
)";
  const Model       model = ReadValid(text);
  // After a quarter turn clockwise about z the beam is at (-100, 100).
  EXPECT_LT((model.nodes[NodeIndex(model, "loop.1")].position - Vec3(-100, 100, 0)).norm(), 1e-9);
  EXPECT_LT((model.nodes[NodeIndex(model, "loop.2")].position - Vec3(0, 200, 0)).norm(), 1e-9);
  EXPECT_LT((model.elements[0].reference_triads[0].col(2) - Vec3(0, 0, -1)).norm(), 1e-12);
}

TEST(InputReader, GeneratedCountsForSeveralBeams)
{
  const std::string text  = R"(sections:
  - {name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}
nodes: {a: [0, 0, 0], b: [1, 0, 0], c: [1, 1, 0]}
beams:
  - {name: first, section: s, from: a, to: b, elements: 5}
  - {name: second, section: s, from: b, to: c, elements: 4, order: 2}
  - {name: branch, section: s, from: second.3, to: a, elements: 2}
supports: [{nodes: a, fix: all}]
)";
  const Model       model = ReadValid(text);
  // 3 named + 4 + 7 + 1 generated nodes; 5 + 4 + 2 elements.
  EXPECT_EQ(model.nodes.size(), 15u);
  EXPECT_EQ(model.elements.size(), 11u);
  EXPECT_EQ(model.beams[1].elements, (std::vector<int>{5, 6, 7, 8}));
  EXPECT_EQ(model.beams[2].nodes.front(), NodeIndex(model, "second.3"));
}

TEST(InputReader, DefaultsAndOutputName)
{
  const std::string text = R"(sections: [{name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}]
nodes: {a: [0, 0, 0], b: [1, 0, 0]}
beams: [{name: only, section: s, from: a, to: b, elements: 1}]
supports: [{nodes: only, fix: [ux, uy, uz, rx, ry, rz]}]
loads:
)";
  Model             model;
  InputError        error;
  ASSERT_TRUE(ReadModelString(text, "input/dir.v2/roll.yaml", &model, &error)) << error.Format();
  EXPECT_EQ(model.output.file, "roll.h5");
  EXPECT_EQ(model.output.every, 1);
  EXPECT_EQ(model.analysis.type, AnalysisType::Static);
  EXPECT_EQ(model.analysis.integrator, TimeSchemeKind::EnergyMomentum);
  EXPECT_DOUBLE_EQ(model.analysis.spectral_radius, 0.9);
  EXPECT_DOUBLE_EQ(model.analysis.initial_step, 0.1);
  EXPECT_TRUE(model.rigid_bodies.empty());
  EXPECT_TRUE(model.initial_conditions.empty());
  EXPECT_DOUBLE_EQ(model.sections[0].rhoA, 0.0);
  EXPECT_EQ(model.sections[0].rhoJ, Vec3::Zero());
  EXPECT_TRUE(model.functions.empty());
  EXPECT_TRUE(model.nodal_loads.empty());
  EXPECT_EQ(model.elements[0].order, 1);
  EXPECT_EQ(model.elements[0].nodes[2], -1);
}

TEST(InputReader, SupportsAcrossABeamRestrainAllModes)
{
  // Pinned translations at two nodes leave the rotation about the line through them free; a
  // third pinned node off that line (via a second beam) removes it.
  const std::string head  = R"(sections: [{name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}]
nodes: {a: [0, 0, 0], b: [1, 0, 0], c: [1, 1, 0]}
beams:
  - {name: ab, section: s, from: a, to: b, elements: 2}
  - {name: bc, section: s, from: b, to: c, elements: 2}
)";
  const InputError  error = ReadInvalid(head + "supports: [{nodes: [a, b], fix: [ux, uy, uz]}]\n");
  EXPECT_NE(error.message.find("mechanism: beam(s) 'ab', 'bc' can move as a rigid body (5 of 6"), std::string::npos) << error.message;
  EXPECT_EQ(error.line, 4);
  ReadValid(head + "supports: [{nodes: [a, b, c], fix: [ux, uy, uz]}]\n");
}

// A free-flying dynamic model: no supports (no mechanism check outside statics), a section
// given by density and geometry, rigid bodies with diagonal and full inertia, and initial
// conditions of both kinds.
const char *const kDynamicModel = R"(sections:
  - {name: al, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5,
     density: 2700, area: 1.0e-3, I2: 2.0e-7, I3: 5.0e-7}
nodes:
  root: [0, 0, 0]
  tip: [2, 0, 0]
  pod: [1, 1, 0]
beams:
  - {name: arm, section: al, from: root, to: tip, elements: 4}
rigid_bodies:
  - node: tip
    mass: 40
    inertia: [0.2, 0.225, 0.225]
  - node: arm.2
    mass: 3
    inertia:
      - [0.5, 0.1, 0]
      - [0.1, 0.4, 0]
      - [0, 0, 0.3]
    offset: [0, 0.1, -0.05]
  - {node: pod, mass: 1.5, inertia: [[0, 0, 0], [0, 0, 0], [0, 0, 0]]}
initial_conditions:
  - nodes: root
    velocity: [1, 0, 0]
  - nodes: [arm.1, arm.2, arm.3, tip]
    velocity: [0, 0, 1]
    angular_velocity: [0, 0, 2]
    rigid_body_center: [0.5, 0, 0]
  - {nodes: pod, angular_velocity: [3, 0, 0]}
analysis:
  type: dynamic
  integrator: genalpha
  spectral_radius: 0.6
  end_time: 0.5
  initial_step: 1.0e-3
  max_step: 0.01
)";

TEST(InputReader, DynamicModelWithRigidBodiesAndInitialConditions)
{
  const Model model = ReadValid(kDynamicModel);
  EXPECT_EQ(model.analysis.type, AnalysisType::Dynamic);
  EXPECT_EQ(model.analysis.integrator, TimeSchemeKind::GeneralizedAlpha);
  EXPECT_DOUBLE_EQ(model.analysis.spectral_radius, 0.6);
  EXPECT_DOUBLE_EQ(model.analysis.end_time, 0.5);
  EXPECT_DOUBLE_EQ(model.analysis.initial_step, 1.0e-3);
  EXPECT_DOUBLE_EQ(model.analysis.max_step, 0.01);
  EXPECT_TRUE(model.supports.empty());

  // rhoA = density * area, rhoJ = density * (I2 + I3, I2, I3).
  ASSERT_EQ(model.sections.size(), 1u);
  EXPECT_NEAR(model.sections[0].rhoA, 2.7, 1e-12);
  EXPECT_NEAR(model.sections[0].rhoJ(0), 1.89e-3, 1e-15);
  EXPECT_NEAR(model.sections[0].rhoJ(1), 5.4e-4, 1e-15);
  EXPECT_NEAR(model.sections[0].rhoJ(2), 1.35e-3, 1e-15);

  ASSERT_EQ(model.rigid_bodies.size(), 3u);
  const RigidBody &tip = model.rigid_bodies[0];
  EXPECT_EQ(tip.node, NodeIndex(model, "tip"));
  EXPECT_DOUBLE_EQ(tip.mass, 40.0);
  EXPECT_EQ(tip.inertia, Vec3(0.2, 0.225, 0.225).asDiagonal().toDenseMatrix());
  EXPECT_EQ(tip.offset, Vec3::Zero());
  EXPECT_EQ(tip.mark.line, 11);
  const RigidBody &middle = model.rigid_bodies[1];
  EXPECT_EQ(middle.node, NodeIndex(model, "arm.2"));
  EXPECT_DOUBLE_EQ(middle.mass, 3.0);
  Mat3 full;
  full << 0.5, 0.1, 0, 0.1, 0.4, 0, 0, 0, 0.3;
  EXPECT_EQ(middle.inertia, full);
  EXPECT_EQ(middle.offset, Vec3(0, 0.1, -0.05));
  EXPECT_EQ(middle.mark.line, 14);
  // A point mass (zero inertia) is positive semi-definite; `pod` belongs to no beam.
  EXPECT_EQ(model.rigid_bodies[2].node, NodeIndex(model, "pod"));
  EXPECT_EQ(model.rigid_bodies[2].inertia, Mat3::Zero());

  ASSERT_EQ(model.initial_conditions.size(), 3u);
  const InitialCondition &uniform = model.initial_conditions[0];
  EXPECT_EQ(uniform.nodes, (std::vector<int>{NodeIndex(model, "root")}));
  EXPECT_EQ(uniform.velocity, Vec3(1, 0, 0));
  EXPECT_EQ(uniform.angular_velocity, Vec3::Zero());
  EXPECT_FALSE(uniform.rigid_body_field);
  EXPECT_EQ(uniform.mark.line, 23);
  const InitialCondition &field = model.initial_conditions[1];
  EXPECT_EQ(field.nodes, (std::vector<int>{NodeIndex(model, "arm.1"), NodeIndex(model, "arm.2"), NodeIndex(model, "arm.3"), NodeIndex(model, "tip")}));
  EXPECT_EQ(field.velocity, Vec3(0, 0, 1));
  EXPECT_EQ(field.angular_velocity, Vec3(0, 0, 2));
  EXPECT_TRUE(field.rigid_body_field);
  EXPECT_EQ(field.center, Vec3(0.5, 0, 0));
  EXPECT_EQ(field.mark.line, 25);
  const InitialCondition &spin = model.initial_conditions[2];
  EXPECT_EQ(spin.nodes, (std::vector<int>{NodeIndex(model, "pod")}));
  EXPECT_EQ(spin.velocity, Vec3::Zero());
  EXPECT_EQ(spin.angular_velocity, Vec3(3, 0, 0));
  EXPECT_FALSE(spin.rigid_body_field);
}

TEST(InputReader, StaticModelNeedsSupportsForBeamlessRigidBodies)
{
  // The same model as a static one: the beam is held by its supports, but the rigid body on
  // `pod`, which belongs to no beam, has no stiffness and must be fixed on its own.
  std::string text = kDynamicModel;
  text.replace(text.find("type: dynamic"), 13, "type: static");
  const InputError error = ReadInvalid(text + "supports: [{nodes: root, fix: all}]\n");
  EXPECT_NE(error.message.find("mechanism: the rigid body at node 'pod' is not connected to any beam and can move freely (0 of 6"), std::string::npos)
      << error.message;
  EXPECT_EQ(error.line, 21);
  const Model model = ReadValid(text + "supports: [{nodes: [root, pod], fix: all}]\n");
  // Integrator settings and initial conditions are accepted, and ignored, by static analyses.
  EXPECT_EQ(model.analysis.integrator, TimeSchemeKind::GeneralizedAlpha);
  EXPECT_EQ(model.initial_conditions.size(), 3u);
}

TEST(InputReader, RigidBodyOnlyModelNeedsNoBeamsOrSections)
{
  const std::string text  = R"(nodes:
  hub: [1, 2, 3]
rigid_bodies:
  - {node: hub, mass: 2, inertia: [1, 2, 3], offset: [0.1, 0, 0]}
initial_conditions:
  - {nodes: all, velocity: [0, 1, 0], angular_velocity: [0, 0, 5], rigid_body_center: [1, 2, 0]}
analysis: {type: dynamic}
)";
  const Model       model = ReadValid(text);
  EXPECT_TRUE(model.sections.empty());
  EXPECT_TRUE(model.beams.empty());
  EXPECT_TRUE(model.elements.empty());
  ASSERT_EQ(model.nodes.size(), 1u);
  ASSERT_EQ(model.rigid_bodies.size(), 1u);
  EXPECT_EQ(model.rigid_bodies[0].node, 0);
  EXPECT_EQ(model.rigid_bodies[0].inertia, Vec3(1, 2, 3).asDiagonal().toDenseMatrix());
  EXPECT_EQ(model.rigid_bodies[0].offset, Vec3(0.1, 0, 0));
  EXPECT_EQ(model.analysis.integrator, TimeSchemeKind::EnergyMomentum);
  EXPECT_DOUBLE_EQ(model.analysis.spectral_radius, 0.9);
  ASSERT_EQ(model.initial_conditions.size(), 1u);
  EXPECT_EQ(model.initial_conditions[0].nodes, (std::vector<int>{0}));
  EXPECT_TRUE(model.initial_conditions[0].rigid_body_field);
  EXPECT_EQ(model.initial_conditions[0].center, Vec3(1, 2, 0));

  // Static: accepted once all six DOFs of the node are held; `sections:` left empty means none.
  const Model fixed = ReadValid("sections:\n" + text.substr(0, text.find("analysis")) + "supports: [{nodes: hub, fix: all}]\n");
  EXPECT_EQ(fixed.analysis.type, AnalysisType::Static);
  EXPECT_TRUE(fixed.sections.empty());
}

TEST(InputReader, AllSelectsEveryNode)
{
  const std::string text  = R"(sections: [{name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}]
nodes: {a: [0, 0, 0], b: [1, 0, 0]}
beams: [{name: ab, section: s, from: a, to: b, elements: 3}]
supports: [{nodes: all, fix: [uz, rx, ry]}, {nodes: a, fix: [ux, uy, rz]}]
loads: [{nodes: [b, all], force: [1, 0, 0]}]
initial_conditions:
  - {nodes: all, velocity: [0, 2, 0]}
)";
  const Model       model = ReadValid(text);
  // Named nodes first, then the generated ones; `all` lists them in index order.
  const std::vector<int> every{0, 1, 2, 3};
  ASSERT_EQ(model.nodes.size(), 4u);
  EXPECT_EQ(model.supports[0].nodes, every);
  EXPECT_EQ(model.nodal_loads[0].nodes, (std::vector<int>{1, 0, 2, 3}));
  EXPECT_EQ(model.initial_conditions[0].nodes, every);
  EXPECT_FALSE(model.initial_conditions[0].rigid_body_field);

  // Every node gets at most one initial condition, `all` included.
  const InputError error = ReadInvalid(text + "  - {nodes: ab.2, velocity: [1, 0, 0]}\n");
  EXPECT_NE(error.message.find("node 'ab.2' already has an initial condition from the entry at line 7"), std::string::npos) << error.message;
  EXPECT_EQ(error.line, 8);
}

TEST(InputReader, SectionMassFromDensityOrGivenDirectly)
{
  // Every allowed value of integrator, and density-based sections side by side with direct ones.
  const std::string head = R"(sections:
  - {name: rod, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1, density: 7850, area: 3.0e-4, I2: 1.5e-8, I3: 2.5e-8}
  - {name: direct, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1, rhoA: 2.355, rhoJ: [3.14e-4, 1.1775e-4, 1.9625e-4]}
nodes: {a: [0, 0, 0], b: [1, 0, 0], c: [2, 0, 0]}
beams:
  - {name: one, section: rod, from: a, to: b, elements: 1}
  - {name: two, section: direct, from: b, to: c, elements: 1}
analysis:
  type: dynamic
)";
  for (const char *integrator : {"newmark", "mc", "em", "genalpha"}) {
    const Model model = ReadValid(head + "  integrator: " + integrator + "\n  spectral_radius: 0\n");
    EXPECT_STREQ(TimeSchemeName(model.analysis.integrator), integrator);
    EXPECT_DOUBLE_EQ(model.analysis.spectral_radius, 0.0);
    ASSERT_EQ(model.sections.size(), 2u);
    EXPECT_NEAR(model.sections[0].rhoA, model.sections[1].rhoA, 1e-12);
    EXPECT_LT((model.sections[0].rhoJ - model.sections[1].rhoJ).norm(), 1e-15);
  }
}

TEST(InputReader, FormatAndUnreadableFile)
{
  Model      model;
  InputError error;
  EXPECT_FALSE(ReadModelFile("/nonexistent/dir/x.yaml", &model, &error));
  EXPECT_EQ(error.line, 0);
  EXPECT_EQ(error.message, "cannot open input file '/nonexistent/dir/x.yaml'");
  EXPECT_EQ(error.Format(), "/nonexistent/dir/x.yaml: error: cannot open input file '/nonexistent/dir/x.yaml'");
  EXPECT_FALSE(ReadModelFile(MSFLEX_BAD_INPUT_DIR, &model, &error));
  EXPECT_NE(error.message.find("not a regular file"), std::string::npos) << error.message;
  // A FIFO without a writer blocked the open for good, and /dev/zero was read until memory ran out:
  // both are refused before they are opened.
  const std::string fifo = std::string(::testing::TempDir()) + "msflex_input_fifo.yaml";
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_FALSE(ReadModelFile(fifo, &model, &error));
  EXPECT_NE(error.message.find("not a regular file"), std::string::npos) << error.message;
  std::remove(fifo.c_str());
  EXPECT_FALSE(ReadModelFile("/dev/zero", &model, &error));
  EXPECT_NE(error.message.find("not a regular file"), std::string::npos) << error.message;

  const InputError located{"a.yaml", 3, 7, "boom"};
  EXPECT_EQ(located.Format(), "a.yaml:3:7: error: boom");
}

// ---- Joints ------------------------------------------------------------------------------

// One joint of every type between a hub and its own slave node (a dynamic model: the mechanism
// check is for statics only).
const char *const kJointModel = R"(functions:
  - {name: spin, type: linear, slope: 2}
nodes:
  hub: [0, 0, 0]
  s_rigid: [1, 0, 0]
  s_spherical: [0, 1, 0]
  s_revolute: [0, 0, 1]
  s_universal: [1, 1, 0]
  s_cylindrical: [1, 0, 1]
  s_prismatic: [0, 1, 1]
  s_planar: [1, 1, 1]
  s_free: [2, 0, 0]
  s_custom: [0, 2, 0]
  s_screw: [0, 0, 2]
  s_rack: [2, 2, 0]
  s_cam: [2, 0, 2]
  s_table: [0, 2, 2]
rigid_bodies:
  - {node: hub, mass: 1, inertia: [1, 1, 1]}
joints:
  - {name: j_rigid, type: rigid, master: hub, slave: s_rigid}
  - {name: j_spherical, type: spherical, master: hub, slave: s_spherical, axis: [0, 0, 2]}
  - name: j_revolute
    type: revolute
    master: ground
    slave: s_revolute
    axis: [1, 1, 0]
    second_axis: [0, 0, 1]
    drive: {coordinate: rotation, value: 0.5}
  - {name: j_universal, type: universal, master: hub, slave: s_universal, axis: [0, 1, 0], second_axis: [1, 0, 1]}
  - {name: j_cylindrical, type: cylindrical, master: hub, slave: s_cylindrical, drive: {coordinate: rx, value: 2}}
  - {name: j_prismatic, type: prismatic, master: hub, slave: s_prismatic, drive: {coordinate: tx, value: 0.25, function: spin}}
  - {name: j_planar, type: planar, master: hub, slave: s_planar, axis: [0, 0, 1], drive: {coordinate: tz, value: 0.1}}
  - {name: j_free, type: free, master: hub, slave: s_free, drive: {coordinate: ty, value: 0.3}}
  - {name: j_custom, type: custom, master: hub, slave: s_custom, release: [rz, tz, tx, ry], drive: {coordinate: ry, value: 0.4}}
  - name: j_screw
    type: screw
    master: hub
    slave: s_screw
    axis: [0, 0, 1]
    pitch: 2.2918
    drive: {coordinate: translation, value: 1.0, function: spin}
  - {name: j_rack, type: rack_pinion, master: hub, slave: s_rack, radius: -0.1, drive: {coordinate: ty, value: 0.2}} # by its series name
  - {name: j_cam, type: cam, master: hub, slave: s_cam, radius: 0.05}
  - name: j_table
    type: cam_table
    master: hub
    slave: s_table
    profile:
      points: [[0, 0], [1.5, 0.1], [3, 0.2], [4.5, 0.1]]
analysis: {type: dynamic}
)";

const Joint &JointNamed(const Model &model, const std::string &name)
{
  for (const Joint &joint : model.joints)
    if (joint.name == name) return joint;
  ADD_FAILURE() << "no joint " << name;
  return model.joints.front();
}

void ExpectRelease(const Joint &joint, std::vector<int> translations, Joint::Rotation rotation, std::vector<int> rotation_axes)
{
  SCOPED_TRACE(joint.name);
  ASSERT_EQ(joint.num_translations, static_cast<int>(translations.size()));
  for (size_t k = 0; k < translations.size(); ++k) EXPECT_EQ(joint.translation_axis[k], translations[k]);
  EXPECT_EQ(joint.rotation, rotation);
  for (size_t k = 0; k < rotation_axes.size(); ++k) EXPECT_EQ(joint.rotation_axis[k], rotation_axes[k]);
}

TEST(InputReader, JointsOfEveryType)
{
  const Model model = ReadValid(kJointModel);
  ASSERT_EQ(model.joints.size(), 13u);
  const int hub = NodeIndex(model, "hub");
  for (const Joint &joint : model.joints) {
    SCOPED_TRACE(joint.name);
    ExpectOrthonormal(joint.axes); // orthonormal and right-handed (det = +1)
    const std::string suffix = joint.name.substr(2);
    EXPECT_EQ(std::string(JointKindName(joint.kind)), suffix == "rack" ? "rack_pinion" : suffix == "table" ? "cam_table" : suffix);
    EXPECT_EQ(joint.master, joint.name == "j_revolute" ? -1 : hub);
    EXPECT_EQ(joint.slave, NodeIndex(model, "s_" + joint.name.substr(2)));
  }

  // Types without a dependent translation.
  const Joint &rigid = JointNamed(model, "j_rigid");
  ExpectRelease(rigid, {}, Joint::Rotation::None, {});
  EXPECT_EQ(rigid.axes, Mat3::Identity()); // default axis [1, 0, 0], a2 from the least aligned global axis y
  EXPECT_EQ(rigid.dependence, Joint::Dependence::None);
  EXPECT_EQ(rigid.driven_coordinate, -1);
  EXPECT_EQ(rigid.mark.line, 21);

  const Joint &spherical = JointNamed(model, "j_spherical");
  ExpectRelease(spherical, {}, Joint::Rotation::Free, {});
  Mat3 z_axes;
  z_axes << 0, 1, 0, 0, 0, 1, 1, 0, 0; // columns a1 = z, a2 = x (first least aligned), a3 = y
  EXPECT_LT((spherical.axes - z_axes).norm(), kTolerance);

  const Joint &revolute = JointNamed(model, "j_revolute");
  ExpectRelease(revolute, {}, Joint::Rotation::OneAxis, {0});
  const double h = std::sqrt(0.5);
  EXPECT_LT((revolute.axes.col(0) - Vec3(h, h, 0)).norm(), kTolerance);
  EXPECT_LT((revolute.axes.col(1) - Vec3(0, 0, 1)).norm(), kTolerance);
  EXPECT_LT((revolute.axes.col(2) - Vec3(h, -h, 0)).norm(), kTolerance);
  EXPECT_EQ(revolute.driven_coordinate, 0);
  EXPECT_DOUBLE_EQ(revolute.drive_value, 0.5);
  EXPECT_EQ(revolute.drive_function, -1);

  const Joint &universal = JointNamed(model, "j_universal");
  ExpectRelease(universal, {}, Joint::Rotation::TwoAxes, {0, 1});
  EXPECT_LT((universal.axes.col(0) - Vec3(0, 1, 0)).norm(), kTolerance);
  EXPECT_LT((universal.axes.col(1) - Vec3(h, 0, h)).norm(), kTolerance); // [1, 0, 1] is already across y

  const Joint &cylindrical = JointNamed(model, "j_cylindrical");
  ExpectRelease(cylindrical, {0}, Joint::Rotation::OneAxis, {0});
  EXPECT_EQ(cylindrical.driven_coordinate, 1); // after the translation
  EXPECT_DOUBLE_EQ(cylindrical.drive_value, 2.0);

  const Joint &prismatic = JointNamed(model, "j_prismatic");
  ExpectRelease(prismatic, {0}, Joint::Rotation::None, {});
  EXPECT_EQ(prismatic.driven_coordinate, 0);
  EXPECT_DOUBLE_EQ(prismatic.drive_value, 0.25);
  EXPECT_EQ(prismatic.drive_function, 0);

  const Joint &planar = JointNamed(model, "j_planar");
  ExpectRelease(planar, {1, 2}, Joint::Rotation::OneAxis, {0});
  EXPECT_EQ(planar.driven_coordinate, 1); // tz is the second translation
  EXPECT_LT((planar.axes - z_axes).norm(), kTolerance);

  const Joint &free = JointNamed(model, "j_free");
  ExpectRelease(free, {0, 1, 2}, Joint::Rotation::Free, {});
  EXPECT_EQ(free.driven_coordinate, 1);

  // Custom: translations in the order tx, ty, tz; rotations in the order listed.
  const Joint &custom = JointNamed(model, "j_custom");
  ExpectRelease(custom, {0, 2}, Joint::Rotation::TwoAxes, {2, 1});
  EXPECT_EQ(custom.driven_coordinate, 3); // tx, tz, rz, ry
  EXPECT_DOUBLE_EQ(custom.drive_value, 0.4);

  // Dependent translations. A drive of a screw's translation drives its angle by value / pitch; the
  // rack's names it by its history series' axis (ty), the same.
  const Joint &screw = JointNamed(model, "j_screw");
  ExpectRelease(screw, {}, Joint::Rotation::OneAxis, {0});
  EXPECT_EQ(screw.dependence, Joint::Dependence::Linear);
  EXPECT_EQ(screw.dependent_axis, 0);
  EXPECT_DOUBLE_EQ(screw.coefficient, 2.2918);
  EXPECT_EQ(screw.driven_coordinate, 0);
  EXPECT_DOUBLE_EQ(screw.drive_value, 1.0 / 2.2918);
  EXPECT_EQ(screw.drive_function, 0);

  const Joint &rack = JointNamed(model, "j_rack");
  ExpectRelease(rack, {}, Joint::Rotation::OneAxis, {0});
  EXPECT_EQ(rack.dependence, Joint::Dependence::Linear);
  EXPECT_EQ(rack.dependent_axis, 1);
  EXPECT_DOUBLE_EQ(rack.coefficient, -0.1);
  EXPECT_DOUBLE_EQ(rack.drive_value, 0.2 / -0.1);

  const Joint &cam = JointNamed(model, "j_cam");
  ExpectRelease(cam, {}, Joint::Rotation::OneAxis, {0});
  EXPECT_EQ(cam.dependence, Joint::Dependence::EccentricCam);
  EXPECT_EQ(cam.dependent_axis, 1);
  EXPECT_DOUBLE_EQ(cam.coefficient, 0.05);

  const Joint &table = JointNamed(model, "j_table");
  ExpectRelease(table, {}, Joint::Rotation::OneAxis, {0});
  EXPECT_EQ(table.dependence, Joint::Dependence::Table);
  EXPECT_EQ(table.dependent_axis, 1);
  EXPECT_DOUBLE_EQ(table.profile_period, 2.0 * M_PI);
  EXPECT_EQ(table.profile_knots, (std::vector<double>{0, 1.5, 3, 4.5}));
  EXPECT_EQ(table.profile_values, (std::vector<double>{0, 0.1, 0.2, 0.1}));
  ASSERT_EQ(table.profile_second.size(), 4u);
  std::vector<double> second(4);
  ASSERT_TRUE(PeriodicSplineSecondDerivatives(2.0 * M_PI, 4, table.profile_knots.data(), table.profile_values.data(), second.data()));
  for (int k = 0; k < 4; ++k) EXPECT_DOUBLE_EQ(table.profile_second[k], second[k]);
  EXPECT_LT(table.profile_second[2], 0.0); // the peak at phi = 3 curves down
  // The spline passes through the points and repeats with the period.
  const PeriodicSpline spline{table.profile_period, 4, table.profile_knots.data(), table.profile_values.data(), table.profile_second.data()};
  double               f = 0, df = 0, ddf = 0;
  PeriodicSplineEvaluate(spline, 1.5 + 2.0 * M_PI, &f, &df, &ddf);
  EXPECT_NEAR(f, 0.1, 1e-12);
}

TEST(InputReader, JointProfilePeriodAndSecondAxisDefaults)
{
  const Model model = ReadValid(R"(nodes: {a: [0, 0, 0], b: [0, 0, 0]}
rigid_bodies: [{node: a, mass: 1, inertia: [1, 1, 1]}]
joints:
  - name: lobe
    type: cam_table
    master: a
    slave: b
    axis: [1, 2, 3]
    profile: {period: 4, points: [[-1, 0], [0, 1], [1, 0], [2, -1]]}
analysis: {type: dynamic}
)");
  ASSERT_EQ(model.joints.size(), 1u);
  const Joint &joint = model.joints[0];
  ExpectOrthonormal(joint.axes);
  EXPECT_LT((joint.axes.col(0) - Vec3(1, 2, 3).normalized()).norm(), kTolerance);
  // Default a2: the global x axis (least aligned with a1) made perpendicular to a1.
  const Vec3 a1 = Vec3(1, 2, 3).normalized();
  EXPECT_LT((joint.axes.col(1) - (Vec3::UnitX() - a1.x() * a1).normalized()).norm(), kTolerance);
  EXPECT_DOUBLE_EQ(joint.profile_period, 4.0);
  // A sampled sine of period 4: by symmetry the second derivatives are 0, -c, 0, c.
  ASSERT_EQ(joint.profile_second.size(), 4u);
  EXPECT_NEAR(joint.profile_second[0], 0.0, 1e-12);
  EXPECT_NEAR(joint.profile_second[2], 0.0, 1e-12);
  EXPECT_LT(joint.profile_second[1], 0.0);
  EXPECT_NEAR(joint.profile_second[1], -joint.profile_second[3], 1e-12);
}

// A universal joint to the ground and a screw at the same point: the screw's master is a node
// that belongs to no beam and carries no rigid body, only joints.
TEST(InputReader, JointChainAtOnePointAndStaticMechanismCheck)
{
  const std::string head  = R"(sections: [{name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}]
nodes: {cross: [0, 0, 0], nut: [0, 0, 0], tip: [0, 0, 2]}
beams: [{name: rod, section: s, from: nut, to: tip, elements: 2}]
joints:
  - {name: cardan, type: universal, master: ground, slave: cross, axis: [1, 0, 0], second_axis: [0, 1, 0]}
  - {name: thread, type: screw, master: cross, slave: nut, axis: [0, 0, 1], pitch: 0.01}
)";
  const Model       model = ReadValid(head + "supports: [{nodes: tip, fix: all}]\n");
  ASSERT_EQ(model.joints.size(), 2u);
  const int cross = NodeIndex(model, "cross"), nut = NodeIndex(model, "nut");
  EXPECT_EQ(model.joints[0].master, -1);
  EXPECT_EQ(model.joints[0].slave, cross);
  EXPECT_EQ(model.joints[1].master, cross);
  EXPECT_EQ(model.joints[1].slave, nut);
  EXPECT_EQ(model.joints[0].rotation, Joint::Rotation::TwoAxes);
  EXPECT_EQ(model.joints[1].dependence, Joint::Dependence::Linear);
  EXPECT_LT((model.joints[1].axes.col(0) - Vec3::UnitZ()).norm(), kTolerance);

  // The universal joint to the ground holds three translations and the rotation about a3 = z;
  // the screw between two nodes holds nothing against the ground.
  InputError error = ReadInvalid(head);
  EXPECT_NE(error.message.find("mechanism: beam(s) 'rod' can move as a rigid body (4 of 6"), std::string::npos) << error.message;
  EXPECT_EQ(error.line, 3);

  // A rigid joint to the ground holds everything; a prismatic one all but the slide along a1.
  const std::string single = R"(sections: [{name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}]
nodes: {a: [0, 0, 0], b: [1, 0, 0]}
beams: [{name: ab, section: s, from: a, to: b, elements: 2}]
joints: [{name: j, master: ground, slave: a, type: )";
  ReadValid(single + "rigid}]\n");
  error = ReadInvalid(single + "prismatic, axis: [1, 1, 0]}]\n");
  EXPECT_NE(error.message.find("(5 of 6"), std::string::npos) << error.message;
  // The slide is held by a support at b along it... but not by one across it.
  ReadValid(single + "prismatic, axis: [1, 1, 0]}]\nsupports: [{nodes: b, fix: [ux]}]\n");
  error = ReadInvalid(single + "prismatic, axis: [1, 0, 0]}]\nsupports: [{nodes: b, fix: [uy]}]\n");
  EXPECT_NE(error.message.find("(5 of 6"), std::string::npos) << error.message;
  // A spherical joint holds three translations; pins at b across the line a-b add two rotations,
  // leaving the spin about the line free.
  error = ReadInvalid(single + "spherical}]\nsupports: [{nodes: b, fix: [uy, uz]}]\n");
  EXPECT_NE(error.message.find("(5 of 6"), std::string::npos) << error.message;
  ReadValid(single + "spherical}]\nsupports: [{nodes: b, fix: [uy, uz, rx]}]\n");
}

TEST(InputReader, JointsConnectComponentsAndRigidBodies)
{
  // Two beams joined by a revolute joint form one component: the first beam's clamp holds both.
  const std::string beams = R"(sections: [{name: s, EA: 1, GA2: 1, GA3: 1, GJ: 1, EI2: 1, EI3: 1}]
nodes: {a: [0, 0, 0], b: [1, 0, 0], c: [1, 0, 0], d: [2, 0, 0]}
beams:
  - {name: ab, section: s, from: a, to: b, elements: 2}
  - {name: cd, section: s, from: c, to: d, elements: 2}
supports: [{nodes: a, fix: all}]
)";
  EXPECT_NE(ReadInvalid(beams).message.find("mechanism: beam(s) 'cd'"), std::string::npos);
  const Model joined = ReadValid(beams + "joints: [{name: pin, type: revolute, master: b, slave: c, axis: [0, 0, 1]}]\n");
  ASSERT_EQ(joined.joints.size(), 1u);

  // A rigid body on a node outside every beam, welded to the ground, needs no support; with a
  // revolute joint it is a mechanism (5 of 6), and a body hung from it by a second joint shares
  // its group (reported once, at the first body).
  const std::string bodies = R"(nodes: {p: [0, 0, 0], q: [0, 0, -1]}
rigid_bodies:
  - {node: p, mass: 1, inertia: [1, 1, 1]}
  - {node: q, mass: 1, inertia: [1, 1, 1]}
joints:
  - {name: hang, type: rigid, master: p, slave: q}
)";
  ReadValid(bodies + "  - {name: weld, type: rigid, master: ground, slave: p}\n");
  const InputError error = ReadInvalid(bodies + "  - {name: pivot, type: revolute, master: ground, slave: p}\n");
  EXPECT_NE(error.message.find("mechanism: the rigid body at node 'p' is not connected to any beam and can move freely (5 of 6"), std::string::npos)
      << error.message;
  EXPECT_EQ(error.line, 3);
}

TEST(InputReader, JointSlavesTakeInitialConditionsButNoSupports)
{
  const std::string head  = R"(nodes: {hub: [0, 0, 0], wheel: [0, 0, 0]}
rigid_bodies: [{node: hub, mass: 1, inertia: [1, 1, 1]}, {node: wheel, mass: 1, inertia: [1, 1, 1]}]
joints: [{name: axle, type: revolute, master: hub, slave: wheel}]
analysis: {type: dynamic}
)";
  const Model       model = ReadValid(head + "initial_conditions: [{nodes: wheel, angular_velocity: [3, 0, 0]}]\n");
  ASSERT_EQ(model.initial_conditions.size(), 1u);
  const InputError error = ReadInvalid(head + "supports: [{nodes: [hub, wheel], fix: [ux]}]\n");
  EXPECT_NE(error.message.find("node 'wheel' is the slave of joint 'axle' (line 3) and cannot carry a support"), std::string::npos) << error.message;
  EXPECT_EQ(error.line, 5);
  EXPECT_EQ(error.column, 26);
}

// ---- HDF5 mesh files (`mesh:`) -----------------------------------------------------------

// One dataset of a mesh file to write: numbers, integers or strings (variable- or fixed-length).
struct MeshDataset {
  enum class Kind { Real, Integer, String, FixedString };
  Kind                     kind = Kind::Real;
  std::vector<hsize_t>     dims;
  std::vector<double>      reals;
  std::vector<long long>   integers;
  std::vector<std::string> strings;
};
using MeshSpec = std::map<std::string, MeshDataset>;

MeshDataset Reals(std::vector<hsize_t> dims, std::vector<double> values) { return {MeshDataset::Kind::Real, dims, values, {}, {}}; }
MeshDataset Integers(std::vector<hsize_t> dims, std::vector<long long> values) { return {MeshDataset::Kind::Integer, dims, {}, values, {}}; }
MeshDataset Strings(std::vector<std::string> values, bool fixed = false)
{
  return {fixed ? MeshDataset::Kind::FixedString : MeshDataset::Kind::String, {values.size()}, {}, {}, values};
}

// Writes `spec` with the HDF5 C API; groups are created as needed.
void WriteMesh(const std::filesystem::path &path, const MeshSpec &spec)
{
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(file, 0) << path;
  const hid_t links = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(links, 1);
  for (const auto &[name, dataset] : spec) {
    const hid_t               space = H5Screate_simple(static_cast<int>(dataset.dims.size()), dataset.dims.data(), nullptr);
    hid_t                     type  = -1;
    const void               *data  = nullptr;
    std::vector<const char *> pointers;
    std::string               fixed;
    switch (dataset.kind) {
    case MeshDataset::Kind::Real:
      type = H5Tcopy(H5T_NATIVE_DOUBLE);
      data = dataset.reals.data();
      break;
    case MeshDataset::Kind::Integer:
      type = H5Tcopy(H5T_NATIVE_LLONG);
      data = dataset.integers.data();
      break;
    case MeshDataset::Kind::String:
      type = H5Tcopy(H5T_C_S1);
      H5Tset_size(type, H5T_VARIABLE);
      H5Tset_cset(type, H5T_CSET_UTF8);
      for (const std::string &text : dataset.strings) pointers.push_back(text.c_str());
      data = pointers.data();
      break;
    case MeshDataset::Kind::FixedString: {
      size_t width = 1;
      for (const std::string &text : dataset.strings) width = std::max(width, text.size());
      type = H5Tcopy(H5T_C_S1);
      H5Tset_size(type, width);
      for (const std::string &text : dataset.strings) fixed += text + std::string(width - text.size(), '\0');
      data = fixed.data();
      break;
    }
    }
    const hid_t id = H5Dcreate2(file, name.c_str(), type, space, links, H5P_DEFAULT, H5P_DEFAULT);
    EXPECT_GE(id, 0) << name;
    EXPECT_GE(H5Dwrite(id, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0) << name;
    H5Dclose(id);
    H5Tclose(type);
    H5Sclose(space);
  }
  H5Pclose(links);
  H5Fclose(file);
}

// A fresh directory per test for the mesh and the (virtual) YAML file next to it.
std::filesystem::path MeshTestDirectory()
{
  const ::testing::TestInfo  *info      = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path directory = std::filesystem::temp_directory_path() / ("msflex_mesh_" + std::to_string(::getpid()) + "_" + info->name());
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  return directory;
}

const char *const kMeshSections = R"(sections:
  - {name: steel, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5, rhoA: 7.8, rhoJ: [0.1, 0.05, 0.05]}
  - {name: alloy, EA: 2.0e7, GA2: 5.0e6, GA3: 5.0e6, GJ: 9.0e5, EI2: 9.0e5, EI3: 9.0e5, rhoA: 2.7, rhoJ: [0.1, 0.05, 0.05]}
)";

// The model of MeshSpecOfEquivalentYaml, written out in YAML.
const std::string kEquivalentYaml = std::string(kMeshSections) + R"(nodes:
  p0: [0, 0, 0]
  p1: [2, 0, 0]
  p2: [2, 1.5, 0.5]
  p3: [2, 1.5, 0.5]
  p4: [2, 3.5, 0.5]
  p5: [2, 3.5, 0.5]
  p6: [3, 3.5, 0.5]
  p7: [3, 3.5, 0.5]
beams:
  - {name: first, section: steel, from: p0, to: p1, elements: 3}
  - {name: second, section: alloy, from: p1, to: p2, elements: 2, order: 2, orientation: [0, 0, 1]}
  - {name: third, section: steel, from: p3, to: p4, elements: 1}
  - {name: fourth, section: alloy, from: p5, to: p6, elements: 2, orientation: [0, 1, 1]}
joints:
  - {name: base, type: rigid, master: ground, slave: p0, axis: [0, 0, 1]}
  - {name: hinge, type: revolute, master: p2, slave: p3, axis: [0, 0, 1], second_axis: [1, 1, 0]}
  - {name: lead, type: screw, master: p4, slave: p5, axis: [1, 0, 0], pitch: 0.01}
  - {name: lobe, type: cam, master: p6, slave: p7, axis: [0, 1, 0], radius: 0.05}
supports:
  - {nodes: p1, fix: [ux]}
probes:
  - {name: tip, node: p6}
analysis: {type: dynamic}
)";

MeshSpec MeshSpecOfEquivalentYaml()
{
  return {
      {"/nodes/coordinates", Reals({8, 3}, {0, 0, 0, 2, 0, 0, 2, 1.5, 0.5, 2, 1.5, 0.5, 2, 3.5, 0.5, 2, 3.5, 0.5, 3, 3.5, 0.5, 3, 3.5, 0.5})},
      {"/nodes/names", Strings({"p0", "p1", "p2", "p3", "p4", "p5", "p6", "p7"})},
      {"/beams/nodes", Integers({4, 2}, {0, 1, 1, 2, 3, 4, 5, 6})},
      {"/beams/section", Integers({4}, {0, 1, 0, 1})},
      {"/beams/elements", Integers({4}, {3, 2, 1, 2})},
      {"/beams/order", Integers({4}, {1, 2, 1, 1})},
      {"/beams/orientation", Reals({4, 3}, {0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1})},
      {"/beams/names", Strings({"first", "second", "third", "fourth"}, true)},
      {"/joints/type", Strings({"rigid", "revolute", "screw", "cam"})},
      {"/joints/master", Integers({4}, {-1, 2, 4, 6})},
      {"/joints/slave", Integers({4}, {0, 3, 5, 7})},
      {"/joints/axis", Reals({4, 3}, {0, 0, 1, 0, 0, 1, 1, 0, 0, 0, 1, 0})},
      {"/joints/second_axis", Reals({4, 3}, {0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0})},
      {"/joints/parameter", Reals({4}, {0, 0, 0.01, 0.05})},
      {"/joints/names", Strings({"base", "hinge", "lead", "lobe"})},
  };
}

// The YAML file that refers to mesh.h5 (line 4: the `mesh:` key).
const std::string kMeshYaml    = std::string(kMeshSections) + R"(mesh: mesh.h5
supports:
  - {nodes: p1, fix: [ux]}
probes:
  - {name: tip, node: p6}
analysis: {type: dynamic}
)";
constexpr int     kMeshKeyLine = 4;

bool ReadWithMesh(const MeshSpec &spec, const std::string &yaml, Model *model, InputError *error)
{
  const std::filesystem::path directory = MeshTestDirectory();
  WriteMesh(directory / "mesh.h5", spec);
  const bool ok = ReadModelString(yaml, (directory / "model.yaml").string(), model, error);
  std::filesystem::remove_all(directory);
  return ok;
}

TEST(InputMesh, SameModelAsEquivalentYaml)
{
  const Model expected = ReadValid(kEquivalentYaml);
  Model       model;
  InputError  error;
  ASSERT_TRUE(ReadWithMesh(MeshSpecOfEquivalentYaml(), kMeshYaml, &model, &error)) << error.Format();

  ASSERT_EQ(model.nodes.size(), expected.nodes.size());
  for (size_t node = 0; node < model.nodes.size(); ++node) {
    SCOPED_TRACE(expected.nodes[node].name);
    EXPECT_EQ(model.nodes[node].name, expected.nodes[node].name);
    EXPECT_EQ(model.nodes[node].position, expected.nodes[node].position); // bit for bit
  }
  ASSERT_EQ(model.beams.size(), expected.beams.size());
  for (size_t beam = 0; beam < model.beams.size(); ++beam) {
    EXPECT_EQ(model.beams[beam].name, expected.beams[beam].name);
    EXPECT_EQ(model.beams[beam].section, expected.beams[beam].section);
    EXPECT_EQ(model.beams[beam].order, expected.beams[beam].order);
    EXPECT_EQ(model.beams[beam].nodes, expected.beams[beam].nodes);
    EXPECT_EQ(model.beams[beam].elements, expected.beams[beam].elements);
    EXPECT_EQ(model.beams[beam].mark.line, kMeshKeyLine);
  }
  ASSERT_EQ(model.elements.size(), expected.elements.size());
  ASSERT_EQ(model.elements.size(), 3u + 2u + 1u + 2u);
  for (size_t element = 0; element < model.elements.size(); ++element) {
    SCOPED_TRACE(element);
    const BeamElement &a = model.elements[element], &b = expected.elements[element];
    EXPECT_EQ(a.nodes, b.nodes);
    EXPECT_EQ(a.section, b.section);
    EXPECT_EQ(a.order, b.order);
    EXPECT_EQ(a.beam, b.beam);
    for (int node = 0; node <= a.order; ++node) EXPECT_EQ(a.reference_triads[node], b.reference_triads[node]);
  }
  ASSERT_EQ(model.joints.size(), expected.joints.size());
  for (size_t index = 0; index < model.joints.size(); ++index) {
    const Joint &a = model.joints[index], &b = expected.joints[index];
    SCOPED_TRACE(b.name);
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.kind, b.kind);
    EXPECT_EQ(a.master, b.master);
    EXPECT_EQ(a.slave, b.slave);
    EXPECT_EQ(a.axes, b.axes);
    EXPECT_EQ(a.num_translations, b.num_translations);
    EXPECT_EQ(a.translation_axis, b.translation_axis);
    EXPECT_EQ(a.rotation, b.rotation);
    EXPECT_EQ(a.rotation_axis, b.rotation_axis);
    EXPECT_EQ(a.dependence, b.dependence);
    EXPECT_EQ(a.dependent_axis, b.dependent_axis);
    EXPECT_EQ(a.coefficient, b.coefficient);
    EXPECT_EQ(a.driven_coordinate, -1);
  }
  EXPECT_EQ(model.joints[0].master, -1);
  EXPECT_EQ(model.joints[2].dependence, Joint::Dependence::Linear);
  EXPECT_EQ(model.joints[3].dependence, Joint::Dependence::EccentricCam);
  // The YAML parts still refer to the mesh's nodes by name.
  ASSERT_EQ(model.supports.size(), 1u);
  EXPECT_EQ(model.supports[0].nodes, (std::vector<int>{1}));
  ASSERT_EQ(model.probes.size(), 1u);
  EXPECT_EQ(model.probes[0].node, 6);
}

TEST(InputMesh, DefaultNamesAndYamlNodesAndBeamsAlongside)
{
  MeshSpec spec = MeshSpecOfEquivalentYaml();
  for (const char *optional : {"/nodes/names", "/beams/names", "/beams/orientation", "/joints/names", "/joints/second_axis"}) spec.erase(optional);
  const std::string yaml = std::string(kMeshSections) + R"(mesh: mesh.h5
nodes:
  extra: [0, -1, 0]
beams:
  - {name: stub, section: steel, from: n0, to: extra, elements: 2}
joints:
  - {name: pin, type: spherical, master: b0.1, slave: n7}
analysis: {type: dynamic}
)";
  // n7 is the slave of the mesh's cam joint j3 already.
  Model      model;
  InputError error;
  EXPECT_FALSE(ReadWithMesh(spec, yaml, &model, &error));
  EXPECT_NE(error.message.find("node 'n7' is already the slave of joint 'j3'"), std::string::npos) << error.Format();

  std::string fixed = yaml;
  fixed.replace(fixed.find("slave: n7"), 9, "slave: extra");
  ASSERT_TRUE(ReadWithMesh(spec, fixed, &model, &error)) << error.Format();
  // Mesh nodes first (n0 .. n7), then the YAML nodes, then the generated ones.
  EXPECT_EQ(model.nodes[0].name, "n0");
  EXPECT_EQ(model.nodes[7].name, "n7");
  EXPECT_EQ(model.nodes[8].name, "extra");
  EXPECT_EQ(model.nodes[9].name, "b0.1");
  ASSERT_EQ(model.beams.size(), 5u);
  EXPECT_EQ(model.beams[0].name, "b0");
  EXPECT_EQ(model.beams[4].name, "stub");
  ASSERT_EQ(model.joints.size(), 5u);
  EXPECT_EQ(model.joints[3].name, "j3");
  EXPECT_EQ(model.joints[4].name, "pin");
  EXPECT_EQ(model.joints[4].master, NodeIndex(model, "b0.1"));
  // Default orientation (0, 1, 0) on beam b3 from n5 to n6 along x: t2 = y.
  const BeamElement &element = model.elements[model.beams[3].elements[0]];
  EXPECT_LT((element.reference_triads[0].col(1) - Vec3::UnitY()).norm(), kTolerance);
  // Default second axis of joint j1 (axis z): a2 = x.
  EXPECT_LT((model.joints[1].axes.col(1) - Vec3::UnitX()).norm(), kTolerance);
}

struct BadMeshCase {
  std::string                     label;
  std::function<void(MeshSpec &)> change;
  std::string                     expected_message;
};

TEST(InputMesh, BadMeshesNameFileDatasetAndRow)
{
  const std::vector<BadMeshCase> cases = {
      {"missing dataset", [](MeshSpec &spec) { spec.erase("/beams/section"); }, "mesh.h5: /beams/section: missing dataset"},
      {"missing nodes", [](MeshSpec &spec) { spec.erase("/nodes/coordinates"); }, "mesh.h5: /nodes/coordinates: missing dataset"},
      {"wrong shape",
       [](MeshSpec &spec) {
         spec["/nodes/coordinates"] = Reals({12, 2}, std::vector<double>(24, 0.0));
       },
       "mesh.h5: /nodes/coordinates: wrong shape (12, 2), expected (n, 3)"},
      {"wrong row count",
       [](MeshSpec &spec) {
         spec["/beams/order"] = Integers({3}, {1, 1, 1});
       },
       "mesh.h5: /beams/order: wrong shape (3,), expected (4,)"},
      {"not integers",
       [](MeshSpec &spec) {
         spec["/beams/elements"] = Reals({4}, {3, 2, 1, 2});
       },
       "mesh.h5: /beams/elements: expected integers, found floating-point numbers"},
      {"node index out of range", [](MeshSpec &spec) { spec["/beams/nodes"].integers[5] = 999; },
       "mesh.h5: /beams/nodes row 2: node index 999 out of range (n = 8)"},
      {"master out of range", [](MeshSpec &spec) { spec["/joints/master"].integers[1] = -2; },
       "mesh.h5: /joints/master row 1: node index -2 out of range (-1 = ground, n = 8)"},
      {"unknown joint type", [](MeshSpec &spec) { spec["/joints/type"].strings[1] = "hinge"; }, "mesh.h5: /joints/type row 1: unknown joint type 'hinge'"},
      {"custom joint", [](MeshSpec &spec) { spec["/joints/type"].strings[0] = "custom"; }, "mesh.h5: /joints/type row 0: a custom joint needs 'release'"},
      {"bad section index", [](MeshSpec &spec) { spec["/beams/section"].integers[3] = 2; },
       "mesh.h5: /beams/section row 3: section index 2 out of range ('sections' lists 2)"},
      {"order three", [](MeshSpec &spec) { spec["/beams/order"].integers[0] = 3; }, "mesh.h5: /beams/order row 0: the order must be 1 or 2, got 3"},
      {"zero elements", [](MeshSpec &spec) { spec["/beams/elements"].integers[1] = 0; },
       "mesh.h5: /beams/elements row 1: the number of elements must be between 1 and 10000000, got 0"},
      {"zero length", [](MeshSpec &spec) { spec["/beams/nodes"].integers[5] = 2; },
       "mesh.h5: /beams/nodes row 2: zero length: nodes 'p3' and 'p2' are at the same position"},
      {"both ends the same", [](MeshSpec &spec) { spec["/beams/nodes"].integers[1] = 0; }, "mesh.h5: /beams/nodes row 0: both ends are node 'p0'"},
      {"orientation along the axis", [](MeshSpec &spec) { spec["/beams/orientation"].reals[0] = 5; },
       "mesh.h5: /beams/orientation row 0: orientation [5, 0, 0] is parallel to the beam's axis"},
      {"zero pitch", [](MeshSpec &spec) { spec["/joints/parameter"].reals[2] = 0; },
       "mesh.h5: /joints/parameter row 2: the pitch of a screw joint must not be zero, got 0"},
      {"zero axis", [](MeshSpec &spec) { std::fill_n(spec["/joints/axis"].reals.begin() + 3, 3, 0.0); },
       "mesh.h5: /joints/axis row 1: the axis must not be the zero vector"},
      {"slave twice", [](MeshSpec &spec) { spec["/joints/slave"].integers[3] = 5; },
       "mesh.h5: /joints/slave row 3: node 'p5' is already the slave of joint 'lead' of the mesh file; a node can be the slave of only one joint"},
      {"not finite", [](MeshSpec &spec) { spec["/nodes/coordinates"].reals[7] = std::nan(""); }, "mesh.h5: /nodes/coordinates row 2: not a finite number"},
      {"duplicate node name", [](MeshSpec &spec) { spec["/nodes/names"].strings[6] = "p1"; },
       "mesh.h5: /nodes/names row 6: node name 'p1' is already used by node row 1 of /nodes"},
      {"beam name taken by a node", [](MeshSpec &spec) { spec["/beams/names"].strings[2] = "p3"; },
       "mesh.h5: /beams/names row 2: beam name 'p3' is already used by node row 3 of /nodes"},
      {"generated name taken", [](MeshSpec &spec) { spec["/nodes/names"].strings[7] = "first.1"; },
       "mesh.h5: /beams/nodes row 0: beam 'first' generates node 'first.1', but that name is already used"},
      {"missing joint types", [](MeshSpec &spec) { spec.erase("/joints/type"); }, "mesh.h5: /joints/type: missing dataset"},
      {"names not strings",
       [](MeshSpec &spec) {
         spec["/joints/names"] = Integers({4}, {1, 2, 3, 4});
       },
       "mesh.h5: /joints/names: expected strings"},
      {"duplicate joint name", [](MeshSpec &spec) { spec["/joints/names"].strings[3] = "base"; }, "mesh.h5: /joints/names row 3: duplicate joint name 'base'"},
      {"slave is master", [](MeshSpec &spec) { spec["/joints/slave"].integers[1] = 2; }, "mesh.h5: /joints/slave row 1: the slave is the master, node 'p2'"},
      {"joint name with a slash", [](MeshSpec &spec) { spec["/joints/names"].strings[1] = "arm/hinge"; },
       "mesh.h5: /joints/names row 1: joint name 'arm/hinge' cannot begin the names of its history series <name>.tx, ... in the result file: it "
       "contains '/', the HDF5 path separator"},
  };
  for (const BadMeshCase &bad : cases) {
    SCOPED_TRACE(bad.label);
    MeshSpec spec = MeshSpecOfEquivalentYaml();
    bad.change(spec);
    Model      model;
    InputError error;
    ASSERT_FALSE(ReadWithMesh(spec, kMeshYaml, &model, &error));
    EXPECT_NE(error.message.find(bad.expected_message), std::string::npos) << error.Format();
    EXPECT_EQ(error.line, kMeshKeyLine) << error.Format();
    EXPECT_NE(error.file.find("model.yaml"), std::string::npos);
  }
}

TEST(InputMesh, UnconnectedMeshNodeAndMissingOrBrokenFile)
{
  MeshSpec spec = MeshSpecOfEquivalentYaml();
  for (const char *joints : {"/joints/type", "/joints/master", "/joints/slave", "/joints/axis", "/joints/second_axis", "/joints/parameter", "/joints/names"})
    spec.erase(joints);
  Model      model;
  InputError error;
  ASSERT_FALSE(ReadWithMesh(spec, kMeshYaml, &model, &error));
  EXPECT_NE(error.message.find("mesh.h5: /nodes row 7: node 'p7' is not connected"), std::string::npos) << error.Format();

  const std::filesystem::path directory = MeshTestDirectory();
  ASSERT_FALSE(ReadModelString(kMeshYaml, (directory / "model.yaml").string(), &model, &error));
  EXPECT_NE(error.message.find("cannot open mesh file 'mesh.h5'"), std::string::npos) << error.Format();
  EXPECT_EQ(error.line, kMeshKeyLine);
  std::ofstream(directory / "mesh.h5") << "nodes: not HDF5\n";
  ASSERT_FALSE(ReadModelString(kMeshYaml, (directory / "model.yaml").string(), &model, &error));
  EXPECT_NE(error.message.find("mesh file 'mesh.h5' is not an HDF5 file"), std::string::npos) << error.Format();
  std::filesystem::remove_all(directory);
}

// A dataset whose header claims `rows` x 3 numbers but whose chunks were never written: a small
// file that would make the reader allocate gigabytes.
void AddHollowDataset(const std::filesystem::path &path, const char *name, hsize_t rows)
{
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const hsize_t dims[2] = {rows, 3}, chunk[2] = {4096, 3};
  const hid_t   space  = H5Screate_simple(2, dims, nullptr);
  const hid_t   create = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(create, 2, chunk);
  const hid_t links = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(links, 1);
  const hid_t dataset = H5Dcreate2(file, name, H5T_IEEE_F64LE, space, links, create, H5P_DEFAULT);
  EXPECT_GE(dataset, 0);
  H5Dclose(dataset);
  H5Pclose(links);
  H5Pclose(create);
  H5Sclose(space);
  H5Fclose(file);
}

TEST(InputMesh, CountsAreCheckedAgainstTheFileBeforeAllocating)
{
  MeshSpec spec = MeshSpecOfEquivalentYaml();
  spec.erase("/nodes/coordinates");
  spec.erase("/nodes/names");
  const std::filesystem::path directory = MeshTestDirectory();
  WriteMesh(directory / "mesh.h5", spec);
  AddHollowDataset(directory / "mesh.h5", "/nodes/coordinates", 400000000);
  Model      model;
  InputError error;
  ASSERT_FALSE(ReadModelString(kMeshYaml, (directory / "model.yaml").string(), &model, &error));
  EXPECT_NE(error.message.find("mesh.h5: /nodes/coordinates: claims 1200000000 entries (9600000000 bytes) but the file holds only 0 bytes of them"),
            std::string::npos)
      << error.Format();
  EXPECT_EQ(error.line, kMeshKeyLine) << error.Format();
  std::filesystem::remove_all(directory);
}

TEST(InputMesh, ModelRemembersItsMeshFile)
{
  Model      model;
  InputError error;
  ASSERT_TRUE(ReadWithMesh(MeshSpecOfEquivalentYaml(), kMeshYaml, &model, &error)) << error.Format();
  EXPECT_EQ(std::filesystem::path(model.mesh_file).filename(), "mesh.h5");
  EXPECT_EQ(ReadValid(kEquivalentYaml).mesh_file, "");
}

// ---- Long joint chains -------------------------------------------------------------------

// A chain of n rigid bodies, body k hanging from body k - 1 by a revolute joint, the first from
// the ground; `extra` is appended to the joints.
std::string RigidChainYaml(int n, const std::string &extra = "")
{
  std::string yaml = "nodes:\n";
  for (int k = 0; k < n; ++k) yaml += "  n" + std::to_string(k) + ": [" + std::to_string(k) + ", 0, 0]\n";
  yaml += "rigid_bodies:\n";
  for (int k = 0; k < n; ++k) yaml += "  - {node: n" + std::to_string(k) + ", mass: 1, inertia: [1, 1, 1]}\n";
  yaml += "joints:\n  - {name: j0, type: revolute, master: ground, slave: n0, axis: [0, 0, 1]}\n";
  for (int k = 1; k < n; ++k)
    yaml +=
        "  - {name: j" + std::to_string(k) + ", type: revolute, master: n" + std::to_string(k - 1) + ", slave: n" + std::to_string(k) + ", axis: [0, 0, 1]}\n";
  return yaml + extra + "analysis: {type: dynamic}\n";
}

TEST(InputJoints, LongChainsReadAndCyclesAreStillFound)
{
  const int   n     = 5000;
  const Model model = ReadValid(RigidChainYaml(n));
  ASSERT_EQ(model.joints.size(), static_cast<size_t>(n));
  EXPECT_EQ(model.joints.back().master, NodeIndex(model, "n" + std::to_string(n - 2)));
  // The same chain rooted at n0 instead of the ground, closed by a joint from its last body back to n0.
  std::string yaml = RigidChainYaml(4);
  yaml.replace(yaml.find("master: ground"), 14, "master: n3");
  const InputError error = ReadInvalid(yaml);
  EXPECT_NE(error.message.find("joint 'j3' closes a cycle of master-slave joints: 'j0', 'j1', 'j2', 'j3' lead from node 'n3' back to itself"),
            std::string::npos)
      << error.message;
}

// ---- The bad-input corpus ----------------------------------------------------------------

struct BadInputCase {
  std::string path;
  std::string expected_message;   // from "# expect: ..."
  int         expected_line = -1; // from "# line: N"
};

std::vector<std::string> BadInputFiles()
{
  // The error_code form does not throw: a missing directory yields no cases and fails the
  // count test below instead of aborting the whole test program.
  std::vector<std::string> files;
  std::error_code          missing_directory;
  for (const auto &entry : std::filesystem::directory_iterator(MSFLEX_BAD_INPUT_DIR, missing_directory))
    if (entry.path().extension() == ".yaml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

// Value of a "# <tag>: value" comment line, or "" when the line has another form.
std::string CommentValue(const std::string &line, const std::string &tag)
{
  const std::string prefix = "# " + tag + ":";
  if (line.compare(0, prefix.size(), prefix) != 0) return "";
  const size_t start = line.find_first_not_of(' ', prefix.size());
  return start == std::string::npos ? "" : line.substr(start);
}

BadInputCase ReadBadInputCase(const std::string &path)
{
  BadInputCase  bad_input;
  std::ifstream stream(path);
  std::string   first_line, second_line;
  std::getline(stream, first_line);
  std::getline(stream, second_line);
  bad_input.path             = path;
  bad_input.expected_message = CommentValue(first_line, "expect");
  const std::string line     = CommentValue(second_line, "line");
  if (!line.empty()) bad_input.expected_line = std::stoi(line);
  return bad_input;
}

class BadInput : public ::testing::TestWithParam<std::string> {};

TEST_P(BadInput, FailsWithExpectedMessageAndLine)
{
  const BadInputCase bad_input = ReadBadInputCase(GetParam());
  ASSERT_FALSE(bad_input.expected_message.empty()) << GetParam() << ": first line must be '# expect: <message part>'";
  ASSERT_GE(bad_input.expected_line, 0) << GetParam() << ": second line must be '# line: N'";
  Model      model;
  InputError error;
  ASSERT_FALSE(ReadModelFile(bad_input.path, &model, &error)) << GetParam() << " was accepted";
  EXPECT_NE(error.message.find(bad_input.expected_message), std::string::npos) << error.Format();
  EXPECT_EQ(error.line, bad_input.expected_line) << error.Format();
  EXPECT_EQ(error.file, bad_input.path);
}

std::string TestNameFromPath(const ::testing::TestParamInfo<std::string> &info)
{
  std::string name = std::filesystem::path(info.param).stem().string();
  for (char &character : name)
    if (!std::isalnum(static_cast<unsigned char>(character))) character = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadInput, ::testing::ValuesIn(BadInputFiles()), TestNameFromPath);

TEST(BadInputCorpus, HasAtLeast25Cases) { EXPECT_GE(BadInputFiles().size(), 25u); }

} // namespace
} // namespace msflex
