// The force elements of the model (docs/input.md, force_elements; kernels in
// elements/force_elements.hpp): springs, dampers and actuators on joints' released coordinates,
// axial spring-dampers and bushings between two nodes. Each element is evaluated by one rank: a
// coordinate's by the owner of its joint's slave, a node pair's by the owner of its first node.
//
// Per problem: statics (springs and actuators at t_{n+1}), the Newmark family (dampers with the
// scheme's velocities at t_{n+1}: a coordinate's rate is integrated by the scheme like a node's,
// State::joints' coordinate_motion), the mid-point family (the discrete-gradient forms, rows
// conjugate to the test quantities), the initial-acceleration problem (the start state's forces,
// no tangent). Stored energy, dissipation and the actuators' work feed the energy balance.
//
// The work over a step (the actuators' work, the dampers' dissipation and the elements' `power`)
// is taken with the quadrature of the scheme's energy balance, the one Assembler::StepExternalWork
// takes for the loads: the mid-point family's own forces times the increments (exact: em keeps
// energy - work + dissipated energy constant), the trapezoidal rule (F_n + F_{n+1}) / 2 times the
// increments in the Newmark family, with F_n the forces of the start state (its configuration,
// velocities and actuators at t_n). Trapezoidal Newmark conserves the energy of a linear system
// exactly in that rule (docs/force_elements.md, energy balance).
#pragma once

#include "contributors/contributor.hpp"
#include "elements/force_elements.hpp"

#include <vector>

namespace msflex {

class CoordinateForceContributor : public ForceContributor {
public:
  void        Setup(const Model &model, const DofMap &map, const State &state);
  const char *Name() const override { return "joint coordinate force elements"; }
  bool        Empty() const { return elements_.empty(); }

  void BeginStep(const State &state) override;
  void AddBlocks(const State &state, bool want_tangent, BlockSink *sink) override;
  void AddStoredEnergy(const State &state, double *energy) const override;
  bool StoresSpringEnergy() const override { return true; }
  void AddStepWork(const State &state, double *work) const override;
  void AddStepDissipation(const State &state, double *dissipation) const override;
  void StartMotion(State *state) override;
  void CommitStep(State *state) override;
  void AddHistory(const State &state, bool with_names, std::vector<HistoryValue> *values) const override;

private:
  struct Element {
    int         element    = -1; // index into the model's force elements
    int         joint      = -1; // index into State::joints
    int         coordinate = -1;
    bool        angle      = false;
    SpringCurve spring;
    bool        has_spring     = false;
    double      actuator       = 0.0; // weighted in time for the step
    double      actuator_start = 0.0; // at the start of the step (the Newmark family's trapezoidal work)
    // Recorded at the last commit for the history: the generalised force on the coordinate and the
    // mean power delivered over the step.
    double force = 0.0, power = 0.0;
  };
  CoordinateForceValues Evaluate(const State &state, const Element &element) const;
  // The forces of the start state (q_n, its rate, the actuator at t_n): the Newmark family's F_n.
  CoordinateForceValues EvaluateStart(const State &state, const Element &element) const;

  const Model         *model_ = nullptr;
  const DofMap        *map_   = nullptr;
  std::vector<Element> elements_;
};

class NodePairForceContributor : public ForceContributor {
public:
  void        Setup(const Model &model, const DofMap &map);
  const char *Name() const override { return "spring-dampers and bushings"; }
  bool        Empty() const { return elements_.empty(); }

  void AddBlocks(const State &state, bool want_tangent, BlockSink *sink) override;
  void AddStoredEnergy(const State &state, double *energy) const override;
  bool StoresSpringEnergy() const override { return true; }
  void AddStepDissipation(const State &state, double *dissipation) const override;
  void StartMotion(State *state) override;
  void CommitStep(State *state) override;
  void AddHistory(const State &state, bool with_names, std::vector<HistoryValue> *values) const override;
  void FindNonFiniteBlocks(const State &state, const std::vector<char> &node_finite, TroubleFindings *findings) const override;

private:
  struct Element {
    int         element  = -1;       // index into the model's force elements
    int         nodes[2] = {-1, -1}; // local nodes
    SpringCurve spring;
    Vec3        reference_offset = Vec3::Zero(); // bushing: d_ref in bushing axes
    // Recorded at the last commit: length and tension (spring-damper) or force and moment on the
    // second node (bushing, global axes), and the mean power delivered over the step.
    Vec6   recorded = Vec6::Zero();
    double power    = 0.0;
  };
  // The damper's force (a spring-damper's damper tension in [0], a bushing's six components, bushing
  // axes) and the change over the step of what it resists (length, or deflection): the dissipation
  // is their product, with the force of the step's equations (mid-point family) or the mean of the
  // start state's and the end's (Newmark family).
  struct DamperWork {
    Vec6 force  = Vec6::Zero();
    Vec6 change = Vec6::Zero();
  };
  // Residual (12) and tangent (12x12, may be null) of an element in the step's equations, or with
  // `start_state` those of the start state (its configuration and velocities, no tangent); false
  // when not evaluable. The recorded quantities and the damper's work on request.
  bool Evaluate(const State &state, const Element &element, bool start_state, Vec12 *residual, Mat12 *tangent, Vec6 *recorded, DamperWork *damper) const;
  // The step's dissipation of an element (0 when not evaluable).
  double StepDissipation(const State &state, const Element &element) const;

  const Model         *model_ = nullptr;
  const DofMap        *map_   = nullptr;
  std::vector<Element> elements_;
};

} // namespace msflex
