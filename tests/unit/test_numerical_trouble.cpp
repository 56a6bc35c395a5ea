// Numerical trouble in words: NewtonDescribeFailure and Assembler::DescribeNonFinite /
// DescribeUnevaluable / DescribeUnknown on small models built like the analysis builds them
// (ReadModelString, PartitionNodes, DofMapCreate, Assembler::Setup, NewtonSolverCreate, then
// DofMapRestrictToLocal), each provoked into one kind of trouble and solved by the real SNES:
//  - NaN or Inf in the residual: a NaN increment, a load function overflowing to Inf, a section
//    with a NaN stiffness, a joint drive overflowing to Inf;
//  - a NaN appearing only in the tangent (the line search then fails on every shortened step,
//    which used to hide the NaN behind DIVERGED_LINE_SEARCH), with the msflex and the bt line search;
//  - a singular tangent: a dynamic model with a node that has neither stiffness nor rotary
//    inertia (MUMPS INFOG(1) = -10), statics of a free beam (MUMPS: absurd updates; PETSc LU: zero pivot);
//  - a diverging solve (one Newton iteration allowed on a hard step);
//  - an element turned by nearly pi by a prescribed rotation.
// The expected messages name nodes, elements and joints by the names the model gives them and
// take their numbers from the run itself (SNES history, residual, MUMPS INFOG). Every rank checks
// the same message, on any number of ranks.
#include "assembly/mechanical_system.hpp"
#include "core/block_envelope_pc.hpp"
#include "core/format.hpp"
#include "integrators/newton.hpp"
#include "io/input_reader.hpp"
#include "parallel/partition.hpp"

#include <gtest/gtest.h>
#include <petscksp.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <functional>
#include <map>

using namespace msflex;

namespace {

// A clamped arm (4 elements) carrying a hand (2 elements) of its own section, a tip load.
// analysis: dynamic only so that the reader's static checks do not apply to the edited models.
const char *kArm = R"(
functions:
  - {name: blowup, type: polynomial, coefficients: [0, 0, 1.0e308]}
sections:
  - {name: s, EA: 1.0e4, GA2: 5.0e3, GA3: 5.0e3, GJ: 50, EI2: 80, EI3: 80, rhoA: 1.0, rhoJ: [0.01, 0.01, 0.01]}
  - {name: h, EA: 1.0e4, GA2: 5.0e3, GA3: 5.0e3, GJ: 50, EI2: 80, EI3: 80, rhoA: 1.0, rhoJ: [0.01, 0.01, 0.01]}
nodes:
  base: [0, 0, 0]
  elbow: [2, 0, 0]
  tip: [3, 0, 0]
beams:
  - {name: arm, section: s, from: base, to: elbow, elements: 4}
  - {name: hand, section: h, from: elbow, to: tip, elements: 2}
supports:
  - {nodes: base, fix: all}
loads:
  - {nodes: tip, force: [0, 1, 0]}
analysis: {type: dynamic}
)";

// A clamped beam with a rotor on a revolute joint and a slider on a prismatic joint.
const char *kMechanism = R"(
functions:
  - {name: blowup, type: polynomial, coefficients: [0, 0, 1.0e308]}
sections:
  - {name: s, EA: 1.0e4, GA2: 5.0e3, GA3: 5.0e3, GJ: 50, EI2: 80, EI3: 80, rhoA: 1.0, rhoJ: [0.01, 0.01, 0.01]}
nodes:
  base: [0, 0, 0]
  hub: [2, 0, 0]
  r0: [2, 0, 0]
  r1: [2, 1, 0]
  p0: [1, 0, 0]
  p1: [1, -1, 0.5]
beams:
  - {name: main, section: s, from: base, to: hub, elements: 2}
  - {name: rotor, section: s, from: r0, to: r1, elements: 2}
  - {name: slider, section: s, from: p0, to: p1, elements: 2}
joints:
  - {name: hinge, type: revolute, master: hub, slave: r0, axis: [0, 0, 1]}
  - {name: guide, type: prismatic, master: main.1, slave: p0, axis: [0, 1, 0]}
supports:
  - {nodes: base, fix: all}
loads:
  - {nodes: [r1, p1], force: [0, 0, -1]}
analysis: {type: dynamic}
)";

const char *const kDofNames[6] = {"ux", "uy", "uz", "rx", "ry", "rz"};

