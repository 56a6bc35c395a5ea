// The State: everything that moves, for the nodes, joints and rigid bodies a rank holds. The
// integrator owns it; assembly, output, checkpoints and diagnostics read it.
//
// Within a step the unknown is the increment from the start of the step (docs/theory.md):
// x = x_n + u, Lambda = exp(hat(omega)) Lambda_n. Ghost nodes
// receive the same increments as their owners (scattered by the assembler), so no rotation ever
// travels between ranks mid-step. A slave node's configuration follows from its master and its
// joint's released coordinates (StateUpdateSlaves). In the initial-acceleration problem
// (schemes/step_equations.hpp) the increment fields hold the unknown accelerations instead and the
// configuration stays at the start of the step.
//
// Lifecycle of a step: StateBeginStep (prescribed values, drives), then any number of trial
// increments (the assembler sets them and calls StateUpdateNode and StateUpdateSlaves), then
// StateCommitStep or StateDiscardStep.
#pragma once

#include "dofs/dof_map.hpp"
#include "joints/joint_kinematics.hpp"
#include "math/rotation.hpp"
#include "model/model.hpp"
#include "schemes/step_equations.hpp"
#include "schemes/time_scheme.hpp"

#include <Eigen/Core>

#include <array>
#include <vector>

namespace msflex {

struct NodeState {
  // At the start of the step (the last converged state).
  Vec3       position_start = Vec3::Zero();
  Quaternion rotation_start; // rotation from the reference configuration, tracked (see rotation.hpp)
  // Increment from the start of the step: the Newton unknowns (or prescribed values).
  Vec3 displacement_increment = Vec3::Zero();
  Vec3 rotation_increment     = Vec3::Zero();
  // Current configuration, derived from the two above by StateUpdateNode.
  Vec3 position                 = Vec3::Zero();
  Mat3 rotation                 = Mat3::Identity();
  Mat3 rotation_tangent         = Mat3::Identity(); // H(omega): d theta = H(omega) d omega
  Mat3 rotation_tangent_inverse = Mat3::Identity(); // H(omega)^{-1} (not finite at |omega| = 2 pi)

