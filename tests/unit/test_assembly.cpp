// The assembled system: the global Jacobian (element tangents, column scaling by H(omega),
// follower loads, constrained and prescribed DOFs, ghost nodes under MPI; in dynamics the
// consistent translational mass, lumped rotary inertia, a rigid body with an offset centre of
// mass and its weight) against central finite differences of the assembled residual with respect
// to the Newton unknowns, at a deformed, moving state with large increments. Statics, Newmark,
// generalized-alpha and the initial-acceleration problem, where the tangent is exact; the
// mid-point schemes' inertia tangents are checked kernel by kernel in test_inertia.
// Runs on any number of ranks.
#include "assembly/mechanical_system.hpp"
#include "io/input_reader.hpp"
#include "output/results.hpp"
#include "parallel/partition.hpp"

#include <gtest/gtest.h>
#include <petscmat.h>

#include <cmath>
#include <cstdio>
#include <random>

using namespace msflex;

namespace {

// A frame of two beams meeting at a rigid corner: 2- and 3-node elements, a curved twisted
// column, dead and follower tip loads, a distributed load, fixed, partly fixed and prescribed DOFs.
const char *kModel = R"(
sections:
  - {name: s, EA: 3.0e3, GA2: 1.2e3, GA3: 9.0e2, GJ: 40, EI2: 60, EI3: 80, rhoA: 1.5}
nodes:
  base: [0, 0, 0]
  corner: [0.3, 0.1, 2]
  end: [1.8, 1.0, 2.2]
beams:
  - {name: column, section: s, from: base, to: corner, elements: 3, order: 2, twist: 0.7, arc: {center: [4, 0.6, 0.395]}}
  - {name: arm, section: s, from: corner, to: end, elements: 4, order: 1, roll: 0.4}
supports:
  - {nodes: base, fix: all}
  - {nodes: end, fix: [uz, rx]}
  - {nodes: end, prescribe: {ry: 0.3}}
loads:
  - {nodes: corner, force: [3, -2, 1], moment: [1, 2, -1]}
  - {nodes: end, force: [2, 1, -4], moment: [-2, 1, 3], follower: true}
  - {beams: arm, distributed: [0, 1, -2]}
  - {gravity: [0, 0, -9.81]}
rigid_bodies:
  - {node: corner, mass: 2.5, inertia: [[0.4, 0.05, 0.0], [0.05, 0.3, 0.02], [0.0, 0.02, 0.5]], offset: [0.2, -0.1, 0.15]}
initial_conditions:
  - {nodes: [column, arm], velocity: [0.3, -0.2, 0.1], angular_velocity: [0.5, -0.4, 0.8], rigid_body_center: [0.3, 0.1, 2]}
)";

// A mechanism: a clamped beam carrying, through joints of every kind, short beams (some with a
// rigid body), a chain (universal joint then screw at one point), joints to the ground, and a
// driven revolute. Every slave node also carries elements, loads or inertia.
const char *kJointModel = R"(
functions:
  - {name: drive, type: harmonic, amplitude: 0.4, frequency: 0.5}
sections:
  - {name: s, EA: 3.0e3, GA2: 1.2e3, GA3: 9.0e2, GJ: 40, EI2: 60, EI3: 80, rhoA: 1.5, rhoJ: [0.03, 0.02, 0.01]}
nodes:
  base: [0, 0, 0]
  hub: [2, 0, 0]
  r0: [2, 0, 0]
  r1: [2, 1, 0]
  u0: [0.5, 0, 0]
  s0: [0.5, 0, 0]
  s1: [0.5, 0, 1.2]
  p0: [1.2, 0, 0]
  p1: [1.2, -1, 0.3]
  c0: [1.6, 0, 0]
  c1: [1.6, 0.2, 1]
  k0: [2.5, 0.3, 0]
  k1: [3.3, 0.3, 0.4]
  q0: [1.0, 0, 0]
  q1: [1.0, 0.9, -0.2]
  f0: [2.0, 0.5, 0.5]
  f1: [2.8, 0.6, 0.9]
beams:
  - {name: main, section: s, from: base, to: hub, elements: 4, order: 2}
  - {name: rotor, section: s, from: r0, to: r1, elements: 2}
  - {name: screwed, section: s, from: s0, to: s1, elements: 2}
  - {name: slider, section: s, from: p0, to: p1, elements: 2}
  - {name: follower, section: s, from: c0, to: c1, elements: 2, order: 2}
  - {name: rack, section: s, from: k0, to: k1, elements: 2}
  - {name: planar, section: s, from: q0, to: q1, elements: 2}
  - {name: floating, section: s, from: f0, to: f1, elements: 2}
joints:
  - {name: hinge, type: revolute, master: hub, slave: r0, axis: [0, 1, 1], drive: {coordinate: rotation, value: 1.0, function: drive}}
  - {name: cross, type: universal, master: main.1, slave: u0, axis: [1, 0, 0], second_axis: [0, 1, 0]}
  - {name: lead, type: screw, master: u0, slave: s0, axis: [1, 0, 0], pitch: 0.3}
  - {name: guide, type: prismatic, master: main.4, slave: p0, axis: [0, 1, 0.2]}
  - {name: lobe, type: cam, master: main.6, slave: c0, axis: [1, 0, 0], second_axis: [0, 0, 1], radius: 0.15}
  - {name: pinion, type: rack_pinion, master: ground, slave: k0, axis: [0, 0, 1], second_axis: [1, 0, 0], radius: 0.2}
  - {name: flat, type: planar, master: main.2, slave: q0, axis: [0, 0, 1]}
  - {name: ball, type: spherical, master: ground, slave: f0}
supports:
  - {nodes: base, fix: all}
loads:
  - {nodes: [r1, s1, p1, c1, k1, q1, f1], force: [3, -2, 1], moment: [1, 2, -1]}
  - {nodes: s1, force: [1, 1, -4], moment: [-2, 1, 3], follower: true}
  - {gravity: [0, 0, -9.81]}
rigid_bodies:
  - {node: s0, mass: 2.5, inertia: [[0.4, 0.05, 0.0], [0.05, 0.3, 0.02], [0.0, 0.02, 0.5]], offset: [0.2, -0.1, 0.15]}
  - {node: k1, mass: 1.0, inertia: [0.1, 0.1, 0.1]}
initial_conditions:
  - {nodes: [main, rotor, screwed, slider, follower, rack, planar, floating], velocity: [0.3, -0.2, 0.1], angular_velocity: [0.5, -0.4, 0.8], rigid_body_center: [0.3, 0.1, 2]}