// What the analysis holds after set-up, plus what the test needs to know of the whole model
// before DofMapRestrictToLocal cuts it down.
struct Problem {
  Model                                          model; // the whole model until the system is set up, then the rank's part
  DofMap                                         map;
  MechanicalSystem                               system;
  Assembler                                     &assembler = system.GetAssembler();
  NewtonContext                                  context;
  SNES                                           snes = nullptr;
  Vec                                            x    = nullptr;
  std::map<std::string, std::array<PetscInt, 6>> node_rows;     // every node's unknowns
  std::map<PetscInt, std::string>                row_names;     // every unknown: "node 'n' uy", "joint 'j' rx"
  std::map<std::string, std::string>             element_names; // first and last element of each beam: "element 4 (nodes 'a', 'b')"
  ~Problem()
  {
    VecDestroy(&x);
    SNESDestroy(&snes);
  }
};

std::string ElementName(const Model &model, int e)
{
  std::string name = Format("element %d (nodes ", e);
  for (int a = 0; a <= model.elements[e].order; ++a) name += Format("%s'%s'", a ? ", " : "", model.nodes[model.elements[e].nodes[a]].name.c_str());
  return name + ")";
}

PetscErrorCode Build(const char *text, const std::function<void(Model &)> &edit, Problem *p)
{
  InputError       error;
  std::vector<int> node_rank;
  PetscFunctionBeginUser;
  PetscCheck(ReadModelString(text, "test_numerical_trouble", &p->model, &error), PETSC_COMM_WORLD, PETSC_ERR_USER_INPUT, "%s", error.Format().c_str());
  if (edit) edit(p->model);
  PetscCall(PartitionNodes(PETSC_COMM_WORLD, p->model, PartitionerType::Simple, &node_rank));
  PetscCall(DofMapCreate(PETSC_COMM_WORLD, p->model, node_rank, &p->map));
  const Model &model = p->model;
  for (size_t n = 0; n < model.nodes.size(); ++n) {
    p->node_rows[model.nodes[n].name] = p->map.node_dofs[n];
    for (int d = 0; d < 6; ++d)
      if (p->map.node_dofs[n][d] >= 0) p->row_names[p->map.node_dofs[n][d]] = Format("node '%s' %s", model.nodes[n].name.c_str(), kDofNames[d]);
  }
  // The released coordinate of the joints used here (docs/joints.md): revolute rx, prismatic tx.
  for (size_t j = 0; j < model.joints.size(); ++j)
    for (PetscInt row : p->map.joint_dofs[j])
      if (row >= 0) p->row_names[row] = Format("joint '%s' %s", model.joints[j].name.c_str(), model.joints[j].kind == JointKind::Revolute ? "rx" : "tx");
  for (const Beam &beam : model.beams) {
    p->element_names[beam.name + ".first"] = ElementName(model, beam.elements.front());
    p->element_names[beam.name + ".last"]  = ElementName(model, beam.elements.back());
  }
  // As the analysis does: what needs the whole model, then the distributed model and its system.
  MatrixPattern pattern;
  NodalMass     mass;
  Model         whole     = std::move(p->model);
  DofMap        whole_map = std::move(p->map);
  PetscCall(MechanicalSystemPrepare(whole, whole_map, &pattern, &mass));
  PetscCall(DofMapRestrictToLocal(whole, whole_map, &p->model, &p->map));
  PetscCall(p->system.Setup(PETSC_COMM_WORLD, p->model, p->map, std::move(pattern), std::move(mass)));
  p->context.assembler = &p->assembler;
  PetscCall(NewtonSolverCreate(PETSC_COMM_WORLD, p->model.analysis, NewtonOperator::Assembled, &p->context, &p->snes));
  PetscCall(VecDuplicate(p->assembler.SolutionTemplate(), &p->x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// One step t0 -> t1 (statics when scheme is null) from the predicted increments, optionally
// changed by `start`; then why it failed.
PetscErrorCode SolveStep(Problem *p, double t0, double t1, const TimeScheme *scheme, const std::function<PetscErrorCode(Vec)> &start,
                         SNESConvergedReason *reason, std::string *why)
{
  PetscFunctionBeginUser;
  PetscCall(p->assembler.BeginStep(scheme ? DynamicStep(*scheme, t0) : StaticStep(t0, t1)));
  PetscCall(p->assembler.PredictIncrements(p->x));
  if (start) PetscCall(start(p->x));
  PetscCall(SNESSolve(p->snes, nullptr, p->x));
  PetscCall(SNESGetConvergedReason(p->snes, reason));
  PetscCall(NewtonDescribeFailure(p->snes, &p->context, why));
  PetscMPIInt size;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%d rank(s), %s: %s\n", size, SNESConvergedReasons[*reason], why->c_str()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Sets one global entry of a distributed vector (on its owner).
PetscErrorCode SetEntry(Vec v, PetscInt row, double value)
{
  PetscInt first, last;
  PetscFunctionBeginUser;
  PetscCall(VecGetOwnershipRange(v, &first, &last));
  if (row >= first && row < last) PetscCall(VecSetValue(v, row, value, INSERT_VALUES));
  PetscCall(VecAssemblyBegin(v));
  PetscCall(VecAssemblyEnd(v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// PETSc options for the lifetime of a test.
struct ScopedOptions {
  std::vector<std::string> names;
  ScopedOptions(std::initializer_list<std::pair<const char *, const char *>> options)
  {
    for (const auto &[name, value] : options) {
      PetscOptionsSetValue(nullptr, name, value);
      names.push_back(name);
    }
  }
  ~ScopedOptions()
  {
    for (const std::string &name : names) PetscOptionsClearValue(nullptr, name.c_str());
  }
};

// The tangent the assembler makes, with a NaN put on the diagonal of one row afterwards: a tangent
// kernel gone wrong while the residual stays finite.
struct PoisonedTangent {
  PetscErrorCode (*assemble)(SNES, Vec, Mat, Mat, void *) = nullptr;
  void    *assemble_context                               = nullptr;
  PetscInt row                                            = -1;
};

PetscErrorCode AssemblePoisonedTangent(SNES snes, Vec x, Mat jacobian, Mat preconditioner, void *ctx)
{
  PoisonedTangent *poison = static_cast<PoisonedTangent *>(ctx);
  PetscInt         first, last;
  PetscFunctionBeginUser;
  PetscCall(poison->assemble(snes, x, jacobian, preconditioner, poison->assemble_context));
  PetscCall(MatGetOwnershipRange(preconditioner, &first, &last));
  if (poison->row >= first && poison->row < last) PetscCall(MatSetValue(preconditioner, poison->row, poison->row, NAN, INSERT_VALUES));
  PetscCall(MatAssemblyBegin(preconditioner, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(preconditioner, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PoisonTangent(Problem *p, PetscInt row, PoisonedTangent *poison)
{
  Mat jacobian, preconditioner;
  PetscFunctionBeginUser;
  PetscCall(SNESGetJacobian(p->snes, &jacobian, &preconditioner, &poison->assemble, &poison->assemble_context));
  poison->row = row;
  PetscCall(SNESSetJacobian(p->snes, jacobian, preconditioner, AssemblePoisonedTangent, poison));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscMPIInt Size()
{
  PetscMPIInt size;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  return size;
}

} // namespace

// MUMPS always (analysis.direct_solver mumps), for the tests of its account of a failure.
static void UseMumps(Model &m) { m.analysis.direct_solver = DirectSolverChoice::Mumps; }

// MUMPS' INFOG(1) and INFOG(2) of the last factorisation of the solver's preconditioner.
PetscErrorCode MumpsInfog(SNES snes, PetscInt *infog1, PetscInt *infog2)
{
  KSP ksp;
  PC  pc;
  Mat factor;
  PetscFunctionBeginUser;
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCFactorGetMatrix(pc, &factor));
  PetscCall(MatMumpsGetInfog(factor, 1, infog1));
  PetscCall(MatMumpsGetInfog(factor, 2, infog2));
  PetscFunctionReturn(PETSC_SUCCESS);
}

TEST(NumericalTrouble, NanIncrementIsNamedAtItsNode)
{
  Problem p;
  ASSERT_EQ(Build(kArm, nullptr, &p), PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  const PetscInt      row = p.node_rows.at("arm.2")[1];
  ASSERT_EQ(SolveStep(
                &p, 0, 1, nullptr, [row](Vec x) { return SetEntry(x, row, NAN); }, &reason, &why),
            PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_FNORM_NAN);
  EXPECT_EQ(why, "the residual is NaN at node 'arm.2', in its increment uy (SNES: DIVERGED_FNORM_NAN)");
}

TEST(NumericalTrouble, LoadFunctionOverflowIsNamedAtItsNode)
{
  Problem p; // the tip load times 1e308 t^2: Inf at t = 2 (and 0 * Inf = NaN in its other components)
  ASSERT_EQ(Build(
                kArm, [](Model &m) { m.nodal_loads[0].function = 0; }, &p),
            PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  ASSERT_EQ(SolveStep(&p, 0, 2, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_FNORM_NAN);
  EXPECT_EQ(why, "the residual is NaN at node 'tip', in its load (SNES: DIVERGED_FNORM_NAN)");
}

TEST(NumericalTrouble, NanSectionIsNamedAtTheFirstElement)
{
  Problem p; // every element of the hand is NaN; the lowest element number wins on any number of ranks
  ASSERT_EQ(Build(
                kArm, [](Model &m) { m.sections[1].EI3 = NAN; }, &p),
            PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  ASSERT_EQ(SolveStep(&p, 0, 1, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_FNORM_NAN);
  EXPECT_EQ(why, "the residual is NaN at " + p.element_names.at("hand.first") + " (SNES: DIVERGED_FNORM_NAN)");
  EXPECT_EQ(p.element_names.at("hand.first"), "element 4 (nodes 'elbow', 'hand.1')");
}

TEST(NumericalTrouble, JointDriveOverflowIsNamedAtTheJoint)
{
  Problem p; // the hinge driven by 1e308 t^2: Inf at t = 2, so the rotor's slave node and elements are NaN
  ASSERT_EQ(Build(
                kMechanism,
                [](Model &m) {
                  m.joints[0].driven_coordinate = 0;
                  m.joints[0].drive_value       = 1.0;
                  m.joints[0].drive_function    = 0;
                },
                &p),
            PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  ASSERT_EQ(SolveStep(&p, 0, 2, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_FNORM_NAN);
  EXPECT_EQ(why, "the residual is NaN at joint 'hinge', in its coordinate rx (SNES: DIVERGED_FNORM_NAN)");
}

// A NaN only in the tangent, solved with point Jacobi (which passes the NaN on without failing):
// the update is NaN, every shortened step of the msflex line search is NaN, and SNES says only
// DIVERGED_LINE_SEARCH (bt: DIVERGED_FNORM_NAN with a finite residual at the iterate).
TEST(NumericalTrouble, NanTangentBehindTheLineSearchIsNamedAtItsRow)
{
  for (const char *line_search : {"shell", "bt"}) {
    ScopedOptions   options{{"-pc_type", "jacobi"}, {"-snes_linesearch_type", line_search}};
    Problem         p;
    PoisonedTangent poison;
    ASSERT_EQ(Build(kArm, nullptr, &p), PETSC_SUCCESS);
    ASSERT_EQ(PoisonTangent(&p, p.node_rows.at("arm.2")[1], &poison), PETSC_SUCCESS);
    SNESConvergedReason reason;
    std::string         why;
    ASSERT_EQ(SolveStep(&p, 0, 1, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
    const SNESConvergedReason expected = std::string(line_search) == "shell" ? SNES_DIVERGED_LINE_SEARCH : SNES_DIVERGED_FNORM_NAN;
    EXPECT_EQ(reason, expected) << line_search;
    EXPECT_EQ(why,
              std::string("the Newton update is NaN: the tangent is not finite at the row of node 'arm.2' uy (SNES: ") + SNESConvergedReasons[expected] + ")")
        << line_search;
  }
}

// The same NaN factored by MUMPS: the factorisation fails, and the row is named.
TEST(NumericalTrouble, NanTangentInTheFactorisationIsNamedAtItsRow)
{
  ScopedOptions   sparse{{"-jacobian_dense_below", "0"}}; // sparse, as for a model of more than 128 unknowns
  Problem         p;
  PoisonedTangent poison;
  ASSERT_EQ(Build(kArm, UseMumps, &p), PETSC_SUCCESS);
  ASSERT_EQ(PoisonTangent(&p, p.node_rows.at("arm.2")[1], &poison), PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  ASSERT_EQ(SolveStep(&p, 0, 1, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_LINEAR_SOLVE);
  EXPECT_EQ(why, "the tangent is not finite at the row of node 'arm.2' uy (SNES: DIVERGED_LINEAR_SOLVE)");
}

// A node with a point mass but no rotary inertia and no element: nothing resists its rotations.
static void AddLooseBody(Model &m)
{
  Node loose;
  loose.name     = "loose";
  loose.position = Vec3(1, 1, 0);
  m.nodes.push_back(loose);
  RigidBody body;
  body.node = (int)m.nodes.size() - 1;
  body.mass = 1.0;
  m.rigid_bodies.push_back(body);
}

// A node with a point mass but no rotary inertia and no element: in dynamics nothing resists its
// rotations, MUMPS stops with INFOG(1) = -10, and the first such unknown is named.
TEST(NumericalTrouble, SingularTangentNamesTheUnknownNothingResists)
{
  ScopedOptions sparse{{"-jacobian_dense_below", "0"}}; // sparse, as for a model of more than 128 unknowns
  Problem       p;
  ASSERT_EQ(Build(
                kArm,
                [](Model &m) {
                  AddLooseBody(m);
                  UseMumps(m);
                },
                &p),
            PETSC_SUCCESS);
  static const TimeScheme scheme = MakeTimeScheme(TimeSchemeKind::Newmark, 0.9, 0.01);
  SNESConvergedReason     reason;
  std::string             why;
  ASSERT_EQ(SolveStep(&p, 0, 0.01, &scheme, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_LINEAR_SOLVE);
  PetscInt infog1, infog2;
  ASSERT_EQ(MumpsInfog(p.snes, &infog1, &infog2), PETSC_SUCCESS);
  EXPECT_EQ(infog1, -10); // MUMPS: numerically singular
  const std::array<PetscInt, 6> &loose = p.node_rows.at("loose");
  EXPECT_EQ(p.row_names.at(*std::min_element(loose.begin() + 3, loose.end())), "node 'loose' rx");
  EXPECT_EQ(why, Format("the tangent is singular (MUMPS INFOG(1) = %" PetscInt_FMT ", INFOG(2) = %" PetscInt_FMT
                        "): nothing resists node 'loose' rx (neither stiffness nor mass) (SNES: DIVERGED_LINEAR_SOLVE)",
                        infog1, infog2));
}

// The same model with the default choice of the direct solver: on one rank the banded tangent
// (BAIJ: its unknowns are all in node blocks) goes to msflex's block LU, which stops at the zero pivot; NewtonUsePivotingLU then hands the solver to MUMPS,
// and the step tried again ends with MUMPS' account, which names the unknown; MUMPS failing too,
// NewtonUseBandedLUAgain gives the factorisation back to the block LU. On two ranks MUMPS factors
// from the start and there is nothing to hand over.
TEST(NumericalTrouble, BandedLUHandsASingularTangentToMumps)
{
  ScopedOptions sparse{{"-jacobian_dense_below", "0"}};
  Problem       p;
  ASSERT_EQ(Build(kArm, AddLooseBody, &p), PETSC_SUCCESS);
  static const TimeScheme scheme = MakeTimeScheme(TimeSchemeKind::Newmark, 0.9, 0.01);
  SNESConvergedReason     reason;
  std::string             why;
  bool                    switched = true;
  EXPECT_EQ(p.context.banded_lu_by_structure, Size() == 1);
  PetscBool node_blocks; // one rank: every unknown in a node's block, so BAIJ's LU meets the zero pivot
  ASSERT_EQ(PetscObjectTypeCompare((PetscObject)p.assembler.Jacobian(), MATSEQBAIJ, &node_blocks), PETSC_SUCCESS);
  EXPECT_EQ((bool)node_blocks, Size() == 1);
  // One rank: the node blocks of this chain go to msflex's block LU, which meets the zero pivot.
  KSP         ksp;
  PC          pc;
  bool        block_lu;
  std::string detail;
  ASSERT_EQ(SNESGetKSP(p.snes, &ksp), PETSC_SUCCESS);
  ASSERT_EQ(KSPGetPC(ksp, &pc), PETSC_SUCCESS);
  ASSERT_EQ(BlockLUDescribeFailure(pc, &block_lu, &detail), PETSC_SUCCESS);
  EXPECT_EQ(block_lu, Size() == 1);
  ASSERT_EQ(SolveStep(&p, 0, 0.01, &scheme, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_LINEAR_SOLVE);
  if (Size() == 1) EXPECT_EQ(why.rfind("the tangent is singular (zero pivot in the diagonal block of unknowns ", 0), 0u) << why;
  ASSERT_EQ(NewtonForgetFactorization(p.snes, &p.context), PETSC_SUCCESS); // as after every failed solve
  ASSERT_EQ(NewtonUsePivotingLU(p.snes, &p.context, &switched), PETSC_SUCCESS);
  EXPECT_EQ(switched, Size() == 1);
  EXPECT_EQ(p.context.pivoting_lu_forced, Size() == 1);
  EXPECT_FALSE(p.context.banded_lu_by_structure);
  ASSERT_EQ(SolveStep(&p, 0, 0.01, &scheme, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_LINEAR_SOLVE);
  PetscInt infog1, infog2;
  ASSERT_EQ(MumpsInfog(p.snes, &infog1, &infog2), PETSC_SUCCESS);
  EXPECT_EQ(infog1, -10);
  EXPECT_EQ(why, Format("the tangent is singular (MUMPS INFOG(1) = %" PetscInt_FMT ", INFOG(2) = %" PetscInt_FMT
                        "): nothing resists node 'loose' rx (neither stiffness nor mass) (SNES: DIVERGED_LINEAR_SOLVE)",
                        infog1, infog2));
  ASSERT_EQ(NewtonUsePivotingLU(p.snes, &p.context, &switched), PETSC_SUCCESS);
  EXPECT_FALSE(switched); // once only
  if (Size() > 1) return;
  // MUMPS failed the same step as well: the banded LU comes back (Integrator::TryEquations), with
  // its flags, and meets the zero pivot again.
  ASSERT_EQ(NewtonUseBandedLUAgain(p.snes, &p.context), PETSC_SUCCESS);
  EXPECT_TRUE(p.context.banded_lu_by_structure);
  EXPECT_FALSE(p.context.pivoting_lu_forced);
  ASSERT_EQ(BlockLUDescribeFailure(pc, &block_lu, &detail), PETSC_SUCCESS);
  EXPECT_TRUE(block_lu);
  ASSERT_EQ(SolveStep(&p, 0, 0.01, &scheme, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_LINEAR_SOLVE);
  EXPECT_EQ(why.rfind("the tangent is singular (zero pivot in the diagonal block of unknowns ", 0), 0u) << why;
}

// A package named by an option is the user's choice: PETSc's LU is kept, and nothing falls back.
TEST(NumericalTrouble, BandedLUNamedByAnOptionIsKept)
{
  if (Size() > 1) GTEST_SKIP() << "PETSc's LU is for one rank";
  ScopedOptions options{{"-jacobian_dense_below", "0"}, {"-pc_factor_mat_solver_type", "petsc"}};
  Problem       p;
  ASSERT_EQ(Build(kArm, nullptr, &p), PETSC_SUCCESS);
  EXPECT_FALSE(p.context.banded_lu_by_structure);
  bool switched = true;
  ASSERT_EQ(NewtonUsePivotingLU(p.snes, &p.context, &switched), PETSC_SUCCESS);
  EXPECT_FALSE(switched);
}

// The same model with its tangent dense (on one rank a model of at most 128 unknowns has one by
// default): msflex's dense LU meets the zero pivot, the solve fails like MUMPS',
// and the unknown nothing resists is named alike.
TEST(NumericalTrouble, SingularDenseTangentNamesTheUnknownNothingResists)
{
  if (Size() > 1) GTEST_SKIP() << "a dense tangent is for one rank";
  ScopedOptions dense{{"-jacobian_dense_below", "1000"}};
  Problem       p;
  ASSERT_EQ(Build(kArm, AddLooseBody, &p), PETSC_SUCCESS);
  MatType type;
  ASSERT_EQ(MatGetType(p.assembler.Jacobian(), &type), PETSC_SUCCESS);
  EXPECT_STREQ(type, MATSEQDENSE);
  static const TimeScheme scheme = MakeTimeScheme(TimeSchemeKind::Newmark, 0.9, 0.01);
  SNESConvergedReason     reason;
  std::string             why;
  ASSERT_EQ(SolveStep(&p, 0, 0.01, &scheme, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_LINEAR_SOLVE);
  const std::string head = "the tangent is singular (zero pivot in column ",
                    tail = " of the dense LU): nothing resists node 'loose' rx (neither stiffness nor mass) (SNES: DIVERGED_LINEAR_SOLVE)";
  EXPECT_EQ(why.rfind(head, 0), 0u) << why;
  EXPECT_TRUE(why.size() > head.size() + tail.size() && why.compare(why.size() - tail.size(), tail.size(), tail) == 0) << why;
}

// Statics of a free beam. MUMPS either finds the singularity (INFOG(1) = -10; seen on 3 ranks) or
// factors the singular stiffness with round-off pivots (1 and 2 ranks): then the first update is
// absurd and Newton runs out of iterations, and the message says so from the history.
TEST(NumericalTrouble, FreeBeamStaticsIsReportedSingular)
{
  ScopedOptions sparse{{"-jacobian_dense_below", "0"}}; // sparse, as for a model of more than 128 unknowns
  Problem       p;
  ASSERT_EQ(Build(
                kArm,
                [](Model &m) {
                  m.supports.clear();
                  UseMumps(m);
                },
                &p),
            PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  ASSERT_EQ(SolveStep(&p, 0, 1, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
  const std::string hint = "is part of the model a mechanism free to move, or has a node neither stiffness nor mass in some direction?";
  if (reason == SNES_DIVERGED_LINEAR_SOLVE) {
    PetscInt infog1, infog2;
    ASSERT_EQ(MumpsInfog(p.snes, &infog1, &infog2), PETSC_SUCCESS);
    EXPECT_EQ(why, Format("the tangent is singular (MUMPS INFOG(1) = %" PetscInt_FMT ", INFOG(2) = %" PetscInt_FMT "): %s (SNES: DIVERGED_LINEAR_SOLVE)",
                          infog1, infog2, hint.c_str()));
    return;
  }
  EXPECT_EQ(reason, SNES_DIVERGED_MAX_IT);
  PetscReal *norms;
  PetscInt  *linear_iterations, count;
  ASSERT_EQ(SNESGetConvergenceHistory(p.snes, &norms, &linear_iterations, &count), PETSC_SUCCESS);
  ASSERT_GT(count, 1);
  int    growth_iteration = 0;
  double growth           = 1.0;
  for (PetscInt i = 1; i < count; ++i)
    if (norms[i] / norms[i - 1] > growth) growth = norms[i] / norms[i - 1], growth_iteration = (int)i;
  EXPECT_GT(growth, 1e12);
  const std::string expected =
      Format("|R| grew %.1e-fold in iteration %d, so the tangent is nearly singular: %s (SNES: DIVERGED_MAX_IT)", growth, growth_iteration, hint.c_str());
  EXPECT_NE(why.find(expected), std::string::npos) << expected;
  EXPECT_EQ(why.rfind("Newton did not converge in 25 iterations: ", 0), 0u);
}

// The same with PETSc's own LU (one rank only: it factors sequential matrices), which stops at
// the zero pivot.
TEST(NumericalTrouble, FreeBeamStaticsWithPetscLUReportsTheZeroPivot)
{
  if (Size() > 1) GTEST_SKIP() << "PETSc's LU is sequential";
  ScopedOptions options{{"-pc_factor_mat_solver_type", "petsc"}, {"-jacobian_dense_below", "0"}};
  Problem       p;
  ASSERT_EQ(Build(
                kArm, [](Model &m) { m.supports.clear(); }, &p),
            PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  ASSERT_EQ(SolveStep(&p, 0, 1, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_LINEAR_SOLVE);
  KSP       ksp;
  PC        pc;
  Mat       factor;
  PetscReal pivot;
  PetscInt  pivot_row;
  ASSERT_EQ(SNESGetKSP(p.snes, &ksp), PETSC_SUCCESS);
  ASSERT_EQ(KSPGetPC(ksp, &pc), PETSC_SUCCESS);
  ASSERT_EQ(PCFactorGetMatrix(pc, &factor), PETSC_SUCCESS);
  ASSERT_EQ(MatFactorGetErrorZeroPivot(factor, &pivot, &pivot_row), PETSC_SUCCESS);
  EXPECT_EQ(
      why,
      Format("the tangent is singular (zero pivot %.3g in the lu factorisation by petsc): is part of the model a mechanism free to move, or has a node neither "
             "stiffness nor mass in some direction? (SNES: DIVERGED_LINEAR_SOLVE)",
             (double)pivot));
}

// One Newton iteration for a moment that rolls the arm up: the residual norms of the first and
// last iterations, what convergence needed and the largest residual's unknown, all from the run.
TEST(NumericalTrouble, DivergingSolveGivesItsResidualsAndLargestResidual)
{
  Problem p;
  ASSERT_EQ(Build(
                kArm,
                [](Model &m) {
                  m.analysis.max_newton_iterations = 1;
                  m.nodal_loads[0].force           = Vec3::Zero();
                  m.nodal_loads[0].moment          = Vec3(0, 0, 2 * M_PI * 80 / 3.0);
                },
                &p),
            PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  ASSERT_EQ(SolveStep(&p, 0, 1, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_MAX_IT);
  PetscReal *norms, atol, rtol, stol, largest;
  PetscInt  *linear_iterations, count, max_iterations, max_evaluations, row;
  Vec        residual, magnitudes;
  double     force_scale;
  ASSERT_EQ(SNESGetConvergenceHistory(p.snes, &norms, &linear_iterations, &count), PETSC_SUCCESS);
  ASSERT_EQ(count, 2);
  ASSERT_EQ(SNESGetTolerances(p.snes, &atol, &rtol, &stol, &max_iterations, &max_evaluations), PETSC_SUCCESS);
  ASSERT_EQ(SNESGetFunction(p.snes, &residual, nullptr, nullptr), PETSC_SUCCESS);
  ASSERT_EQ(VecDuplicate(residual, &magnitudes), PETSC_SUCCESS);
  ASSERT_EQ(VecCopy(residual, magnitudes), PETSC_SUCCESS);
  ASSERT_EQ(VecAbs(magnitudes), PETSC_SUCCESS);
  ASSERT_EQ(VecMax(magnitudes, &row, &largest), PETSC_SUCCESS);
  ASSERT_EQ(VecDestroy(&magnitudes), PETSC_SUCCESS);
  ASSERT_EQ(p.assembler.ForceScale(&force_scale), PETSC_SUCCESS);
  const double needed = std::max({(double)atol, rtol * norms[0], rtol * force_scale, p.assembler.RoundoffForceLevel()});
  EXPECT_GT(norms[1], 1e-3 * norms[0]); // not converged by far
  EXPECT_EQ(
      why,
      Format("Newton did not converge in 1 iteration: |R| = %.3e at the start of the step, %.3e after the last iteration (convergence needs %.3e); the largest "
             "residual, %.3e, is at %s (SNES: DIVERGED_MAX_IT)",
             norms[0], norms[1], needed, (double)largest, p.row_names.at(row).c_str()));
  // The assembler is left at the increments SNESSolve ended with.
  double after_description, at_solution;
  ASSERT_EQ(p.assembler.MaxRotationIncrement(&after_description), PETSC_SUCCESS);
  ASSERT_EQ(p.assembler.SetIncrements(p.x), PETSC_SUCCESS);
  ASSERT_EQ(p.assembler.MaxRotationIncrement(&at_solution), PETSC_SUCCESS);
  EXPECT_EQ(after_description, at_solution);
  EXPECT_GT(at_solution, 0.1);
}

// A prescribed tip rotation of 3 rad in one step: the hand's last element turns by more than
// 0.95 pi between its nodes and cannot be evaluated at the start of the step.
TEST(NumericalTrouble, HalfTurnNamesTheElement)
{
  Problem p;
  ASSERT_EQ(Build(
                kArm,
                [](Model &m) {
                  Support turn;
                  turn.nodes     = {2}; // tip
                  turn.kind[5]   = Support::Kind::Prescribed;
                  turn.values[5] = 3.0;
                  m.supports.push_back(turn);
                },
                &p),
            PETSC_SUCCESS);
  SNESConvergedReason reason;
  std::string         why;
  ASSERT_EQ(SolveStep(&p, 0, 1, nullptr, nullptr, &reason, &why), PETSC_SUCCESS);
  EXPECT_EQ(reason, SNES_DIVERGED_FUNCTION_DOMAIN);
  EXPECT_EQ(p.element_names.at("hand.last"), "element 5 (nodes 'hand.1', 'tip')");
  EXPECT_EQ(
      why,
      p.element_names.at("hand.last") +
          " cannot be evaluated: its nodes turn by nearly pi relative to each other at the start of the step (the predicted or prescribed increments) (SNES: "
          "DIVERGED_FUNCTION_DOMAIN)");
}

// Every unknown of a model with joints, after the model is cut down to each rank's part, against
// the whole model's DofMap.
TEST(NumericalTrouble, DescribeUnknownMatchesTheDofMap)
{
  Problem p;
  ASSERT_EQ(Build(kMechanism, nullptr, &p), PETSC_SUCCESS);
  ASSERT_EQ((PetscInt)p.row_names.size(), p.map.num_global);
  int joint_rows = 0;
  for (const auto &[row, name] : p.row_names) {
    std::string what;
    ASSERT_EQ(p.assembler.DescribeUnknown(row, &what), PETSC_SUCCESS);
    EXPECT_EQ(what, name) << "row " << row;
    joint_rows += name.rfind("joint", 0) == 0;
  }
  EXPECT_EQ(joint_rows, 2);
  EXPECT_EQ(p.row_names.at(p.node_rows.at("r1")[5]), "node 'r1' rz");
  std::string what;
  ASSERT_EQ(p.assembler.DescribeUnknown(p.map.num_global, &what), PETSC_SUCCESS);
  EXPECT_EQ(what, Format("unknown %" PetscInt_FMT, p.map.num_global));
}

// Nothing to report at a finite, evaluable state.
TEST(NumericalTrouble, FiniteStateHasNothingToDescribe)
{
  Problem p;
  ASSERT_EQ(Build(kMechanism, nullptr, &p), PETSC_SUCCESS);
  ASSERT_EQ(p.assembler.BeginStep(StaticStep(0, 1)), PETSC_SUCCESS);
  ASSERT_EQ(p.assembler.PredictIncrements(p.x), PETSC_SUCCESS);
  ASSERT_EQ(p.assembler.SetIncrements(p.x), PETSC_SUCCESS);
  std::string non_finite = "?", unevaluable = "?";
  ASSERT_EQ(p.assembler.DescribeNonFinite(&non_finite), PETSC_SUCCESS);
  ASSERT_EQ(p.assembler.DescribeUnevaluable(&unevaluable), PETSC_SUCCESS);
  EXPECT_EQ(non_finite, "");
  EXPECT_EQ(unevaluable, "");
}
