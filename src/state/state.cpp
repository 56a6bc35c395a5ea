#include "state/state.hpp"

#include "model/joint_geometry.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include <array>
#include <cmath>
#include <limits>

namespace msflex {

namespace {

// exp(omega) R_n, H(omega) and H(omega)^{-1} (which the inertia's tangents read) from one
// evaluation of the series c_n(|omega|^2): this runs per node and Newton iterate. `midpoint`: also
// the mid-point schemes' tangent-scaled increment, from the same series.
void NodeUpdateConfiguration(NodeState *node, bool midpoint = false)
{
  const Vec3          &omega     = node->rotation_increment;
  const RotationSeries series    = RotationSeriesValues(omega.squaredNorm());
  node->position                 = node->position_start + node->displacement_increment;
  node->rotation                 = RodriguesMatrix(ExpForm(series), omega) * QuaternionToMatrix(node->rotation_start);
  node->rotation_tangent         = RodriguesMatrix(TangentForm(series), omega);
  node->rotation_tangent_inverse = RodriguesMatrix(TangentInverseForm(series), omega);
  if (midpoint) TangentScaledIncrement(omega, series.c[1], series.c[2], &node->tangent_scaled_increment, &node->tangent_scaled_derivative);
}

void NodeCommit(NodeState *node)
{
  node->rotation_start         = NodeStateCurrentQuaternion(*node);
  node->position_start         = node->position_start + node->displacement_increment;
  node->displacement_increment = Vec3::Zero();
  node->rotation_increment     = Vec3::Zero();
  NodeUpdateConfiguration(node);
}

} // namespace

Quaternion NodeStateCurrentQuaternion(const NodeState &node)
{
  return QuaternionNormalize(QuaternionMultiply(QuaternionFromRotationVector(node.rotation_increment), node.rotation_start));
}

void StateCreate(const Model &model, const DofMap &map, State *state)
{
  *state                 = State{};
  state->num_owned_nodes = map.num_owned_nodes;
  state->nodes.resize(map.local_nodes.size());
  for (size_t l = 0; l < state->nodes.size(); ++l) {
    state->nodes[l].position_start = model.nodes[map.local_nodes[l]].position;
    NodeUpdateConfiguration(&state->nodes[l]);
  }
  state->node_joint.assign(state->nodes.size(), -1);
  for (int j : map.local_joints) {
    const Joint &joint = model.joints[j];
    JointState   J;
    J.joint        = j;
    J.local_slave  = map.node_to_local[joint.slave];
    J.local_master = joint.master >= 0 ? map.node_to_local[joint.master] : -1;
    J.geometry     = JointGeometryOf(joint, JointReferenceOffset(model, joint));
    J.map.setZero();
    J.rows_map.setZero();
    state->node_joint[J.local_slave] = (int)state->joints.size();
    state->joints.push_back(J);
  }
  bool damped = false;
  for (const Section &section : model.sections) damped = damped || section.Damped();
  if (damped) state->beam_strains.assign(map.local_elements.size(), BeamStrainMotion{});
  for (size_t b = 0; b < model.rigid_bodies.size(); ++b) {
    const RigidBody &body = model.rigid_bodies[b];
    const int        l    = map.node_to_local[body.node];
    if (l < 0 || l >= map.num_owned_nodes) continue;
    RigidBodyState local;
    local.body         = (int)b;
    local.global_index = map.global_rigid_bodies[b];
    local.local_node   = l;
    local.mass         = body.mass;
    local.offset       = body.offset;
    state->bodies.push_back(local);
  }
  StateUpdateSlaves(model, state); // the joints' maps at the reference configuration
}

void StateUpdateNode(const StepEquations &equations, NodeState *s)
{
  if (equations.RateUnknowns()) return;
  NodeUpdateConfiguration(s, equations.Midpoint());
  if (!equations.Dynamic()) return;
  s->translation_update = AdvanceMotion(equations.scheme, s->translation_motion, s->displacement_increment);
  for (int d = 0; d < 3; ++d)
    if (s->prescribed_rates & (1u << d)) {
      s->translation_update.velocity(d)     = s->prescribed_velocity(d);
      s->translation_update.acceleration(d) = s->translation_update.pseudo_acceleration(d) = s->prescribed_acceleration(d);
    }
}

MotionUpdate NodeSpinUpdate(const TimeScheme &scheme, const NodeState &node)
{
  if (node.prescribed_spin) return node.prescribed_spin_motion;
  return AdvanceMotion(scheme, node.rotation_motion, QuaternionToMatrix(node.rotation_start).transpose() * node.rotation_increment);
}

// The node's material spin at the end of the step from its material increment: Theta = R_n^T omega
// (Newmark family, or the prescribed spin), theta = R_n^T alpha (mid-point).
static MotionUpdate NodeEndSpin(const TimeScheme &scheme, const NodeState &s)
{
  if (!scheme.Midpoint()) return NodeSpinUpdate(scheme, s);
  return AdvanceMotion(scheme, s.rotation_motion, QuaternionToMatrix(s.rotation_start).transpose() * s.tangent_scaled_increment);
}

Vec3 NodeTangentScaledIncrement(const StepEquations &equations, const NodeState &node)
{
  if (equations.Midpoint()) return node.tangent_scaled_increment;
  Vec3 alpha;
  TangentScaledIncrement(node.rotation_increment, &alpha, nullptr);
  return alpha;
}

// A node's velocity and angular velocity, spatial.
static Vec6 SpatialVelocity(const NodeState &s)
{
  Vec6 v;
  v << s.translation_motion.velocity, QuaternionToMatrix(s.rotation_start) * s.rotation_motion.velocity;
  return v;
}

// The kinetic energy of rigid bodies on a node as a quadratic form of its spatial velocity
// (v, w): T = 1/2 sum m |v - c^ w|^2 + 1/2 w^T J_c w, c = R offset, J_c = R J R^T.
static Eigen::Matrix<double, 6, 6> KineticEnergyMetric(const Model &model, const std::vector<int> &bodies, const Mat3 &R)
{
  Eigen::Matrix<double, 6, 6> W = Eigen::Matrix<double, 6, 6>::Zero();
  for (int b : bodies) {
    const RigidBody &body = model.rigid_bodies[b];
    const Mat3       hat  = Skew(R * body.offset);
    W.topLeftCorner<3, 3>() += body.mass * Mat3::Identity();
    W.topRightCorner<3, 3>() -= body.mass * hat;
    W.bottomLeftCorner<3, 3>() += body.mass * hat;
    W.bottomRightCorner<3, 3>() += R * body.inertia * R.transpose() - body.mass * hat * hat;
  }
  return W;
}

// The rigid bodies' centre-of-mass velocities from their nodes' velocities at the start state.
static void SetBodyVelocities(State *state)
{
  for (RigidBodyState &body : state->bodies) {
    const NodeState &s           = state->nodes[body.local_node];
    const Vec6       v           = SpatialVelocity(s);
    body.centre_of_mass.velocity = v.head<3>() + v.tail<3>().cross(QuaternionToMatrix(s.rotation_start) * body.offset);
  }
}

// Fixed DOFs keep a zero increment. A prescribed displacement reaches its absolute target
// X + value f(t_end); a prescribed rotation component turns by value (f(t_end) - f(t_start)) about
// its global axis. In the initial-acceleration problem the unknowns are accelerations, so a
// prescribed DOF gets value f''(t). A driven released coordinate reaches q(t_end) (DriveCoordinate).
void StateBeginStep(const Model &model, const DofMap &map, const StepEquations &equations, State *state)
{
  state->equations     = equations;
  const double t_start = equations.t_start, t_end = equations.t_end;
  const bool   accelerations = equations.InitialAcceleration(), velocities = equations.problem == StepProblem::InitialVelocity;
  // Newmark family: a prescribed translation's end-of-step rates are the motion's own (NodeState).
  const bool exact_rates = equations.NewmarkFamily();
  for (size_t l = 0; l < state->nodes.size(); ++l) {
    const int  node    = map.local_nodes[l];
    NodeState &s       = state->nodes[l];
    s.prescribed_rates = 0;
    s.prescribed_spin  = false;
    // A rotation prescribed about one global axis with the other two fixed is exp(phi(t) e_d)
    // Lambda_0 whatever the steps: its spatial rates are phi' e_d and phi'' e_d. (Components
    // prescribed about two or more axes compose step by step, which no closed-form rate follows.)
    int  prescribed_rotations = 0, fixed_rotations = 0;
    Vec3 spin_rate = Vec3::Zero(), spin_acceleration = Vec3::Zero();
    for (int d = 0; d < 6; ++d) {
      const DofConstraint &c = map.constraints[node][d];
      if (c.kind == Support::Kind::Free) continue;
      double value = 0.0;
      if (c.kind == Support::Kind::Prescribed) {
        // The end-of-step rates are the step's own, from the left of t_end where f has a kink (a
        // table's point, a ramp's end: the spin-up's table ends at the run's last time, where the
        // rate from the right was 0 and the last row's root turned at 0 instead of 6 rad/s).
        const auto motion = [&](double t, int order) {
          return c.value * PrescribedMotion(model, c.function, c.by_rate, t, order, order > 0 && exact_rates ? TimeSide::Before : TimeSide::After);
        };
        if (accelerations || velocities) value = motion(t_end, accelerations ? 2 : 1);
        else if (d < 3) value = model.nodes[node].position(d) + motion(t_end, 0) - s.position_start(d);
        else value = motion(t_end, 0) - motion(t_start, 0);
        if (exact_rates && d < 3) {
          s.prescribed_rates |= 1u << d;
          s.prescribed_velocity(d)     = motion(t_end, 1);
          s.prescribed_acceleration(d) = motion(t_end, 2);
        } else if (exact_rates) {
          ++prescribed_rotations;
          spin_rate(d - 3)         = motion(t_end, 1);
          spin_acceleration(d - 3) = motion(t_end, 2);
        }
      } else if (d >= 3) {
        ++fixed_rotations;
      }
      if (d < 3) s.displacement_increment(d) = value;
      else s.rotation_increment(d - 3) = value;
    }
    StateUpdateNode(equations, &s);
    if (prescribed_rotations == 1 && fixed_rotations == 2) {
      // Material rates at t_end: W = Lambda^T w, Wdot = Lambda^T wdot (w x w = 0).
      const Vec3 W_dot         = s.rotation.transpose() * spin_acceleration;
      s.prescribed_spin        = true;
      s.prescribed_spin_motion = {s.rotation.transpose() * spin_rate, W_dot, W_dot};
    }
  }
  for (JointState &J : state->joints) {
    const Joint &joint = model.joints[J.joint];
    for (int c = 0; c < kJointMaxReleased; ++c) J.increment[c] = 0.0;
    if (joint.driven_coordinate < 0) continue;
    const int c = joint.driven_coordinate;
    J.increment[c] =
        accelerations || velocities ? DriveCoordinate(model, joint, t_end, accelerations ? 2 : 1) : DriveCoordinate(model, joint, t_end, 0) - J.start.q[c];
    if (exact_rates)
      J.drive_rate         = DriveCoordinate(model, joint, t_end, 1, TimeSide::Before),
      J.drive_acceleration = DriveCoordinate(model, joint, t_end, 2, TimeSide::Before);
  }
  StateUpdateSlaves(model, state);
  if (!exact_rates) return;
  // The slave of a drive to the ground whose joint releases nothing else moves as the drive
  // prescribes: with the map's column n_q of the coordinate (J.map at q(t_end)),
  //   (v, w) = n_q q',   (a, wdot) = n_q q'' + d(n_q)/dq q'^2,
  // where only a dependent translation f(phi) (a cam) bends the path: d(n_q)/dq = f''(phi) a_dep.
  for (JointState &J : state->joints) {
    const Joint &joint = model.joints[J.joint];
    if (J.local_master >= 0 || joint.driven_coordinate < 0 || JointNumCoordinates(J.geometry) != 1) continue;
    NodeState   &slave = state->nodes[J.local_slave];
    const double rate = J.drive_rate, acceleration = J.drive_acceleration;
    const Vec6   column = J.map.col(6);
    Vec3         a      = acceleration * column.head<3>();
    if (J.geometry.dependence != JointDependence::None) {
      double f, df, ddf;
      JointDependentTranslation(J.geometry, J.start.q[0] + J.increment[0], &f, &df, &ddf);
      a += ddf * rate * rate * J.geometry.axes.col(J.geometry.dependent_axis);
    }
    slave.prescribed_rates        = 0x7;
    slave.prescribed_velocity     = rate * column.head<3>();
    slave.prescribed_acceleration = a;
    const Vec3 W_dot              = slave.rotation.transpose() * (acceleration * column.tail<3>());
    slave.prescribed_spin         = true;
    slave.prescribed_spin_motion  = {slave.rotation.transpose() * (rate * column.tail<3>()), W_dot, W_dot};
    StateUpdateNode(equations, &slave);
  }
}

void StateUpdateSlaves(const Model &model, State *state)
{
  const StepEquations &equations     = state->equations;
  const bool           accelerations = equations.RateUnknowns(); // accelerations or velocities: linear in N
  for (JointState &J : state->joints) {
    const Joint &joint = model.joints[J.joint];
    NodeState   &slave = state->nodes[J.local_slave];
    Vec3         x_m   = model.nodes[joint.slave].position; // the ground frame sits at the slave's reference position
    Mat3         R_m   = Mat3::Identity();
    if (J.local_master >= 0) {
      x_m = state->nodes[J.local_master].position;
      R_m = state->nodes[J.local_master].rotation;
    }
    // In the initial-acceleration problem the increments are accelerations: the map stays at the start.
    JointCoordinates q = J.start;
    if (!accelerations)
      for (int c = 0; c < kJointMaxReleased; ++c) q.q[c] += J.increment[c];
    JointMatrix &N = J.map;
    JointMap(J.geometry, q, R_m, &N);
    const int k = JointNumCoordinates(J.geometry);
    if (accelerations) {
      // Accelerations: (xddot_s, wdot_s) = N (xddot_m, wdot_m, qddot) + (dN/dt) (v_m, w_m, qdot), the
      // second the centripetal and Coriolis terms of the start's velocities
      // (JointVelocityProductAcceleration; the initial-velocity problem has none). Without them a
      // slave started moving had a wrong first acceleration, the first row's reactions lacked its
      // centripetal force, and newmark's trapezoidal rule, whose error mode -1 never decays, carried
      // the error on growing.
      Eigen::Matrix<double, 6 + kJointMaxReleased, 1> rates = Eigen::Matrix<double, 6 + kJointMaxReleased, 1>::Zero();
      if (J.local_master >= 0)
        rates << state->nodes[J.local_master].displacement_increment, state->nodes[J.local_master].rotation_increment,
            Eigen::Matrix<double, kJointMaxReleased, 1>::Zero();
      for (int c = 0; c < k; ++c) rates(6 + c) = J.increment[c];
      Eigen::Matrix<double, 6, 1> slave_accelerations = N * rates;
      if (equations.InitialAcceleration()) {
        Vec3 w_m = Vec3::Zero();
        if (J.local_master >= 0) w_m = R_m * state->nodes[J.local_master].rotation_motion.velocity; // (R_m is the start's here)
        double coordinate_rates[kJointMaxReleased];
        for (int c = 0; c < kJointMaxReleased; ++c) coordinate_rates[c] = J.CoordinateRate(c);
        slave_accelerations += JointVelocityProductAcceleration(J.geometry, q, R_m, w_m, coordinate_rates);
      }
      slave.displacement_increment = slave_accelerations.head<3>();
      slave.rotation_increment     = slave_accelerations.tail<3>();
    } else {
      // The slave's step from the steps of its master and coordinates, never from differences of
      // positions or rotations formed from the coordinates themselves: q_n + dq rounds to eps |q|,
      // and a coordinate that has gone far (a shaft at 130 rad, a slider 2 km along) would make
      // the slave's increments a staircase in the unknowns, whose steps the inertia turns into a
      // residual floor that Newton cannot pass (docs/joints.md). With b_n = b(q_n),
      //   x_s - x_s,n = dx_m + R_m (b(q_n + dq) - b_n) + (R_m - R_m,n) b_n + (x_m,n + R_m,n b_n - x_s,n),
      //   R_s = R_m [C(q_n + dq) C(q_n)^T] C(q_n),
      // the brackets from dq alone (JointOffsetStep, JointRotationStep); the last term of the first
      // line is constant during the step.
      Vec3 dx_m = Vec3::Zero(), x_m_start = x_m;
      Mat3 R_m_start = Mat3::Identity();
      if (J.local_master >= 0) {
        const NodeState &master = state->nodes[J.local_master];
        dx_m                    = master.displacement_increment;
        x_m_start               = master.position_start;
        R_m_start               = QuaternionToMatrix(master.rotation_start);
      }
      const Vec3 b_start           = JointOffset(J.geometry, J.start);
      slave.displacement_increment = dx_m + R_m * JointOffsetStep(J.geometry, J.start, J.increment) + (R_m - R_m_start) * b_start +
                                     (x_m_start + R_m_start * b_start - slave.position_start);
      const Mat3 R_s           = R_m * JointRotationStep(J.geometry, J.start, J.increment) * JointReleasedRotation(J.geometry, J.start);
      slave.rotation_increment = LogSO3(R_s * QuaternionToMatrix(slave.rotation_start).transpose());
      StateUpdateNode(equations, &slave);
    }
    if (equations.Dynamic())
      for (int half = 0; half < 2; ++half)
        J.coordinate_update[half] =
            AdvanceMotion(equations.scheme, J.coordinate_motion[half], Vec3(J.increment[3 * half], J.increment[3 * half + 1], J.increment[3 * half + 2]));
    // Newmark family: a driven coordinate's end-of-step rates are the drive's own (the scheme's
    // second difference of a prescribed motion never settles, NodeState::prescribed_rates), for the
    // force elements on it and the next step's start.
    if (equations.NewmarkFamily() && joint.driven_coordinate >= 0) {
      const int     c            = joint.driven_coordinate;
      MotionUpdate &update       = J.coordinate_update[c / 3];
      update.velocity(c % 3)     = J.drive_rate;
      update.acceleration(c % 3) = update.pseudo_acceleration(c % 3) = J.drive_acceleration;
    }
    // Rows of the mid-point schemes: the conserving map of eq. (21-22), so that the slave's work
    // and momenta carry over exactly; elsewhere N itself.
    J.rows_map = N;
    for (int c = 0; c < kJointMaxReleased; ++c) J.released_test[c] = J.increment[c];
    if (equations.Midpoint()) {
      Vec3 x_m_start = model.nodes[joint.slave].position, alpha_m = Vec3::Zero();
      Mat3 R_m_start = Mat3::Identity();
      if (J.local_master >= 0) {
        const NodeState &master = state->nodes[J.local_master];
        x_m_start               = master.position_start;
        R_m_start               = QuaternionToMatrix(master.rotation_start);
        alpha_m                 = master.tangent_scaled_increment;
      }
      JointConservingMap(J.geometry, J.start, J.increment, R_m_start, alpha_m, slave.position_start - x_m_start, slave.position - x_m, &J.rows_map,
                         J.released_test);
    }
  }
}

void StateCommitStep(const Model &model, State *state)
{
  const StepEquations &equations = state->equations;
  if (equations.Dynamic()) {
    const TimeScheme &scheme = equations.scheme;
    for (RigidBodyState &body : state->bodies) {
      const NodeState &s       = state->nodes[body.local_node];
      const Mat3       R_start = QuaternionToMatrix(s.rotation_start);
      if (scheme.Midpoint()) {
        // The centre of mass moves with its own algorithmic velocity (elements/inertia.hpp).
        const Vec3         u_c  = s.displacement_increment + (s.rotation - R_start) * body.offset;
        const MotionUpdate next = AdvanceMotion(scheme, body.centre_of_mass, u_c);
        body.centre_of_mass     = {next.velocity, next.acceleration, next.pseudo_acceleration};
      } else {
        // A point of the node's frame (RigidOffsetMassInertia): its motion follows from the node's.
        const MotionUpdate spin = NodeSpinUpdate(scheme, s);
        const Vec3        &c = body.offset, &W = spin.velocity;
        body.centre_of_mass.velocity            = s.translation_update.velocity + s.rotation * W.cross(c);
        body.centre_of_mass.acceleration        = s.translation_update.acceleration + s.rotation * (spin.acceleration.cross(c) + W.cross(W.cross(c)));
        body.centre_of_mass.pseudo_acceleration = body.centre_of_mass.acceleration;
      }
    }
    for (JointState &J : state->joints)
      for (int half = 0; half < 2; ++half)
        J.coordinate_motion[half] = {J.coordinate_update[half].velocity, J.coordinate_update[half].acceleration, J.coordinate_update[half].pseudo_acceleration};
    for (NodeState &s : state->nodes) {
      const MotionUpdate rotation = NodeEndSpin(scheme, s);
      s.translation_motion        = {s.translation_update.velocity, s.translation_update.acceleration, s.translation_update.pseudo_acceleration};
      s.rotation_motion           = {rotation.velocity, rotation.acceleration, rotation.pseudo_acceleration};
    }
  }
  for (NodeState &s : state->nodes) NodeCommit(&s);
  for (JointState &J : state->joints) {
    const int nt = J.geometry.num_translations;
    if (J.geometry.rotation == JointRotation::Free) {
      J.start.free_rotation_start = ExpSO3(Vec3(J.increment[nt], J.increment[nt + 1], J.increment[nt + 2])) * J.start.free_rotation_start;
      for (int c = 0; c < nt; ++c) J.start.q[c] += J.increment[c];
    } else {
      for (int c = 0; c < kJointMaxReleased; ++c) J.start.q[c] += J.increment[c];
    }
    for (double &increment : J.increment) increment = 0.0;
  }
  StateUpdateSlaves(model, state);
}

void StateCommitInitialAcceleration(State *state)
{
  for (RigidBodyState &body : state->bodies) {
    const NodeState &s = state->nodes[body.local_node];
    const Mat3       R = QuaternionToMatrix(s.rotation_start);
    const Vec3       r = R * body.offset, w = R * s.rotation_motion.velocity;
    const Vec3       a               = s.displacement_increment + s.rotation_increment.cross(r) + w.cross(w.cross(r));
    body.centre_of_mass.acceleration = body.centre_of_mass.pseudo_acceleration = a;
  }
  for (NodeState &s : state->nodes) {
    const Mat3 R                      = QuaternionToMatrix(s.rotation_start);
    s.translation_motion.acceleration = s.translation_motion.pseudo_acceleration = s.displacement_increment;
    s.rotation_motion.acceleration = s.rotation_motion.pseudo_acceleration = R.transpose() * s.rotation_increment;
    s.displacement_increment.setZero();
    s.rotation_increment.setZero();
  }
  for (JointState &J : state->joints) {
    for (int c = 0; c < kJointMaxReleased; ++c)
      J.coordinate_motion[c / 3].acceleration(c % 3) = J.coordinate_motion[c / 3].pseudo_acceleration(c % 3) = J.increment[c];
    for (double &increment : J.increment) increment = 0.0;
  }
}

void StateDiscardStep(const Model &model, State *state)
{
  for (NodeState &s : state->nodes) {
    s.displacement_increment.setZero();
    s.rotation_increment.setZero();
    StateUpdateNode(state->equations, &s);
  }
  for (JointState &J : state->joints)
    for (double &increment : J.increment) increment = 0.0;
  StateUpdateSlaves(model, state);
  // In the initial-acceleration problem a slave's "increment" holds its velocity products even at
  // zero unknowns; a discarded solve leaves no increment anywhere (the mid-point schemes discard
  // theirs, and a slave's would have read as a rotation: a universal joint started at rates
  // (1, 2) wrote a first frame turned by 2 rad).
  if (state->equations.RateUnknowns())
    for (const JointState &J : state->joints) {
      state->nodes[J.local_slave].displacement_increment.setZero();
      state->nodes[J.local_slave].rotation_increment.setZero();
    }
}

void StateSetInitialVelocities(const Model &model, const DofMap &map, double t, State *state)
{
  std::vector<const InitialCondition *> condition(model.nodes.size(), nullptr);
  for (const InitialCondition &ic : model.initial_conditions)
    for (int node : ic.nodes) condition[node] = &ic;
  for (size_t l = 0; l < state->nodes.size(); ++l) {
    const int  node = map.local_nodes[l];
    NodeState &s    = state->nodes[l];
    Vec3       v = Vec3::Zero(), w = Vec3::Zero();
    if (const InitialCondition *ic = condition[node]) {
      w = ic->angular_velocity;
      v = ic->velocity + (ic->rigid_body_field ? Vec3(ic->angular_velocity.cross(model.nodes[node].position - ic->center)) : Vec3::Zero());
    }
    for (int d = 0; d < 6; ++d) {
      const DofConstraint &c = map.constraints[node][d];
      if (c.kind == Support::Kind::Free) continue;
      const double rate = c.kind == Support::Kind::Prescribed ? c.value * PrescribedMotion(model, c.function, c.by_rate, t, 1) : 0.0;
      if (d < 3) v(d) = rate;
      else w(d - 3) = rate;
    }
    s.translation_motion.velocity = v;
    s.rotation_motion.velocity    = QuaternionToMatrix(s.rotation_start).transpose() * w;
  }
  for (const JointState &J : state->joints) {
    const Joint &joint = model.joints[J.joint];
    if (condition[joint.slave]) continue;
    NodeState &slave = state->nodes[J.local_slave];
    Vec3       v = Vec3::Zero(), w = Vec3::Zero();
    if (J.local_master >= 0) {
      const NodeState &master = state->nodes[J.local_master];
      w                       = QuaternionToMatrix(master.rotation_start) * master.rotation_motion.velocity;
      v                       = master.translation_motion.velocity + w.cross(slave.position_start - master.position_start);
    }
    slave.translation_motion.velocity = v;
    slave.rotation_motion.velocity    = QuaternionToMatrix(slave.rotation_start).transpose() * w;
  }
  SetBodyVelocities(state);
}

void StateSetInitialConfiguration(const Model &model, const DofMap &map, State *state)
{
  state->equations = StepEquations{};
  for (size_t l = 0; l < state->nodes.size(); ++l) {
    NodeState &s = state->nodes[l];
    s.displacement_increment.setZero();
    s.rotation_increment.setZero();
  }
  for (const InitialCondition &ic : model.initial_conditions) {
    if (ic.displacement.isZero(0.0) && ic.rotation.isZero(0.0)) continue;
    const Mat3 R = ExpSO3(ic.rotation);
    for (int node : ic.nodes) {
      const int l = map.node_to_local[node];
      if (l < 0 || state->node_joint[l] >= 0) continue;
      NodeState &s             = state->nodes[l];
      const Vec3 X             = model.nodes[node].position;
      const Vec3 moved         = ic.rigid_body_field ? Vec3(ic.center + R * (X - ic.center)) : X;
      s.displacement_increment = moved + ic.displacement - s.position_start;
      s.rotation_increment     = ic.rotation;
      NodeUpdateConfiguration(&s);
    }
  }
  for (const CoordinateInitialCondition &ic : model.coordinate_initial_conditions) {
    if (!ic.has_value) continue;
    const int j = map.joint_to_local[ic.joint];
    if (j < 0) continue;
    JointState &J              = state->joints[j];
    J.increment[ic.coordinate] = ic.value - J.start.q[ic.coordinate];
  }
  StateUpdateSlaves(model, state);
  StateCommitStep(model, state);
}

void StateSetCoordinateRates(const Model &model, const DofMap &map, double t, State *state, SlaveVelocityChange *largest_change)
{
  if (largest_change) *largest_change = SlaveVelocityChange{};
  // The coordinates given a rate, per local joint (NaN: none given).
  std::array<double, kJointMaxReleased> none;
  none.fill(std::numeric_limits<double>::quiet_NaN());
  std::vector<std::array<double, kJointMaxReleased>> given(state->joints.size(), none);
  for (const CoordinateInitialCondition &ic : model.coordinate_initial_conditions)
    if (const int j = ic.has_rate ? map.joint_to_local[ic.joint] : -1; j >= 0) given[j][ic.coordinate] = ic.rate;
  // Slaves given a velocity of their own (a node initial condition) keep it as far as their joint
  // allows; the others move with their master as their joint says, also when a joint above them
  // in the chain has just set the master moving (a bob welded below a hinge started at 3 rad/s
  // stayed at rest, and the weld was violated at velocity level).
  std::vector<char> own_velocity(model.nodes.size(), 0);
  for (const InitialCondition &ic : model.initial_conditions)
    for (int node : ic.nodes) own_velocity[node] = 1;
  // Which rigid bodies each node carries: the metric of a slave's "nearest" allowed velocity.
  std::vector<std::vector<int>> bodies_at(model.nodes.size());
  for (size_t b = 0; b < model.rigid_bodies.size(); ++b)
    if (const int node = model.rigid_bodies[b].node; node >= 0 && own_velocity[node]) bodies_at[node].push_back((int)b);
  for (size_t j = 0; j < state->joints.size(); ++j) {
    JointState  &J     = state->joints[j];
    const Joint &joint = model.joints[J.joint];
    const int    k     = JointNumCoordinates(J.geometry);
    // v_s - N_m v_m = N_q qdot (velocities of the slave and the master, spatial).
    NodeState            &slave   = state->nodes[J.local_slave];
    const Mat3            R       = QuaternionToMatrix(slave.rotation_start);
    const Vec6            own_v   = SpatialVelocity(slave);
    const Vec6            carried = J.local_master >= 0 ? Vec6(J.map.leftCols<6>() * SpatialVelocity(state->nodes[J.local_master])) : Vec6(Vec6::Zero());
    const Eigen::MatrixXd N_q     = J.map.block(0, 6, 6, k);
    Eigen::VectorXd       rates   = Eigen::VectorXd::Zero(k);
    const bool            own     = own_velocity[joint.slave] != 0;
    if (k > 0 && own) { // a rigid joint releases nothing; a slave without a velocity of its own turns with nothing
      const Vec6 relative = own_v - carried;
      // "Nearest" in the kinetic energy of the slave's rigid bodies when it carries any: the same
      // motion in any unit of length (in the plain norm of the 6 velocities a screw of 5 mm
      // pitch given 10 mm/s along its axis turned at 5e-5 rad/s in metres, 1.92 in millimetres).
      // Without a body, or where the bodies' energy does not fix every rate, the plain norm.
      const Eigen::Matrix<double, 6, 6>  W      = KineticEnergyMetric(model, bodies_at[joint.slave], R);
      const Eigen::MatrixXd              normal = N_q.transpose() * W * N_q;
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
      const double                       scale = normal.diagonal().cwiseAbs().maxCoeff();
      if (!bodies_at[joint.slave].empty() && ldlt.info() == Eigen::Success && scale > 0 && ldlt.vectorD().minCoeff() > 1e-12 * scale)
        rates = ldlt.solve(N_q.transpose() * W * relative);
      else rates = N_q.colPivHouseholderQr().solve(relative);
    }
    bool rate_given = false;
    for (int c = 0; c < k; ++c)
      if (!std::isnan(given[j][c])) rates(c) = given[j][c], rate_given = true;
    if (joint.driven_coordinate >= 0) rates(joint.driven_coordinate) = DriveCoordinate(model, joint, t, 1), rate_given = true;
    for (int c = 0; c < kJointMaxReleased; ++c) J.coordinate_motion[c / 3].velocity(c % 3) = c < k ? rates(c) : 0.0;
    // The slave as the joint moves it: v_s = N_m v_m + N_q qdot.
    const Vec6 v_s = N_q * rates + carried;
    // A slave's own velocity that its joint forbids, beyond what a rate given on purpose changes.
    if (own && !rate_given && largest_change) {
      const double change = (v_s - own_v).norm();
      if (change > largest_change->largest) *largest_change = SlaveVelocityChange{change, own_v.norm(), J.joint};
    }
    slave.translation_motion.velocity = v_s.head<3>();
    slave.rotation_motion.velocity    = R.transpose() * Vec3(v_s.tail<3>());
  }
  SetBodyVelocities(state);
}

bool NodeStateFinite(const NodeState &s)
{
  return s.displacement_increment.allFinite() && s.rotation_increment.allFinite() && s.position.allFinite() && s.rotation.allFinite() &&
         s.rotation_tangent.allFinite() && s.tangent_scaled_increment.allFinite() && s.tangent_scaled_derivative.allFinite() &&
         s.translation_update.velocity.allFinite() && s.translation_update.acceleration.allFinite();
}

void StateLocalErrorSums(const State &state, double dt, double sums[4])
{
  const TimeScheme &scheme = state.equations.scheme;
  const double      c      = std::abs((scheme.Midpoint() ? 0.25 : scheme.beta) - 1.0 / 6.0) * dt * dt;
  for (PetscInt l = 0; l < state.num_owned_nodes; ++l) {
    const NodeState   &s    = state.nodes[l];
    const MotionUpdate spin = NodeEndSpin(scheme, s);
    sums[0] += (c * (s.translation_update.acceleration - s.translation_motion.acceleration)).squaredNorm();
    sums[1] += s.displacement_increment.squaredNorm();
    sums[2] += (c * (spin.acceleration - s.rotation_motion.acceleration)).squaredNorm();
    sums[3] += s.rotation_increment.squaredNorm();
  }
}

double StateMaxRotationIncrement(const State &state, bool joint_angles)
{
  double largest = 0.0;
  for (PetscInt l = 0; l < state.num_owned_nodes; ++l) largest = std::max(largest, state.nodes[l].rotation_increment.norm());
  if (!joint_angles) return largest;
  for (const JointState &J : state.joints) {
    const int nt = J.geometry.num_translations;
    switch (J.geometry.rotation) {
    case JointRotation::None:
      break;
    case JointRotation::OneAxis:
      largest = std::max(largest, std::abs(J.increment[nt]));
      break;
    case JointRotation::TwoAxes:
      largest = std::max({largest, std::abs(J.increment[nt]), std::abs(J.increment[nt + 1])});
      break;
    case JointRotation::Free:
      largest = std::max(largest, Vec3(J.increment[nt], J.increment[nt + 1], J.increment[nt + 2]).norm());
      break;
    }
  }
  return largest;
}

} // namespace msflex