analysis: {type: dynamic}   # a mechanism: the static rigid-body check would refuse it; the test sets up each problem itself
)";

// Force elements and structural damping on a mechanism: coordinate springs (linear and
// tabulated), dampers and actuators on a revolute (slave on a beam), a prismatic (to the ground)
// and a driven revolute's coordinate; a spring-damper between two beams that share no element
// (one end a joint's slave); a bushing between a beam node and a node carrying only a rigid body,
// and one between two slaves; damped sections (stiffness-proportional and given).
const char *kForceElementModel = R"(
functions:
  - {name: drive, type: harmonic, amplitude: 0.4, frequency: 0.5}
  - {name: torque, type: linear, slope: 2.0, offset: 1.0}
sections:
  - {name: s, EA: 3.0e3, GA2: 1.2e3, GA3: 9.0e2, GJ: 40, EI2: 60, EI3: 80, rhoA: 1.5, rhoJ: [0.03, 0.02, 0.01], damping_time: 0.02}
  - {name: d, EA: 2.0e3, GA2: 1.0e3, GA3: 8.0e2, GJ: 30, EI2: 50, EI3: 70, rhoA: 1.0, rhoJ: [0.02, 0.02, 0.01], damping: [5, 2, 2, 0.1, 0.2, 0.3]}
nodes:
  base: [0, 0, 0]
  hub: [1.5, 0, 0]
  a0: [1.5, 0, 0]
  a1: [1.5, 1.2, 0.3]
  p0: [0.5, -0.5, 0.2]
  p1: [0.2, -1.5, 0.6]
  m0: [0.8, 0.0, 0.0]
  m1: [0.8, 0.4, -0.9]
  body: [1.1, 0.3, -0.4]
beams:
  - {name: main, section: s, from: base, to: hub, elements: 3, order: 2}
  - {name: arm, section: d, from: a0, to: a1, elements: 2}
  - {name: slide, section: s, from: p0, to: p1, elements: 2}
  - {name: motor, section: d, from: m0, to: m1, elements: 2, order: 2}
joints:
  - {name: hinge, type: revolute, master: hub, slave: a0, axis: [0, 1, 1]}
  - {name: rail, type: prismatic, master: ground, slave: p0, axis: [0.3, 1, 0]}
  - {name: shaft, type: revolute, master: main.2, slave: m0, axis: [0, 0, 1], drive: {coordinate: rx, value: 1.0, function: drive}}
force_elements:
  - {name: k_hinge, type: coordinate, joint: hinge, coordinate: rx, stiffness: 35, free_value: 0.2, damping: 0.8, actuator: 1.5, function: torque}
  - {name: k_rail, type: coordinate, joint: rail, coordinate: tx, force_table: [[-0.3, -40], [0, 0], [0.02, 1], [0.4, 30]], damping: 2.0}
  - {name: k_shaft, type: coordinate, joint: shaft, coordinate: rotation, stiffness: 10, damping: 0.3}
  - {name: strut, type: spring_damper, nodes: [arm.1, slide.1], stiffness: 80, damping: 4}
  - {name: strut2, type: spring_damper, nodes: [p1, a0], force_table: [[-1, -50], [0.1, 10], [1, 20]], free_length: 1.4, damping: 1}
  - {name: mount, type: bushing, nodes: [main.4, body], stiffness: [300, 200, 250, 20, 30, 25], damping: [3, 2, 2, 0.2, 0.3, 0.1], axis: [1, 1, 0]}
  - name: link
    type: bushing
    nodes: [a0, m0]
    stiffness: [[200, 10, 0, 5, 0, 0], [10, 150, 0, 0, 3, 0], [0, 0, 180, 0, 0, 2], [5, 0, 0, 15, 0, 0], [0, 3, 0, 0, 12, 0], [0, 0, 2, 0, 0, 10]]
    damping: [1, 1, 1, 0.05, 0.05, 0.05]
supports:
  - {nodes: base, fix: all}
loads:
  - {nodes: [a1, p1, m1], force: [3, -2, 1], moment: [1, 2, -1]}
  - {gravity: [0, 0, -9.81]}
rigid_bodies:
  - {name: block, node: body, mass: 2.0, inertia: [0.2, 0.3, 0.25], offset: [0.05, -0.1, 0.1]}
initial_conditions:
  - {nodes: [main, arm, slide, motor, body], velocity: [0.3, -0.2, 0.1], angular_velocity: [0.5, -0.4, 0.8], rigid_body_center: [0.3, 0.1, 2]}
analysis: {type: dynamic}
)";

// Which problem the assembler is set up for.
enum class Problem { Static, Newmark, GeneralizedAlpha, InitialAcceleration, MomentumConserving, EnergyMomentum };

struct AssembledSystem {
  Model            model;
  DofMap           map;
  MechanicalSystem system;
};

StepEquations EquationsOf(Problem problem)
{
  switch (problem) {
  case Problem::Static:
    return StaticStep(0.0, 0.8);
  case Problem::Newmark:
  case Problem::GeneralizedAlpha:
    return DynamicStep(MakeTimeScheme(problem == Problem::Newmark ? TimeSchemeKind::Newmark : TimeSchemeKind::GeneralizedAlpha, 0.6, 0.05), 0.0);
  case Problem::MomentumConserving:
  case Problem::EnergyMomentum:
    return DynamicStep(MakeTimeScheme(problem == Problem::EnergyMomentum ? TimeSchemeKind::EnergyMomentum : TimeSchemeKind::MomentumConserving, 0.6, 0.05),
                       0.0);
  case Problem::InitialAcceleration:
    break;
  }
  return InitialAccelerationProblem(0.0);
}