  // Dynamics at the start of the step: translation in global axes, rotation in the node's body
  // frame (W, Wdot and the Newmark family's pseudo-acceleration).
  MotionState translation_motion, rotation_motion;
  // Dynamics at the end of the step, derived from the increments by the time scheme.
  MotionUpdate translation_update;
  // Newmark family: the end-of-step velocity and acceleration of the translations a support
  // prescribes (bit d of prescribed_rates), the prescribed motion's own rates, which replace the
  // scheme's in translation_update. The trapezoidal rule's acceleration of a prescribed
  // displacement is its second difference, whose error alternates in sign from step to step and
  // never decays; the reaction (m a) then carried a sawtooth growing with time.
  unsigned prescribed_rates        = 0;
  Vec3     prescribed_velocity     = Vec3::Zero();
  Vec3     prescribed_acceleration = Vec3::Zero();
  // Newmark family: a node whose rotation is prescribed as a whole takes that motion's own
  // end-of-step material angular velocity W and acceleration Wdot instead of the scheme's
  // (NodeSpinUpdate), for the reason above: one rotation DOF prescribed with the other two fixed,
  // or the slave of a drive to the ground whose joint releases nothing else.
  bool         prescribed_spin = false;
  MotionUpdate prescribed_spin_motion; // W, Wdot and the pseudo-acceleration (= Wdot) at t_end
  // The kernels' argument: the prescribed spin, or null for the scheme's.
  const MotionUpdate *PrescribedSpin() const { return prescribed_spin ? &prescribed_spin_motion : nullptr; }
  // The mid-point schemes' tangent-scaled increment, kept current by StateUpdateNode for them only
  // (their residuals read it at every iterate); other readers call NodeTangentScaledIncrement.
  Vec3 tangent_scaled_increment  = Vec3::Zero();     // alpha = 2 tan(|omega|/2) omega/|omega|
  Mat3 tangent_scaled_derivative = Mat3::Identity(); // d alpha / d omega
  // The residual this rank assembled on the node's prescribed DOFs (the reaction that drives
  // them, zero on other DOFs) at the end of the last step: the Newmark family's work of the
  // reactions is the trapezoidal rule over the step.
  Eigen::Matrix<double, 6, 1> prescribed_reaction = Eigen::Matrix<double, 6, 1>::Zero();
};

using Vec6 = Eigen::Matrix<double, 6, 1>;

// A joint whose slave node is local.
struct JointState {
  int              joint        = -1; // index into the model's joints
  int              local_slave  = -1;
  int              local_master = -1; // -1: the ground
  JointGeometry    geometry;
  JointCoordinates start; // at the start of the step (a free rotation keeps C_n, q = 0)
  double           increment[kJointMaxReleased] = {0, 0, 0, 0, 0, 0};
  // Derived from the master and the increments by StateUpdateSlaves: the map N of the slave's
  // spin variations, the map of the residual rows (N, or the conserving map of the mid-point
  // schemes) and the released test quantities that go with it.
  JointMatrix map;
  JointMatrix rows_map;
  double      released_test[kJointMaxReleased] = {0, 0, 0, 0, 0, 0};
  // Output of an owned joint (Assembler::EvaluateJointReactions): force and moment on the slave,
  // mean rates of the released coordinates over the last step.
  Vec6 reaction = Vec6::Zero();
  // A driven joint: the generalised force its drive exerts on the driven coordinate (N or N m; the
  // slave's residual, with the force elements' on the coordinate's own row, mapped on the
  // coordinate; summed over the ranks), at the scheme's evaluation point, as `reaction`. Set with
  // it by Assembler::EvaluateJointReactions.
  double                                drive_force = 0.0;
  std::array<double, kJointMaxReleased> rate{};
  // The generalised reaction on a driven coordinate this rank assembled at the end of the last
  // step (the Newmark family's trapezoidal work of the drive).
  double drive_reaction = 0.0;
  // Newmark family: the drive's own rate and acceleration at the end of the step being solved,
  // q'(t_end) and q''(t_end) (StateBeginStep), which replace the scheme's.
  double drive_rate = 0.0, drive_acceleration = 0.0;
  // Dynamics of the released coordinates (dampers on them): rate, acceleration and the Newmark
  // family's pseudo-acceleration at the start of the step, coordinates 0-2 in [0] and 3-5 in [1],
  // and what the step's increments imply at its end (Newmark family).
  MotionState  coordinate_motion[2];
  MotionUpdate coordinate_update[2];
  // The coordinate's rate (start of the step) and, in dynamics, its end-of-step update.
  double CoordinateRate(int c) const { return coordinate_motion[c / 3].velocity(c % 3); }
  double CoordinateEndRate(int c) const { return coordinate_update[c / 3].velocity(c % 3); }
};

// Strains of a damped beam element at its Gauss points (at most two, elements/beam.hpp) as a
// motion of the Newmark family: the strain rates and their accelerations at the start of the step
// (structural damping, contributors/beam_damping_contributor.hpp), and the strains at the starts
// of the two steps before ([0]: e_{n-1}, [1]: e_{n-2}; per Gauss point), those steps' lengths and
// how many of them are known (0 to 2), from which a step's start rate is taken.
struct BeamStrainMotion {
  MotionState strain[2], curvature[2];
  Vec3        previous_strain[2][2], previous_curvature[2][2]; // [age][Gauss point]
  double      previous_steps[2] = {0.0, 0.0};
  int         previous_count    = 0;
};

// A rigid body on an owned node: its translational inertia sits at its centre of mass, which
// moves with its own algorithmic velocity (elements/inertia.hpp).
struct RigidBodyState {
  int         body         = -1; // index into the model's rigid bodies
  int         global_index = -1; // number in the whole model (checkpoints)
  int         local_node   = -1;
  double      mass         = 0.0;
  Vec3        offset       = Vec3::Zero(); // centre of mass, node body frame
  MotionState centre_of_mass;              // motion of the centre of mass, global axes
};

struct State {
  std::vector<NodeState>        nodes;           // per local node (DofMap::local_nodes: owned first)
  std::vector<JointState>       joints;          // per local joint (DofMap::local_joints: masters' joints first)
  std::vector<int>              node_joint;      // per local node: index into joints when it is a slave, else -1
  std::vector<RigidBodyState>   bodies;          // rigid bodies on owned nodes
  std::vector<BeamStrainMotion> beam_strains;    // per local element when a section is damped, else empty
  std::vector<Vec6>             probe_reactions; // per model probe: the supports' reaction at a reaction probe's node (Assembler::EvaluateSupportReactions)
  PetscInt                      num_owned_nodes = 0;
  StepEquations                 equations; // of the step being solved
};

// The local error estimate of a converged dynamic step, Zienkiewicz and Xie's for the Newmark
// family: e = (beta - 1/6) dt^2 (a_{n+1} - a_n) per owned node, of the translations and of the
// material angular accelerations, with beta = 1/4 for the mid-point schemes (trapezoidal in their
// positions; their accelerations are the steps' mean ones). Into sums, added: |e_x|^2, |u|^2,
// |e_theta|^2, |omega|^2 (the step's increments, the scale the error is measured against).
void StateLocalErrorSums(const State &state, double dt, double sums[4]);

// The reference configuration at rest.
void StateCreate(const Model &model, const DofMap &map, State *state);
// Starts a step: fixed DOFs keep a zero increment, prescribed DOFs and driven joint coordinates
// get their values at t_end (their second derivatives in the initial-acceleration problem), every
// other increment is zero; slaves follow.
void StateBeginStep(const Model &model, const DofMap &map, const StepEquations &equations, State *state);
// The configuration and, in dynamics, the end-of-step translational motion and the tangent-scaled
// rotation increment implied by a node's increments.
void StateUpdateNode(const StepEquations &equations, NodeState *node);
// Slave configurations from their masters and joints (masters first), the joints' maps N and the
// rows' maps (the conserving map of eq. 21-22 in the mid-point schemes).
void StateUpdateSlaves(const Model &model, State *state);
// Accepts the increments as the new start of step (with velocities and accelerations); slaves follow.
void StateCommitStep(const Model &model, State *state);
// Stores the solved initial accelerations as the start-of-step accelerations.
void StateCommitInitialAcceleration(State *state);
// Forgets the increments (a rejected step); slaves follow.
void StateDiscardStep(const Model &model, State *state);
// The initial configuration: nodes moved by their initial conditions' displacements and rotations,
// joint coordinates at their initial values; slaves follow. Starts the state there (at rest).
void StateSetInitialConfiguration(const Model &model, const DofMap &map, State *state);
// The rate of every joint coordinate implied by the slave's and master's velocities (the least-
// squares solution of N_q qdot = v_s - N_m v_m) where the slave has a velocity of its own (a node
// initial condition), else 0; used when the velocities are given rather than projected. Driven
// coordinates take their drive's rate, and coordinates given a `rate` in the initial conditions
// that rate. Every slave then moves as its joint says, v_s = N_m v_m + N_q qdot (masters first, so
// that a chain carries it on): a slave given a velocity its joint forbids gets the nearest one the
// joint allows (it kept the given one, and the kinetic energy counted the forbidden part for the
// whole run). *largest_change (when not null): the largest change of a slave's given velocity,
// |v_s - v_given| over the translational and angular parts, and the slave's joint (-1: none).
struct SlaveVelocityChange {
  double largest = 0.0, given = 0.0; // |v_s - v_given| and |v_given| of that slave
  int    joint = -1;                 // index into Model::joints
};
void StateSetCoordinateRates(const Model &model, const DofMap &map, double t, State *state, SlaveVelocityChange *largest_change = nullptr);
// Initial velocities from the model's initial conditions and prescribed motions at time t; a slave
// without an initial condition moves rigidly with its master.
void StateSetInitialVelocities(const Model &model, const DofMap &map, double t, State *state);
// Largest rotation increment of the step: |omega| over the owned nodes and, with `joint_angles`
// (dynamics), the released angles of the local joints (each angle of a one- or two-axis joint,
// |omega_R| of a free rotation). A joint angle counts on its own: the mid-point schemes measure it by tau = 2 tan(dphi/2), which repeats
// every 2 pi and whose equation vanishes at dphi = pi whatever the motion, so a step that turns a
// joint by pi satisfied them falsely (energy 47 -> 706 J under em with max_rotation_increment 3)
// while its nodes turned less (2.57 rad).
// (Statics leaves the joints out: a load step's equilibrium does not depend on how far a joint
// turned to reach it.)
double StateMaxRotationIncrement(const State &state, bool joint_angles);
// Whether everything a node holds for this step is finite (diagnostics).
bool NodeStateFinite(const NodeState &node);
// The tracked quaternion of a node's current rotation: q(omega) * q_n.
Quaternion NodeStateCurrentQuaternion(const NodeState &node);
// Newmark family: the node's end-of-step material rotational motion (W, Wdot and the
// pseudo-acceleration), the scheme's from its increment (Theta = Lambda_n^T omega) or a wholly
// prescribed rotation's own (NodeState::prescribed_spin).
MotionUpdate NodeSpinUpdate(const TimeScheme &scheme, const NodeState &node);
// alpha = 2 tan(|omega|/2) omega/|omega| of the node's rotation increment under any scheme: the
// kept value for the mid-point schemes, else evaluated here (the per-step work and power sums of
// the Newmark family).
Vec3 NodeTangentScaledIncrement(const StepEquations &equations, const NodeState &node);

} // namespace msflex
