#include "contributors/force_element_contributors.hpp"

#include <limits>

namespace msflex {

namespace {

SpringCurve CurveOf(const SpringLaw &law)
{
  SpringCurve curve;
  curve.stiffness  = law.stiffness;
  curve.free_value = law.free_value;
  if (!law.deflections.empty()) {
    curve.count       = (int)law.deflections.size();
    curve.deflections = law.deflections.data();
    curve.forces      = law.forces.data();
  }
  return curve;
}

bool IsDynamic(const Model &model) { return model.analysis.type == AnalysisType::Dynamic; }

// The spatial angular velocity at the end of the step of the Newmark family, w = Lambda_{n+1} W_{n+1},
// and d w / d theta = -hat(w) + c_v Lambda_{n+1} Lambda_n^T H(omega)^{-1}.
void EndAngularVelocity(const TimeScheme &scheme, const NodeState &s, Vec3 *w, Mat3 *jacobian)
{
  const MotionUpdate spin = NodeSpinUpdate(scheme, s);
  *w                      = s.rotation * spin.velocity;
  *jacobian               = -Skew(*w);
  // A prescribed spin does not vary with the node's rotation unknowns.
  if (!s.prescribed_spin)
    *jacobian += scheme.VelocityCoefficient() * s.rotation * QuaternionToMatrix(s.rotation_start).transpose() * s.rotation_tangent_inverse;
}

} // namespace

// --- Coordinates ----------------------------------------------------------------------------------

void CoordinateForceContributor::Setup(const Model &model, const DofMap &map, const State &state)
{
  model_ = &model;
  map_   = &map;
  elements_.clear();
  for (size_t e = 0; e < model.force_elements.size(); ++e) {
    const ForceElement &element = model.force_elements[e];
    if (element.kind != ForceElement::Kind::Coordinate) continue;
    const int j = map.joint_to_local[element.joint];
    if (j < 0 || state.joints[j].local_slave >= map.num_owned_nodes) continue; // the slave's owner evaluates it
    Element local;
    local.element    = (int)e;
    local.joint      = j;
    local.coordinate = element.coordinate;
    local.angle      = element.coordinate >= state.joints[j].geometry.num_translations;
    local.has_spring = element.spring.present;
    local.spring     = CurveOf(element.spring);
    elements_.push_back(local);
  }
}

void CoordinateForceContributor::BeginStep(const State &state)
{
  const StepEquations &eq = state.equations;
  for (Element &e : elements_) {
    const ForceElement &element = model_->force_elements[e.element];
    e.actuator       = element.has_actuator ? element.actuator * (eq.LoadWeightStart() * FunctionValue(*model_, element.actuator_function, eq.t_start) +
                                                            eq.LoadWeightEnd() * FunctionValue(*model_, element.actuator_function, eq.t_end))
                                            : 0.0;
    e.actuator_start = element.has_actuator ? element.actuator * eq.load_scale * FunctionValue(*model_, element.actuator_function, eq.t_start) : 0.0;
  }
}

CoordinateForceValues CoordinateForceContributor::Evaluate(const State &state, const Element &e) const
{
  const StepEquations &eq = state.equations;
  const JointState    &J  = state.joints[e.joint];
  CoordinateForceStep  step;
  step.start    = J.start.q[e.coordinate];
  step.angle    = e.angle;
  step.actuator = e.actuator;
  if (eq.InitialAcceleration()) {
    // The increments hold accelerations: the forces of the start state.
    step.rate = J.CoordinateRate(e.coordinate);
  } else if (eq.Midpoint()) {
    step.midpoint  = true;
    step.increment = J.increment[e.coordinate];
    step.dt        = eq.scheme.dt;
  } else {
    step.increment = J.increment[e.coordinate];
    if (eq.Dynamic()) {
      step.rate             = J.CoordinateEndRate(e.coordinate);
      step.rate_coefficient = eq.scheme.VelocityCoefficient();
    }
  }
  CoordinateForceValues values;
  CoordinateForce(e.has_spring ? &e.spring : nullptr, model_->force_elements[e.element].damping, step, &values);
  return values;
}

CoordinateForceValues CoordinateForceContributor::EvaluateStart(const State &state, const Element &e) const
{
  const JointState   &J = state.joints[e.joint];
  CoordinateForceStep step;
  step.start    = J.start.q[e.coordinate];
  step.angle    = e.angle;
  step.rate     = J.CoordinateRate(e.coordinate);
  step.actuator = e.actuator_start;
  CoordinateForceValues values;
  CoordinateForce(e.has_spring ? &e.spring : nullptr, model_->force_elements[e.element].damping, step, &values);
  return values;
}

void CoordinateForceContributor::AddBlocks(const State &state, bool want_tangent, BlockSink *sink)
{
  for (const Element &e : elements_) {
    const CoordinateForceValues values = Evaluate(state, e);
    sink->AddCoordinate(e.joint, e.coordinate, values.residual, state.equations.InitialAcceleration() ? 0.0 : values.tangent);
  }
}

void CoordinateForceContributor::AddStoredEnergy(const State &state, double *energy) const
{
  for (const Element &e : elements_) {
    if (!e.has_spring) continue;
    const JointState &J = state.joints[e.joint];
    *energy += SpringEnergy(e.spring, J.start.q[e.coordinate] + (state.equations.InitialAcceleration() ? 0.0 : J.increment[e.coordinate]));
  }
}

// Mid-point family: the actuator's force of the step's equations, (A(t_n) + A(t_{n+1}))/2, times
// dq (exact). Newmark family: the equations hold at t_{n+1} with A(t_{n+1}); the work is the
// trapezoidal rule (A(t_n) + A(t_{n+1}))/2 dq, as for the loads (Assembler::StepExternalWork).
void CoordinateForceContributor::AddStepWork(const State &state, double *work) const
{
  const StepEquations &eq = state.equations;
  for (const Element &e : elements_) {
    if (eq.NewmarkFamily()) *work += 0.5 * (e.actuator_start + e.actuator) * state.joints[e.joint].increment[e.coordinate];
    else *work += Evaluate(state, e).actuator_work;
  }
}

// Mid-point family: c dq/dt dq (exact). Newmark family: the trapezoidal rule c (qdot_n + qdot_{n+1})/2 dq.
void CoordinateForceContributor::AddStepDissipation(const State &state, double *dissipation) const
{
  const StepEquations &eq = state.equations;
  for (const Element &e : elements_) {
    const CoordinateForceValues end = Evaluate(state, e);
    if (!eq.NewmarkFamily()) {
      *dissipation += end.dissipation;
      continue;
    }
    // damper_force is the force the damper exerts, -c qdot.
    *dissipation += -0.5 * (EvaluateStart(state, e).damper_force + end.damper_force) * state.joints[e.joint].increment[e.coordinate];
  }
}

void CoordinateForceContributor::StartMotion(State *state)
{
  for (Element &e : elements_) {
    const ForceElement &element = model_->force_elements[e.element];
    const JointState   &J       = state->joints[e.joint];
    CoordinateForceStep step;
    step.start    = J.start.q[e.coordinate];
    step.rate     = IsDynamic(*model_) ? J.CoordinateRate(e.coordinate) : 0.0;
    step.actuator = element.has_actuator ? element.actuator * FunctionValue(*model_, element.actuator_function, 0.0) : 0.0;
    CoordinateForceValues values;
    CoordinateForce(e.has_spring ? &e.spring : nullptr, element.damping, step, &values);
    e.force = values.spring_force + values.damper_force + values.actuator_force;
    e.power = 0.0;
  }
}

void CoordinateForceContributor::CommitStep(State *state)
{
  const StepEquations &eq = state->equations;
  for (Element &e : elements_) {
    const CoordinateForceValues values = Evaluate(*state, e);
    e.force                            = values.spring_force + values.damper_force + values.actuator_force;
    // Work on the mechanism over the step: minus the residual times the released test quantity
    // (mid-point family), the mean of the start state's and the end's force times the increment
    // (Newmark family).
    const double test = state->joints[e.joint].released_test[e.coordinate];
    if (eq.NewmarkFamily()) {
      const CoordinateForceValues start = EvaluateStart(*state, e);
      e.power                           = 0.5 * (start.spring_force + start.damper_force + start.actuator_force + e.force) * test / eq.scheme.dt;
    } else {
      e.power = eq.Dynamic() ? -values.residual * test / eq.scheme.dt : 0.0;
    }
  }
}

void CoordinateForceContributor::AddHistory(const State &state, bool with_names, std::vector<HistoryValue> *values) const
{
  const bool dynamic = IsDynamic(*model_);
  for (const Element &e : elements_) {
    const ForceElement &element = model_->force_elements[e.element];
    const long long     order   = 8LL * element.number;
    values->push_back({order, with_names ? element.name + ".force" : std::string(), e.force});
    if (dynamic) values->push_back({order + 1, with_names ? element.name + ".power" : std::string(), e.power});
  }
}

// --- Node pairs -----------------------------------------------------------------------------------

void NodePairForceContributor::Setup(const Model &model, const DofMap &map)
{
  model_ = &model;
  map_   = &map;
  elements_.clear();
  for (size_t e = 0; e < model.force_elements.size(); ++e) {
    const ForceElement &element = model.force_elements[e];
    if (element.kind == ForceElement::Kind::Coordinate) continue;
    const int a = map.node_to_local[element.nodes[0]], b = map.node_to_local[element.nodes[1]];
    if (a < 0 || a >= map.num_owned_nodes || b < 0) continue; // the first node's owner evaluates it
    Element local;
    local.element  = (int)e;
    local.nodes[0] = a;
    local.nodes[1] = b;
    local.spring   = CurveOf(element.spring);
    if (element.kind == ForceElement::Kind::Bushing)
      local.reference_offset = element.axes.transpose() * (model.nodes[element.nodes[1]].position - model.nodes[element.nodes[0]].position);
    elements_.push_back(local);
  }
}

bool NodePairForceContributor::Evaluate(const State &state, const Element &e, bool start_state, Vec12 *residual, Mat12 *tangent, Vec6 *recorded,
                                        DamperWork *damper) const
{
  const ForceElement  &element = model_->force_elements[e.element];
  const StepEquations &eq      = state.equations;
  const NodeState     &a = state.nodes[e.nodes[0]], &b = state.nodes[e.nodes[1]];
  const bool           at_start = start_state || eq.InitialAcceleration(); // the configuration and velocities of the start state
  if (at_start) tangent = nullptr;
  if (element.kind == ForceElement::Kind::SpringDamper) {
    AxialSpringValues values;
    bool              ok;
    if (eq.Midpoint() && !at_start) {
      ok = AxialSpringDamperMidpoint(e.spring, element.damping, a.position_start, b.position_start, a.position, b.position, eq.scheme.dt, &values, tangent);
    } else {
      const Vec3 xa = at_start ? a.position_start : a.position, xb = at_start ? b.position_start : b.position;
      Vec3       va = Vec3::Zero(), vb = Vec3::Zero();
      double     cv = 0.0;
      if (at_start) va = a.translation_motion.velocity, vb = b.translation_motion.velocity;
      else if (eq.Dynamic()) va = a.translation_update.velocity, vb = b.translation_update.velocity, cv = eq.scheme.VelocityCoefficient();
      ok = AxialSpringDamperEndPoint(e.spring, element.damping, xa, xb, va, vb, cv, &values, tangent);
    }
    if (!ok) return false;
    *residual = values.residual;
    if (recorded) *recorded << values.length, values.tension, 0.0, 0.0, 0.0, 0.0;
    if (damper) {
      *damper          = DamperWork{};
      damper->force(0) = values.damper_tension;
      if (!at_start) damper->change(0) = values.length - (b.position_start - a.position_start).norm();
    }
    return true;
  }
  BushingNode   na, nb;
  BushingValues values;
  bool          ok;
  if (eq.Midpoint() && !at_start) {
    BushingNode sa, sb;
    sa.position = a.position_start, sa.rotation = QuaternionToMatrix(a.rotation_start);
    sb.position = b.position_start, sb.rotation = QuaternionToMatrix(b.rotation_start);
    na.position = a.position, na.rotation = a.rotation;
    nb.position = b.position, nb.rotation = b.rotation;
    ok = BushingMidpoint(element.bushing_stiffness, element.bushing_damping, element.axes, e.reference_offset, sa, sb, na, nb, a.tangent_scaled_increment,
                         b.tangent_scaled_increment, eq.scheme.dt, &values, tangent);
  } else {
    for (int k = 0; k < 2; ++k) {
      const NodeState &s = k == 0 ? a : b;
      BushingNode     &n = k == 0 ? na : nb;
      if (at_start) {
        n.position = s.position_start;
        n.rotation = QuaternionToMatrix(s.rotation_start);
        n.velocity = s.translation_motion.velocity;
        n.angular  = n.rotation * s.rotation_motion.velocity;
      } else {
        n.position = s.position;
        n.rotation = s.rotation;
        if (eq.Dynamic()) {
          n.velocity             = s.translation_update.velocity;
          n.velocity_coefficient = eq.scheme.VelocityCoefficient();
          EndAngularVelocity(eq.scheme, s, &n.angular, &n.angular_jacobian);
        }
      }
    }
    ok = BushingEndPoint(element.bushing_stiffness, element.bushing_damping, element.axes, e.reference_offset, na, nb, &values, tangent);
  }
  if (!ok) return false;
  *residual = values.residual;
  if (recorded) *recorded = -values.residual.tail<6>(); // force and moment the bushing exerts on the second node
  if (damper) {
    Vec6 start;
    *damper       = DamperWork{};
    damper->force = values.damper_force;
    if (!at_start && BushingDeflection(element.axes, e.reference_offset, a.position_start, QuaternionToMatrix(a.rotation_start), b.position_start,
                                       QuaternionToMatrix(b.rotation_start), &start))
      damper->change = values.deflection - start;
  }
  return true;
}

void NodePairForceContributor::AddBlocks(const State &state, bool want_tangent, BlockSink *sink)
{
  const bool tangent = want_tangent && !state.equations.InitialAcceleration();
  for (const Element &e : elements_) {
    Vec12     r;
    Mat12     K;
    NodeBlock block;
    block.num_nodes = 2;
    block.nodes[0]  = e.nodes[0];
    block.nodes[1]  = e.nodes[1];
    if (!Evaluate(state, e, false, &r, tangent ? &K : nullptr, nullptr, nullptr)) {
      // Not evaluable (coinciding nodes, a bushing turned by pi): NaN, named by the diagnostics.
      r.setConstant(std::numeric_limits<double>::quiet_NaN());
      K.setZero();
    }
    sink->Add(block, r.data(), tangent ? K.data() : nullptr);
  }
}

void NodePairForceContributor::AddStoredEnergy(const State &state, double *energy) const
{
  for (const Element &e : elements_) {
    const ForceElement &element = model_->force_elements[e.element];
    const NodeState    &a = state.nodes[e.nodes[0]], &b = state.nodes[e.nodes[1]];
    if (element.kind == ForceElement::Kind::SpringDamper) {
      if (element.spring.present) *energy += SpringEnergy(e.spring, (b.position - a.position).norm());
      continue;
    }
    Vec6 deflection;
    if (BushingDeflection(element.axes, e.reference_offset, a.position, a.rotation, b.position, b.rotation, &deflection))
      *energy += 0.5 * deflection.dot(element.bushing_stiffness * deflection);
  }
}

// Mid-point family: the damper's force of the step's equations times the change of what it resists
// (exact). Newmark family: the trapezoidal rule, the mean of the start state's and the end's force.
double NodePairForceContributor::StepDissipation(const State &state, const Element &e) const
{
  Vec12      r;
  DamperWork end;
  if (!Evaluate(state, e, false, &r, nullptr, nullptr, &end)) return 0.0;
  if (!state.equations.NewmarkFamily()) return end.force.dot(end.change);
  DamperWork start;
  if (!Evaluate(state, e, true, &r, nullptr, nullptr, &start)) return end.force.dot(end.change);
  return (0.5 * (start.force + end.force)).dot(end.change);
}

void NodePairForceContributor::AddStepDissipation(const State &state, double *dissipation) const
{
  for (const Element &e : elements_) *dissipation += StepDissipation(state, e);
}

void NodePairForceContributor::StartMotion(State *state)
{
  // The forces of the start state, with its velocities.
  StepEquations saved = state->equations;
  state->equations    = InitialAccelerationProblem(0.0);
  if (!IsDynamic(*model_)) state->equations = StaticStep(0.0, 0.0);
  for (Element &e : elements_) {
    Vec12 r;
    if (!Evaluate(*state, e, false, &r, nullptr, &e.recorded, nullptr)) e.recorded.setConstant(std::numeric_limits<double>::quiet_NaN());
    e.power = 0.0;
  }
  state->equations = saved;
}

void NodePairForceContributor::CommitStep(State *state)
{
  const StepEquations &eq = state->equations;
  for (Element &e : elements_) {
    Vec12 r, r_start;
    if (!Evaluate(*state, e, false, &r, nullptr, &e.recorded, nullptr)) continue;
    if (!eq.Dynamic()) continue;
    const NodeState &a = state->nodes[e.nodes[0]], &b = state->nodes[e.nodes[1]];
    Vec12            test;
    test << a.displacement_increment, NodeTangentScaledIncrement(eq, a), b.displacement_increment, NodeTangentScaledIncrement(eq, b);
    // Newmark family: the trapezoidal rule, the mean of the start state's residual and the end's.
    if (eq.NewmarkFamily() && Evaluate(*state, e, true, &r_start, nullptr, nullptr, nullptr)) r = 0.5 * (r_start + r);
    e.power = -r.dot(test) / eq.scheme.dt;
  }
}

void NodePairForceContributor::AddHistory(const State &state, bool with_names, std::vector<HistoryValue> *values) const
{
  const bool dynamic = IsDynamic(*model_);
  for (const Element &e : elements_) {
    const ForceElement &element = model_->force_elements[e.element];
    const long long     order   = 8LL * element.number;
    if (element.kind == ForceElement::Kind::SpringDamper) {
      values->push_back({order, with_names ? element.name + ".length" : std::string(), e.recorded(0)});
      values->push_back({order + 1, with_names ? element.name + ".tension" : std::string(), e.recorded(1)});
    } else {
      const char *names[6] = {".force_x", ".force_y", ".force_z", ".moment_x", ".moment_y", ".moment_z"};
      for (int i = 0; i < 6; ++i) values->push_back({order + i, with_names ? element.name + names[i] : std::string(), e.recorded(i)});
    }
    if (dynamic) values->push_back({order + 7, with_names ? element.name + ".power" : std::string(), e.power});
  }
}

void NodePairForceContributor::FindNonFiniteBlocks(const State &state, const std::vector<char> &node_finite, TroubleFindings *findings) const
{
  for (const Element &e : elements_) {
    if (!node_finite[e.nodes[0]] || !node_finite[e.nodes[1]]) continue;
    Vec12 r;
    Mat12 K;
    if (Evaluate(state, e, false, &r, state.equations.InitialAcceleration() ? nullptr : &K, nullptr, nullptr) && r.allFinite() &&
        (state.equations.InitialAcceleration() || K.allFinite()))
      continue;
    const ForceElement &element = model_->force_elements[e.element];
    findings->Offer(TroubleSource::ForceElement, element.number, "force element '" + element.name + "'");
  }
}

} // namespace msflex