// The system of a model (whole, or restricted with the pattern and masses of the whole), with its
// initial velocities, set up for `problem`.
PetscErrorCode SetupSystem(Model *model, DofMap *map, MatrixPattern pattern, NodalMass mass, Problem problem, MechanicalSystem *system)
{
  PetscFunctionBeginUser;
  PetscCall(system->Setup(PETSC_COMM_WORLD, *model, *map, std::move(pattern), std::move(mass)));
  StateSetInitialVelocities(*model, *map, 0.0, &system->GetState());
  StateSetCoordinateRates(*model, *map, 0.0, &system->GetState());
  system->StartMotion(); // strain rates of the damped beams
  PetscCall(system->GetAssembler().BeginStep(EquationsOf(problem)));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Build(const char *text, Problem problem, AssembledSystem *system)
{
  InputError error;
  PetscFunctionBeginUser;
  PetscCheck(ReadModelString(text, "test_assembly", &system->model, &error), PETSC_COMM_WORLD, PETSC_ERR_USER_INPUT, "%s", error.Format().c_str());
  std::vector<int> node_rank;
  PetscCall(PartitionNodes(PETSC_COMM_WORLD, system->model, PartitionerType::Simple, &node_rank));
  PetscCall(DofMapCreate(PETSC_COMM_WORLD, system->model, node_rank, &system->map));
  MatrixPattern pattern;
  NodalMass     mass;
  PetscCall(MechanicalSystemPrepare(system->model, system->map, &pattern, &mass));
  PetscCall(SetupSystem(&system->model, &system->map, std::move(pattern), std::move(mass), problem, &system->system));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Residual(Assembler &assembler, Vec x, Vec r)
{
  PetscBool ok;
  PetscFunctionBeginUser;
  PetscCall(assembler.SetIncrements(x));
  PetscCall(assembler.AssembleResidual(r, &ok));
  PetscCheck(ok, PETSC_COMM_SELF, PETSC_ERR_PLIB, "residual not evaluable");
  PetscFunctionReturn(PETSC_SUCCESS);
}

// ||J - J_fd||_F / ||J||_F with J_fd by central differences, column by column.
// `residual_first`: the residual is assembled at the same unknowns just before the tangent, as SNES
// does (em then takes beta from that residual and adds K_corr element by element).
PetscErrorCode JacobianRelativeError(const char *text, Problem problem, double *relative_error, bool *rank_one_active = nullptr, bool residual_first = false)
{
  bool unused;
  if (!rank_one_active) rank_one_active = &unused;
  *rank_one_active = false;
  AssembledSystem system;
  Vec             x, r_plus, r_minus, column;
  Mat             fd;
  PetscInt        n, first, last;
  PetscFunctionBeginUser;
  PetscCall(Build(text, problem, &system));
  Assembler &assembler = system.system.GetAssembler();
  PetscCall(VecDuplicate(assembler.SolutionTemplate(), &x));
  PetscCall(VecDuplicate(x, &r_plus));
  PetscCall(VecDuplicate(x, &r_minus));
  PetscCall(VecDuplicate(x, &column));
  PetscCall(VecGetSize(x, &n));
  PetscCall(VecGetOwnershipRange(x, &first, &last));
  // A deformed state: increments of up to 0.15 in displacement and 0.6 rad in rotation.
  std::mt19937                           gen(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (PetscInt i = 0; i < n; ++i) {
    const double value = u(gen);
    if (i >= first && i < last) PetscCall(VecSetValue(x, i, value * 0.15, INSERT_VALUES));
  }
  PetscCall(VecAssemblyBegin(x));
  PetscCall(VecAssemblyEnd(x));
  PetscBool ok;
  if (residual_first) PetscCall(Residual(assembler, x, r_plus));
  PetscCall(assembler.SetIncrements(x));
  PetscCall(assembler.AssembleJacobian(assembler.Jacobian(), &ok));
  PetscCheck(ok, PETSC_COMM_SELF, PETSC_ERR_PLIB, "jacobian not evaluable");
  // em: the operator is the assembled tangent plus the rank-one term a b^T (beta couples every
  // element); the finite differences are compared with it, b gathered on every rank.
  Vec        a, b, b_all = nullptr;
  bool       rank_one;
  VecScatter to_all = nullptr;
  assembler.RankOneTerm(&a, &b, &rank_one);
  if (rank_one) {
    PetscCall(VecScatterCreateToAll(b, &to_all, &b_all));
    PetscCall(VecScatterBegin(to_all, b, b_all, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(to_all, b, b_all, INSERT_VALUES, SCATTER_FORWARD));
    PetscReal b_norm;
    PetscCall(VecNorm(b, NORM_2, &b_norm));
    PetscCheck(b_norm > 0.0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "em's rank-one term is zero");
    *rank_one_active = true;
  }
  PetscCall(MatDuplicate(assembler.Jacobian(), MAT_DO_NOT_COPY_VALUES, &fd));
  PetscCall(MatSetOption(fd, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE));
  const double h = 1e-6;
  for (PetscInt j = 0; j < n; ++j) {
    const bool owner = j >= first && j < last; // only the owner perturbs x_j
    if (owner) PetscCall(VecSetValue(x, j, h, ADD_VALUES));
    PetscCall(VecAssemblyBegin(x));
    PetscCall(VecAssemblyEnd(x));
    PetscCall(Residual(assembler, x, r_plus));
    if (owner) PetscCall(VecSetValue(x, j, -2 * h, ADD_VALUES));
    PetscCall(VecAssemblyBegin(x));
    PetscCall(VecAssemblyEnd(x));
    PetscCall(Residual(assembler, x, r_minus));
    if (owner) PetscCall(VecSetValue(x, j, h, ADD_VALUES));
    PetscCall(VecAssemblyBegin(x));
    PetscCall(VecAssemblyEnd(x));
    PetscCall(VecWAXPY(column, -1.0, r_minus, r_plus));
    PetscCall(VecScale(column, 1.0 / (2 * h)));
    if (to_all) { // the rank-one part of column j: a b_j
      const PetscScalar *b_values;
      PetscCall(VecGetArrayRead(b_all, &b_values));
      const PetscScalar b_j = b_values[j];
      PetscCall(VecRestoreArrayRead(b_all, &b_values));
      PetscCall(VecAXPY(column, -b_j, a));
    }
    const PetscScalar *values;
    PetscCall(VecGetArrayRead(column, &values));
    for (PetscInt i = first; i < last; ++i)
      if (values[i - first] != 0.0) PetscCall(MatSetValue(fd, i, j, values[i - first], INSERT_VALUES));
    PetscCall(VecRestoreArrayRead(column, &values));
  }
  PetscCall(MatAssemblyBegin(fd, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(fd, MAT_FINAL_ASSEMBLY));
  PetscReal jacobian_norm, difference_norm;
  PetscCall(MatNorm(assembler.Jacobian(), NORM_FROBENIUS, &jacobian_norm));
  PetscCall(MatAXPY(fd, -1.0, assembler.Jacobian(), DIFFERENT_NONZERO_PATTERN));
  PetscCall(MatNorm(fd, NORM_FROBENIUS, &difference_norm));
  *relative_error = difference_norm / jacobian_norm;
  PetscCall(VecScatterDestroy(&to_all));
  PetscCall(VecDestroy(&b_all));
  PetscCall(MatDestroy(&fd));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&r_plus));
  PetscCall(VecDestroy(&r_minus));
  PetscCall(VecDestroy(&column));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

// Checks the Jacobian of `model` for statics, Newmark, genalpha, the initial-acceleration problem
// and the mid-point schemes mc and em (em: with its rank-one term, which must be active).
void CheckEveryProblem(const char *model, const char *label)
{
  const struct {
    Problem     problem;
    const char *name;
  } cases[] = {{Problem::Static, "statics"},
               {Problem::Newmark, "newmark"},
               {Problem::GeneralizedAlpha, "genalpha"},
               {Problem::InitialAcceleration, "initial accelerations"},
               {Problem::MomentumConserving, "mc"},
               {Problem::EnergyMomentum, "em"}};
  PetscMPIInt size;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  for (const auto &c : cases) {
    double relative_error = 1.0;
    bool   rank_one       = false;
    ASSERT_EQ(JacobianRelativeError(model, c.problem, &relative_error, &rank_one), PETSC_SUCCESS) << c.name;
    PetscPrintf(PETSC_COMM_WORLD, "assembled Jacobian%s, %s, %d rank(s): ||J - J_fd||_F / ||J||_F = %.2e\n", label, c.name, size, relative_error);
    EXPECT_LT(relative_error, 1e-6) << c.name;
    EXPECT_EQ(rank_one, c.problem == Problem::EnergyMomentum) << c.name;
  }
  // em's tangent at the iterate of the last residual (beta taken from it, K_corr added per element).
  double relative_error = 1.0;
  bool   rank_one       = false;
  ASSERT_EQ(JacobianRelativeError(model, Problem::EnergyMomentum, &relative_error, &rank_one, true), PETSC_SUCCESS);
  PetscPrintf(PETSC_COMM_WORLD, "assembled Jacobian%s, em after the residual, %d rank(s): ||J - J_fd||_F / ||J||_F = %.2e\n", label, size, relative_error);
  EXPECT_LT(relative_error, 1e-6);
  EXPECT_TRUE(rank_one);
}

TEST(AssembledSystem, JacobianMatchesFiniteDifferences) { CheckEveryProblem(kModel, ""); }

// The same with joints of every kind condensed at assembly.
TEST(AssembledSystem, JacobianWithJointsMatchesFiniteDifferences) { CheckEveryProblem(kJointModel, " with joints"); }

// The same with force elements on joint coordinates and between nodes, and damped beams.
TEST(AssembledSystem, JacobianWithForceElementsMatchesFiniteDifferences) { CheckEveryProblem(kForceElementModel, " with force elements"); }

// Each joint kind alone: a clamped beam carrying a second beam (with a rigid body at its far end)
// through the joint, in a deformed, rotated, moving state; statics and Newmark.
std::string SingleJointModel(const std::string &joint_keys)
{
  return R"(
sections:
  - {name: s, EA: 3.0e3, GA2: 1.2e3, GA3: 9.0e2, GJ: 40, EI2: 60, EI3: 80, rhoA: 1.5, rhoJ: [0.03, 0.02, 0.01]}
nodes:
  base: [0, 0, 0]
  hub: [1.5, 0.2, 0.1]
  arm0: [1.5, 0.2, 0.1]
  arm1: [2.1, 1.3, -0.4]
beams:
  - {name: main, section: s, from: base, to: hub, elements: 3, order: 2}
  - {name: arm, section: s, from: arm0, to: arm1, elements: 3}
joints:
  - {name: j, master: hub, slave: arm0, axis: [0.2, 0.3, 1], second_axis: [1, 0, 0], )" +
         joint_keys + R"(}
supports:
  - {nodes: base, fix: all}
loads:
  - {nodes: arm1, force: [3, -2, 1], moment: [1, 2, -1]}
  - {nodes: arm0, force: [0.5, 1, -1], follower: true}
rigid_bodies:
  - {node: arm1, mass: 1.5, inertia: [0.2, 0.1, 0.15], offset: [0.1, 0.05, -0.1]}
initial_conditions:
  - {nodes: [main, arm], velocity: [0.3, -0.2, 0.1], angular_velocity: [0.5, -0.4, 0.8], rigid_body_center: [0.3, 0.1, 2]}
analysis: {type: dynamic}
)";
}

TEST(AssembledSystem, JacobianOfEveryJointKindMatchesFiniteDifferences)
{
  const struct {
    const char *kind, *keys;
  } joints[] = {{"rigid", "type: rigid"},
                {"spherical", "type: spherical"},
                {"revolute", "type: revolute"},
                {"universal", "type: universal"},
                {"cylindrical", "type: cylindrical"},
                {"prismatic", "type: prismatic"},
                {"planar", "type: planar"},
                {"free", "type: free"},
                {"custom", "type: custom, release: [ty, rz, rx]"},
                {"screw", "type: screw, pitch: 0.3"},
                {"rack_pinion", "type: rack_pinion, radius: 0.2"},
                {"cam", "type: cam, radius: 0.15"},
                {"cam_table", "type: cam_table, profile: {points: [[0, 0], [1, 0.1], [2.5, 0.15], [4, 0.05], [5.5, -0.02]]}"}};
  PetscMPIInt size;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  for (const auto &joint : joints) {
    const std::string model = SingleJointModel(joint.keys);
    for (Problem problem : {Problem::Static, Problem::Newmark, Problem::EnergyMomentum}) {
      double relative_error = 1.0;
      ASSERT_EQ(JacobianRelativeError(model.c_str(), problem, &relative_error), PETSC_SUCCESS) << joint.kind;
      PetscPrintf(PETSC_COMM_WORLD, "assembled Jacobian, %-11s joint, %-7s, %d rank(s): %.2e\n", joint.kind,
                  problem == Problem::Static    ? "statics"
                  : problem == Problem::Newmark ? "newmark"
                                                : "em",
                  size, relative_error);
      EXPECT_LT(relative_error, 1e-6) << joint.kind;
    }
  }
}

// Restricting the model to each rank's part (what the analysis does after set-up) changes no number:
// residual, tangent, joint output and initial velocities are bitwise those of the whole model, and
// afterwards every rank holds only its local nodes, elements and joints.
struct AssembledState {
  Vec                      residual = nullptr;
  Mat                      jacobian = nullptr;
  std::vector<std::string> joint_names;
  std::vector<double>      joint_values;
};

PetscErrorCode AssembleState(const Model &model, const DofMap &map, MechanicalSystem &system, Vec x, AssembledState *state)
{
  PetscBool     ok;
  Assembler    &assembler = system.GetAssembler();
  HistoryGather names;
  PetscFunctionBeginUser;
  PetscCall(assembler.SetIncrements(x));
  PetscCall(VecDuplicate(x, &state->residual));
  PetscCall(assembler.AssembleResidual(state->residual, &ok));
  PetscCall(assembler.AssembleJacobian(assembler.Jacobian(), &ok));
  PetscCall(MatDuplicate(assembler.Jacobian(), MAT_COPY_VALUES, &state->jacobian));
  PetscCall(assembler.EvaluateJointReactions(0.05));
  PetscCall(JointHistory(PETSC_COMM_WORLD, model, map, system.GetState(), &names, &state->joint_names, &state->joint_values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

TEST(AssembledSystem, RestrictedModelAssemblesIdentically)
{
  PetscMPIInt size, rank;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  for (Problem problem : {Problem::Static, Problem::Newmark}) {
    AssembledSystem system;
    ASSERT_EQ(Build(kJointModel, problem, &system), PETSC_SUCCESS);
    const size_t num_nodes = system.model.nodes.size(), num_elements = system.model.elements.size(), num_joints = system.model.joints.size();
    Vec          x;
    PetscInt     first, last;
    ASSERT_EQ(VecDuplicate(system.system.GetAssembler().SolutionTemplate(), &x), PETSC_SUCCESS);
    ASSERT_EQ(VecGetOwnershipRange(x, &first, &last), PETSC_SUCCESS);
    for (PetscInt i = first; i < last; ++i) ASSERT_EQ(VecSetValue(x, i, 0.1 * std::sin(1.0 + 3.7 * (double)i), INSERT_VALUES), PETSC_SUCCESS);
    ASSERT_EQ(VecAssemblyBegin(x), PETSC_SUCCESS);
    ASSERT_EQ(VecAssemblyEnd(x), PETSC_SUCCESS);
    AssembledState whole, restricted;
    ASSERT_EQ(AssembleState(system.model, system.map, system.system, x, &whole), PETSC_SUCCESS);
    // The distributed model: a new model and map, and a system built on them.
    Model            local_model;
    DofMap           local_map;
    MatrixPattern    pattern;
    NodalMass        mass;
    MechanicalSystem local_system;
    ASSERT_EQ(MechanicalSystemPrepare(system.model, system.map, &pattern, &mass), PETSC_SUCCESS);
    ASSERT_EQ(DofMapRestrictToLocal(system.model, system.map, &local_model, &local_map), PETSC_SUCCESS);
    ASSERT_EQ(SetupSystem(&local_model, &local_map, std::move(pattern), std::move(mass), problem, &local_system), PETSC_SUCCESS);
    ASSERT_EQ(AssembleState(local_model, local_map, local_system, x, &restricted), PETSC_SUCCESS);

    PetscReal residual_difference, jacobian_difference, residual_norm, jacobian_norm;
    ASSERT_EQ(VecNorm(whole.residual, NORM_2, &residual_norm), PETSC_SUCCESS);
    ASSERT_EQ(MatNorm(whole.jacobian, NORM_FROBENIUS, &jacobian_norm), PETSC_SUCCESS);
    ASSERT_EQ(VecAXPY(restricted.residual, -1.0, whole.residual), PETSC_SUCCESS);
    ASSERT_EQ(MatAXPY(restricted.jacobian, -1.0, whole.jacobian, SAME_NONZERO_PATTERN), PETSC_SUCCESS);
    ASSERT_EQ(VecNorm(restricted.residual, NORM_2, &residual_difference), PETSC_SUCCESS);
    ASSERT_EQ(MatNorm(restricted.jacobian, NORM_FROBENIUS, &jacobian_difference), PETSC_SUCCESS);
    EXPECT_GT(residual_norm, 1.0);
    EXPECT_GT(jacobian_norm, 1.0);
    EXPECT_EQ(residual_difference, 0.0);
    EXPECT_EQ(jacobian_difference, 0.0);
    EXPECT_EQ(whole.joint_names, restricted.joint_names);
    EXPECT_EQ(whole.joint_values, restricted.joint_values);
    if (rank == 0) {
      EXPECT_GT(whole.joint_names.size(), 6 * num_joints); // every joint: its coordinates, rates, force, moment
    }

    // Only the local part remains, numbered locally; the output numbering keeps the global rows.
    const DofMap &map = local_map;
    EXPECT_EQ(local_model.nodes.size(), map.local_nodes.size());
    EXPECT_EQ(map.node_dofs.size(), map.local_nodes.size());
    EXPECT_EQ(map.node_unknowns.size(), map.local_nodes.size());
    EXPECT_EQ(map.global_nodes.size(), map.local_nodes.size());
    EXPECT_EQ(local_model.elements.size(), map.local_elements.size());
    EXPECT_EQ(local_model.joints.size(), map.local_joints.size());
    EXPECT_EQ(map.global_count.nodes, (PetscInt)num_nodes);
    EXPECT_EQ(map.global_count.elements, (PetscInt)num_elements);
    EXPECT_TRUE(local_model.node_sets.empty() && local_model.input_text.empty());
    for (const Beam &beam : local_model.beams) EXPECT_TRUE(beam.elements.empty() && beam.nodes.empty()); // names only
    if (size > 1) {
      EXPECT_LT(local_model.nodes.size(), num_nodes);
      EXPECT_LT(local_model.elements.size(), num_elements);
    }
    PetscInt owned_nodes = map.num_owned_nodes, total_owned = 0;
    MPI_Allreduce(&owned_nodes, &total_owned, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD);
    EXPECT_EQ(total_owned, (PetscInt)num_nodes);
    for (const BeamElement &element : local_model.elements)
      for (int a = 0; a <= element.order; ++a) EXPECT_TRUE(element.nodes[a] >= 0 && element.nodes[a] < (int)local_model.nodes.size());
    VecDestroy(&x);
    for (AssembledState *state : {&whole, &restricted}) {
      VecDestroy(&state->residual);
      MatDestroy(&state->jacobian);
    }
  }
}

// Unknowns x_i = amplitude sin(phase + rate i): a deformed, moving state with every unknown set.
PetscErrorCode SetWavyIncrements(Vec x, double amplitude, double phase, double rate)
{
  PetscInt first, last;
  PetscFunctionBeginUser;
  PetscCall(VecGetOwnershipRange(x, &first, &last));
  for (PetscInt i = first; i < last; ++i) PetscCall(VecSetValue(x, i, amplitude * std::sin(phase + rate * (double)i), INSERT_VALUES));
  PetscCall(VecAssemblyBegin(x));
  PetscCall(VecAssemblyEnd(x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The strain energy the residual pass keeps for the history: the same as a pass over the elements
// at those unknowns (end-point and mid-point kernels), and given only while the State holds them.
TEST(AssembledSystem, ResidualKeepsTheStrainEnergyOfItsUnknowns)
{
  for (Problem problem : {Problem::Static, Problem::Newmark, Problem::EnergyMomentum}) {
    AssembledSystem system;
    ASSERT_EQ(Build(kJointModel, problem, &system), PETSC_SUCCESS);
    Assembler &assembler = system.system.GetAssembler();
    Vec        x, r;
    ASSERT_EQ(VecDuplicate(assembler.SolutionTemplate(), &x), PETSC_SUCCESS);
    ASSERT_EQ(VecDuplicate(x, &r), PETSC_SUCCESS);
    ASSERT_EQ(SetWavyIncrements(x, 0.05, 1.0, 3.0), PETSC_SUCCESS);
    double kept = 0.0, recomputed = 0.0;
    EXPECT_FALSE(assembler.LastResidualStrainEnergy(&kept)) << "no residual yet";
    ASSERT_EQ(Residual(assembler, x, r), PETSC_SUCCESS);
    ASSERT_TRUE(assembler.LastResidualStrainEnergy(&kept));
    ASSERT_TRUE(system.system.Beams().StrainEnergy(system.system.GetState(), &recomputed));
    EXPECT_GT(recomputed, 0.0);
    EXPECT_NEAR(kept, recomputed, 1e-12 * recomputed) << "problem " << (int)problem;
    // The same unknowns again: still the residual's; other unknowns or a State changed otherwise: not.
    ASSERT_EQ(assembler.SetIncrements(x), PETSC_SUCCESS);
    EXPECT_TRUE(assembler.LastResidualStrainEnergy(&kept));
    assembler.ForgetIncrements();
    EXPECT_FALSE(assembler.LastResidualStrainEnergy(&kept));
    ASSERT_EQ(Residual(assembler, x, r), PETSC_SUCCESS);
    ASSERT_EQ(VecScale(x, 0.5), PETSC_SUCCESS);
    ASSERT_EQ(assembler.SetIncrements(x), PETSC_SUCCESS);
    EXPECT_FALSE(assembler.LastResidualStrainEnergy(&kept));
    // MechanicalSystem::StrainEnergy is right either way (here from a pass over the elements).
    double total = 0.0;
    ASSERT_EQ(system.system.StrainEnergy(&total), PETSC_SUCCESS);
    ASSERT_TRUE(system.system.Beams().StrainEnergy(system.system.GetState(), &recomputed));
    double recomputed_total = 0.0;
    MPI_Allreduce(&recomputed, &recomputed_total, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    EXPECT_NEAR(total, recomputed_total, 1e-14 * recomputed_total);
    VecDestroy(&x);
    VecDestroy(&r);
  }
}

// Newton assembles the residual of its line search and the tangent there in one pass
// (AssembleResidualWithJacobian): the residual, the tangent and what the residual leaves behind
// for the step's external work and the joint reactions (CurrentResidualByProducts) equal those of
// the separate passes, on joints with chains (condensed whole, and with relay nodes every joint),
// rigid bodies, follower loads, force elements on coordinates and nodes, drives and damped
// sections, in statics, the Newmark family, mc and em (whose rank-one term must be the same too,
// and whose tangent after a residual that kept nothing, Newton's guess of convergence gone wrong,
// as well). The matrix counts as the tangent of its unknowns only until they or the matrix change.
TEST(AssembledSystem, ResidualWithJacobianEqualsTheSeparatePasses)
{
  const std::string joints = kJointModel;
  const std::string relays = joints.substr(0, joints.rfind("analysis:")) + "analysis: {type: dynamic, condensation_depth: 1}\n";
  const struct {
    const char *name;
    std::string text;
  } models[] = {{"joints", joints}, {"joints with relays", relays}, {"force elements", kForceElementModel}};
  for (const auto &model : models) {
    for (Problem problem : {Problem::Static, Problem::Newmark, Problem::GeneralizedAlpha, Problem::MomentumConserving, Problem::EnergyMomentum}) {
      AssembledSystem separate, together;
      ASSERT_EQ(Build(model.text.c_str(), problem, &separate), PETSC_SUCCESS);
      ASSERT_EQ(Build(model.text.c_str(), problem, &together), PETSC_SUCCESS);
      Assembler &a = separate.system.GetAssembler(), &b = together.system.GetAssembler();
      ASSERT_TRUE(b.CanAssembleResidualWithJacobian());
      Vec x, r_separate, r_together;
      Mat J_separate;
      ASSERT_EQ(VecDuplicate(a.SolutionTemplate(), &x), PETSC_SUCCESS);
      ASSERT_EQ(VecDuplicate(x, &r_separate), PETSC_SUCCESS);
      ASSERT_EQ(VecDuplicate(x, &r_together), PETSC_SUCCESS);
      ASSERT_EQ(SetWavyIncrements(x, 0.04, 0.7, 2.3), PETSC_SUCCESS);
      // Separate: residual, then the tangent (whose pass rebuilds the slave residuals, so the
      // by-products come from a new residual pass).
      PetscBool ok_separate, ok_together;
      ASSERT_EQ(a.SetIncrements(x), PETSC_SUCCESS);
      ASSERT_EQ(a.AssembleResidual(r_separate, &ok_separate), PETSC_SUCCESS);
      ASSERT_EQ(a.AssembleJacobian(a.Jacobian(), &ok_separate), PETSC_SUCCESS);
      EXPECT_FALSE(a.JacobianCurrent()) << "AssembleJacobian alone is no residual's tangent";
      ASSERT_EQ(MatDuplicate(a.Jacobian(), MAT_COPY_VALUES, &J_separate), PETSC_SUCCESS);
      // Together: one pass, whose by-products serve the work and the reactions.
      ASSERT_EQ(b.SetIncrements(x), PETSC_SUCCESS);
      ASSERT_EQ(b.AssembleResidualWithJacobian(r_together, &ok_together), PETSC_SUCCESS);
      ASSERT_TRUE(ok_separate && ok_together);
      EXPECT_TRUE(b.JacobianCurrent());
      ASSERT_EQ(b.SetIncrements(x, true), PETSC_SUCCESS);
      EXPECT_TRUE(b.JacobianCurrent()) << "the same unknowns again";

      PetscReal residual_norm, residual_difference, tangent_norm, tangent_difference;
      ASSERT_EQ(VecNorm(r_separate, NORM_INFINITY, &residual_norm), PETSC_SUCCESS);
      ASSERT_EQ(VecAXPY(r_together, -1.0, r_separate), PETSC_SUCCESS);
      ASSERT_EQ(VecNorm(r_together, NORM_INFINITY, &residual_difference), PETSC_SUCCESS);
      ASSERT_EQ(MatNorm(J_separate, NORM_FROBENIUS, &tangent_norm), PETSC_SUCCESS);
      ASSERT_EQ(MatAXPY(J_separate, -1.0, b.Jacobian(), SAME_NONZERO_PATTERN), PETSC_SUCCESS);
      ASSERT_EQ(MatNorm(J_separate, NORM_FROBENIUS, &tangent_difference), PETSC_SUCCESS);
      EXPECT_GT(residual_norm, 0.0);
      EXPECT_LE(residual_difference, 1e-13 * residual_norm) << model.name << ", problem " << (int)problem;
      EXPECT_LE(tangent_difference, 1e-13 * tangent_norm) << model.name << ", problem " << (int)problem;
      if (problem == Problem::EnergyMomentum) {
        // The rank-one term R_corr (grad beta)^T of both paths, and of a tangent assembled after a
        // residual that kept no iterate (the beam kernels then evaluate afresh).
        AssembledSystem guessed;
        ASSERT_EQ(Build(model.text.c_str(), problem, &guessed), PETSC_SUCCESS);
        Assembler &c = guessed.system.GetAssembler();
        Vec        r_guessed;
        PetscBool  ok_guessed;
        ASSERT_EQ(VecDuplicate(x, &r_guessed), PETSC_SUCCESS);
        ASSERT_EQ(c.SetIncrements(x), PETSC_SUCCESS);
        ASSERT_EQ(c.AssembleResidual(r_guessed, &ok_guessed, false), PETSC_SUCCESS);
        ASSERT_EQ(c.AssembleJacobian(c.Jacobian(), &ok_guessed), PETSC_SUCCESS);
        ASSERT_TRUE(ok_guessed);
        Mat J_guessed;
        ASSERT_EQ(MatDuplicate(c.Jacobian(), MAT_COPY_VALUES, &J_guessed), PETSC_SUCCESS);
        ASSERT_EQ(MatAXPY(J_guessed, -1.0, a.Jacobian(), SAME_NONZERO_PATTERN), PETSC_SUCCESS);
        ASSERT_EQ(MatNorm(J_guessed, NORM_FROBENIUS, &tangent_difference), PETSC_SUCCESS);
        EXPECT_LE(tangent_difference, 1e-13 * tangent_norm) << model.name << ", em after a residual that kept nothing";
        Vec  left[3], right[3];
        bool active[3];
        a.RankOneTerm(&left[0], &right[0], &active[0]);
        b.RankOneTerm(&left[1], &right[1], &active[1]);
        c.RankOneTerm(&left[2], &right[2], &active[2]);
        ASSERT_TRUE(active[0] && active[1] && active[2]) << model.name << ": beta is not zero at these increments";
        for (int other = 1; other < 3; ++other)
          for (auto [mine, theirs] : {std::pair{left[0], left[other]}, std::pair{right[0], right[other]}}) {
            PetscReal norm, difference;
            Vec       d;
            ASSERT_EQ(VecDuplicate(mine, &d), PETSC_SUCCESS);
            ASSERT_EQ(VecWAXPY(d, -1.0, mine, theirs), PETSC_SUCCESS);
            ASSERT_EQ(VecNorm(mine, NORM_INFINITY, &norm), PETSC_SUCCESS);
            ASSERT_EQ(VecNorm(d, NORM_INFINITY, &difference), PETSC_SUCCESS);
            EXPECT_GT(norm, 0.0);
            EXPECT_LE(difference, 1e-12 * norm) << model.name << ", rank-one vector, path " << other;
            VecDestroy(&d);
          }
        MatDestroy(&J_guessed);
        VecDestroy(&r_guessed);
      }
      if (problem != Problem::Static) {
        double work_separate = 0.0, work_together = 0.0;
        ASSERT_EQ(a.StepExternalWork(&work_separate), PETSC_SUCCESS);
        ASSERT_EQ(b.StepExternalWork(&work_together), PETSC_SUCCESS);
        EXPECT_NE(work_separate, 0.0);
        EXPECT_NEAR(work_together, work_separate, 1e-13 * std::abs(work_separate)) << model.name << ", problem " << (int)problem;
      }
      ASSERT_EQ(a.EvaluateJointReactions(0.05), PETSC_SUCCESS);
      ASSERT_EQ(b.EvaluateJointReactions(0.05), PETSC_SUCCESS);
      const State &state_separate = separate.system.GetState(), &state_together = together.system.GetState();
      ASSERT_EQ(state_separate.joints.size(), state_together.joints.size());
      for (size_t j = 0; j < state_separate.joints.size(); ++j) {
        const double scale = std::max(1.0, state_separate.joints[j].reaction.norm());
        EXPECT_LE((state_together.joints[j].reaction - state_separate.joints[j].reaction).norm(), 1e-12 * scale) << model.name << ", joint " << j;
      }

      // Other unknowns, or another matrix assembled: the matrix is no longer the current tangent.
      ASSERT_EQ(b.AssembleResidualWithJacobian(r_together, &ok_together), PETSC_SUCCESS);
      ASSERT_EQ(VecScale(x, 0.5), PETSC_SUCCESS);
      ASSERT_EQ(b.SetIncrements(x, true), PETSC_SUCCESS);
      EXPECT_FALSE(b.JacobianCurrent());
      ASSERT_EQ(b.AssembleResidualWithJacobian(r_together, &ok_together), PETSC_SUCCESS);
      ASSERT_EQ(b.AssembleJacobian(b.Jacobian(), &ok_together), PETSC_SUCCESS);
      EXPECT_FALSE(b.JacobianCurrent());
      ASSERT_EQ(b.AssembleResidualWithJacobian(r_together, &ok_together), PETSC_SUCCESS);
      b.ForgetIncrements();
      EXPECT_FALSE(b.JacobianCurrent());
      MatDestroy(&J_separate);
      VecDestroy(&x);
      VecDestroy(&r_separate);
      VecDestroy(&r_together);
    }
  }
  // The initial accelerations assemble apart.
  AssembledSystem initial;
  ASSERT_EQ(Build(kJointModel, Problem::InitialAcceleration, &initial), PETSC_SUCCESS);
  EXPECT_FALSE(initial.system.GetAssembler().CanAssembleResidualWithJacobian());
}

// The node-block tangent (BAIJ with blocks of 6, values added straight into its blocks) equals the
// scalar one (AIJ, straight into its rows) entry for entry, in every problem and for em's tangent
// after its residual (K_mc + beta K_corr from a second matrix), on 1 and 2 ranks. The frame of
// kModel without its partly fixed end, so that every unknown is in a node's block: dynamic and
// banded, it is BAIJ by default on one rank (Assembler::Setup); -jacobian_mat_type baij makes it
// BAIJ on two.
TEST(AssembledSystem, NodeBlockTangentEqualsTheScalarOne)
{
  std::string text = kModel;
  for (const char *line : {"  - {nodes: end, fix: [uz, rx]}\n", "  - {nodes: end, prescribe: {ry: 0.3}}\n"}) {
    const size_t at = text.find(line);
    ASSERT_NE(at, std::string::npos) << line;
    text.erase(at, strlen(line));
  }
  text += "analysis: {type: dynamic}\n";
  PetscMPIInt size;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  ASSERT_EQ(PetscOptionsSetValue(nullptr, "-jacobian_dense_below", "0"), PETSC_SUCCESS);
  for (Problem problem :
       {Problem::Static, Problem::Newmark, Problem::GeneralizedAlpha, Problem::InitialAcceleration, Problem::MomentumConserving, Problem::EnergyMomentum}) {
    Mat tangents[2] = {nullptr, nullptr};
    for (int blocked = 0; blocked < 2; ++blocked) {
      if (!blocked) ASSERT_EQ(PetscOptionsSetValue(nullptr, "-jacobian_mat_type", "aij"), PETSC_SUCCESS);
      if (blocked && size > 1) ASSERT_EQ(PetscOptionsSetValue(nullptr, "-jacobian_mat_type", "baij"), PETSC_SUCCESS);
      AssembledSystem system;
      ASSERT_EQ(Build(text.c_str(), problem, &system), PETSC_SUCCESS);
      ASSERT_EQ(PetscOptionsClearValue(nullptr, "-jacobian_mat_type"), PETSC_SUCCESS);
      Assembler &assembler = system.system.GetAssembler();
      PetscBool  is_block;
      ASSERT_EQ(PetscObjectTypeCompareAny((PetscObject)assembler.Jacobian(), &is_block, MATSEQBAIJ, MATMPIBAIJ, ""), PETSC_SUCCESS);
      EXPECT_EQ((bool)is_block, (bool)blocked) << "problem " << (int)problem;
      PetscInt block_size;
      ASSERT_EQ(MatGetBlockSize(assembler.Jacobian(), &block_size), PETSC_SUCCESS);
      if (blocked) EXPECT_EQ(block_size, 6);
      Vec       x, r;
      PetscBool ok;
      ASSERT_EQ(VecDuplicate(assembler.SolutionTemplate(), &x), PETSC_SUCCESS);
      ASSERT_EQ(VecDuplicate(x, &r), PETSC_SUCCESS);
      ASSERT_EQ(SetWavyIncrements(x, 0.04, 0.7, 2.3), PETSC_SUCCESS);
      if (problem == Problem::EnergyMomentum) ASSERT_EQ(Residual(assembler, x, r), PETSC_SUCCESS); // beta from it
      ASSERT_EQ(assembler.SetIncrements(x), PETSC_SUCCESS);
      ASSERT_EQ(assembler.AssembleJacobian(assembler.Jacobian(), &ok), PETSC_SUCCESS);
      ASSERT_TRUE(ok);
      ASSERT_EQ(MatConvert(assembler.Jacobian(), MATAIJ, MAT_INITIAL_MATRIX, &tangents[blocked]), PETSC_SUCCESS);
      VecDestroy(&x);
      VecDestroy(&r);
    }
    PetscReal norm, difference;
    ASSERT_EQ(MatNorm(tangents[0], NORM_FROBENIUS, &norm), PETSC_SUCCESS);
    ASSERT_EQ(MatAXPY(tangents[1], -1.0, tangents[0], DIFFERENT_NONZERO_PATTERN), PETSC_SUCCESS);
    ASSERT_EQ(MatNorm(tangents[1], NORM_FROBENIUS, &difference), PETSC_SUCCESS);
    PetscPrintf(PETSC_COMM_WORLD, "node-block tangent, problem %d, %d rank(s): ||J_baij - J_aij||_F / ||J_aij||_F = %.2e\n", (int)problem, size,
                difference / norm);
    EXPECT_GT(norm, 0.0);
    EXPECT_LE(difference, 1e-15 * norm) << "problem " << (int)problem;
    MatDestroy(&tangents[0]);
    MatDestroy(&tangents[1]);
  }
  ASSERT_EQ(PetscOptionsClearValue(nullptr, "-jacobian_dense_below"), PETSC_SUCCESS);
}

// The predictor moves every released coordinate at its rate (Delta q = dt q'), as it moves the
// nodes (u = dt v): on the mechanism with joints of every kind, each free coordinate's unknown
// starts at dt times the rate the step starts with, a driven one has no unknown.
TEST(AssembledSystem, PredictorMovesJointCoordinatesAtTheirRates)
{
  AssembledSystem system;
  ASSERT_EQ(Build(kJointModel, Problem::Newmark, &system), PETSC_SUCCESS);
  Assembler &assembler = system.system.GetAssembler();
  State     &state     = system.system.GetState();
  // Rates of every released coordinate, distinct and nonzero (the model starts them at rest).
  for (JointState &J : state.joints)
    for (int c = 0; c < kJointMaxReleased; ++c) J.coordinate_motion[c / 3].velocity(c % 3) = 0.1 * (J.joint + 1) + 0.01 * c;
  const double dt = EquationsOf(Problem::Newmark).scheme.dt;
  Vec          x;
  ASSERT_EQ(VecDuplicate(assembler.SolutionTemplate(), &x), PETSC_SUCCESS);
  ASSERT_EQ(assembler.PredictIncrements(x), PETSC_SUCCESS);
  PetscInt first, last;
  ASSERT_EQ(VecGetOwnershipRange(x, &first, &last), PETSC_SUCCESS);
  const PetscScalar *values;
  ASSERT_EQ(VecGetArrayRead(x, &values), PETSC_SUCCESS);
  int checked = 0;
  for (const JointState &J : state.joints)
    for (int c = 0; c < kJointMaxReleased; ++c) {
      const PetscInt row = system.map.joint_dofs[J.joint][c];
      if (row < first || row >= last) continue;
      EXPECT_DOUBLE_EQ(values[row - first], dt * J.CoordinateRate(c)) << "joint " << J.joint << " coordinate " << c;
      ++checked;
    }
  ASSERT_EQ(VecRestoreArrayRead(x, &values), PETSC_SUCCESS);
  int total = checked;
  MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPI_INT, MPI_SUM, PETSC_COMM_WORLD);
  EXPECT_GE(total, 8) << "released coordinates of the mechanism"; // revolute driven; universal 2, screw 1, prismatic 1, cam 1+, ...
  VecDestroy(&x);
}
