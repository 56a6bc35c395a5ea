// The msflex model: plain data produced by the input reader (io/) and consumed by everything
// downstream. No PETSc, no MPI here. Beam lines and arcs are already expanded into nodes and
// elements; every object remembers where in the input it came from so later checks can name the
// file and line.
#pragma once

#include "joints/joint_kinematics.hpp"
#include "math/rotation.hpp"
#include "model/analysis_types.hpp"
#include "model/joint_kinds.hpp"
#include "schemes/time_scheme.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <string>
#include <vector>

namespace msflex {

// Where an object was defined: file and 1-based line/column.
struct SourceMark {
  std::string file;
  int         line   = 0;
  int         column = 0;
};

// Which side of t a derivative is taken from where a function has a kink: After (from the right,
// the coming motion) or Before (from the left, the motion up to t).
enum class TimeSide { After, Before };

// A scalar function of (pseudo-)time that multiplies a load or a prescribed motion.
struct TimeFunction {
  enum class Kind { Constant, Linear, Table, Harmonic, CosineRamp, Polynomial, Sum };
  std::string name;
  Kind        kind = Kind::Linear;
  // Constant: value = offset. Linear: value = offset + slope * t.
  // Harmonic: value = offset + amplitude * sin(2 pi frequency t + phase).
  // Table: piecewise linear through (times[i], values[i]), constant beyond the ends.
  // CosineRamp: amplitude (1 - cos(pi (t - start) / duration)) / 2 for start <= t < start +
  //   duration, amplitude after, 0 before: a ramp with zero rate at both ends.
  // Polynomial: sum_k values[k] t^k.
  // Sum: the sum of the functions numbered `terms`, each defined before this one.
  double              offset = 0.0, slope = 1.0, amplitude = 0.0, frequency = 0.0, phase = 0.0, duration = 1.0, start = 0.0;
  std::vector<double> times, values;
  std::vector<int>    terms;
  SourceMark          mark;
  // f(t) (order 0), f'(t), f''(t) (order 1, 2) or its integral from 0 to t (order -1), in closed
  // form. At a kink (a table's points, a ramp's ends) the derivatives are those after t (from the
  // right: the coming motion, at the start of an analysis) or, with TimeSide::Before, those before
  // it (from the left: a step's motion up to its end). A Sum needs the other functions:
  // FunctionValue and the like below.
  double Evaluate(double t, int order = 0, TimeSide side = TimeSide::After) const;
};

// Cross-section constants in the section frame (t1 = beam axis, t2, t3 principal axes).
struct Section {
  std::string name;
  double      EA = 0, GA2 = 0, GA3 = 0, GJ = 0, EI2 = 0, EI3 = 0; // N, N, N, N m^2, N m^2, N m^2
  double      rhoA = 0;                                           // mass per unit length, kg/m
  Vec3        rhoJ = Vec3::Zero();                                // rotational inertia per length (J1, J2, J3), kg m
  // Structural damping: viscous section forces C_d (Gammadot, Kdot) on the strain rates, C_d =
  // diag(damping_axial_shear, damping_torsion_bending) (N s, N s, N s, N m^2 s, N m^2 s, N m^2 s).
  Vec3       damping_axial_shear = Vec3::Zero(), damping_torsion_bending = Vec3::Zero();
  bool       Damped() const { return !damping_axial_shear.isZero(0.0) || !damping_torsion_bending.isZero(0.0); }
  SourceMark mark;
};

struct Node {
  std::string name;     // user name, or "<beam>.<k>" for nodes generated inside a beam line
  Vec3        position; // reference position, m
  SourceMark  mark;
};

// A Lagrange beam element of order 1 (2 nodes) or 2 (3 nodes, middle node in the middle).
struct BeamElement {
  int                section = -1;
  int                order   = 1;
  std::array<int, 3> nodes{{-1, -1, -1}};
  // Reference section triads at the element's nodes: columns t1 (axis), t2, t3. The current triad
  // of the section at element node a is R_node * reference_triads[a], where R_node is the node's
  // rotation from the reference configuration (identity at the start).
  std::array<Mat3, 3> reference_triads{{Mat3::Identity(), Mat3::Identity(), Mat3::Identity()}};
  int                 beam = -1; // index into Model::beams
};

// A generated beam (line or arc): a named group of consecutive elements.
struct Beam {
  std::string      name;
  int              section = -1;
  int              order   = 1;
  std::vector<int> elements;
  std::vector<int> nodes; // in order along the beam, including both end nodes
  SourceMark       mark;
};

struct NodeSet {
  std::string      name;
  std::vector<int> nodes;
  SourceMark       mark;
};

enum DofIndex { DOF_UX = 0, DOF_UY, DOF_UZ, DOF_RX, DOF_RY, DOF_RZ };

// A support fixes or prescribes any subset of the six DOFs of a set of nodes. Prescribed
// displacements are global components; a prescribed rotation component k is applied as the
// spin about global axis k (exact when a single rotation component is prescribed or all three
// are). value(t) = values[k] * function(t).
struct Support {
  enum class Kind { Free, Fixed, Prescribed };
  std::vector<int>      nodes;
  std::array<Kind, 6>   kind{{Kind::Free, Kind::Free, Kind::Free, Kind::Free, Kind::Free, Kind::Free}};
  std::array<double, 6> values{{0, 0, 0, 0, 0, 0}};
  std::array<bool, 6>   by_rate{{false, false, false, false, false, false}}; // prescribe_rate: the DOF's rate is value * function
  int                   function = -1;                                       // index into Model::functions; -1: linear ramp value * t
  SourceMark            mark;
};

// Concentrated load on each node of a set: value(t) = (force, moment) * function(t).
// Dead loads keep their global direction; follower loads are given in the node's rotated frame
// (f = R_node f0, m = R_node m0).
struct NodalLoad {
  std::vector<int> nodes;
  Vec3             force    = Vec3::Zero();
  Vec3             moment   = Vec3::Zero();
  bool             follower = false;
  int              function = -1;
  SourceMark       mark;
};

// Distributed dead load per unit reference length on a set of elements. With gravity = true the
// load is rhoA * acceleration on every element (elements lists all of them).
struct DistributedLoad {
  std::vector<int> elements;
  Vec3             force_per_length = Vec3::Zero(); // N/m, or m/s^2 when gravity
  bool             gravity          = false;
  int              function         = -1;
  SourceMark       mark;
};

// A rigid body attached to a node: mass, inertia tensor about its centre of mass and the offset of
// the centre of mass from the node, both given in global axes for the reference configuration
// (the node's rotation is the identity there, so they are also the node's body-frame values).
struct RigidBody {
  std::string name; // optional (probes refer to it)
  int         node    = -1;
  double      mass    = 0.0;          // kg
  Mat3        inertia = Mat3::Zero(); // kg m^2, about the centre of mass, symmetric positive semi-definite
  Vec3        offset  = Vec3::Zero(); // m, centre of mass minus node position
  SourceMark  mark;
};

// Initial velocities of a set of nodes: uniform (v = velocity) or a rigid-body field
// v = velocity + angular_velocity x (X - center) when `rigid_body_field`; every node of the set
// gets the angular velocity `angular_velocity` (global axes).
// Initial displacements: the set is moved rigidly (rotation vector `rotation`, global axes, about
// `center` when `rigid_body_field`, else about each node) and translated by `displacement`.
struct InitialCondition {
  std::vector<int> nodes;
  Vec3             velocity         = Vec3::Zero(); // m/s
  Vec3             angular_velocity = Vec3::Zero(); // rad/s
  bool             rigid_body_field = false;
  Vec3             center           = Vec3::Zero(); // m
  bool             has_velocity     = false;        // velocity or angular_velocity given
  Vec3             displacement     = Vec3::Zero(); // m
  Vec3             rotation         = Vec3::Zero(); // rad, rotation vector in global axes
  SourceMark       mark;
};

// The initial value and rate of a joint's released coordinate (from the reference value 0).
struct CoordinateInitialCondition {
  int        joint = -1, coordinate = -1;
  bool       has_value = false, has_rate = false;
  double     value = 0.0, rate = 0.0; // m or rad, m/s or rad/s
  SourceMark mark;
};

// A master–slave joint (docs/joints.md). The slave node's motion follows from the master's and
// the released coordinates; the joint axes a1, a2, a3 are given in global axes at the reference
// configuration. master = -1 means the ground (a fixed frame).
struct Joint {
  using Rotation   = JointRotation; // the kinematics' enums (joints/joint_kinematics.hpp)
  using Dependence = JointDependence;
  std::string         name;
  JointKind           kind   = JointKind::Rigid; // the registered kind (model/joint_kinds.hpp)
  int                 master = -1, slave = -1;
  Mat3                axes             = Mat3::Identity(); // columns a1, a2, a3: orthonormal, right-handed
  int                 num_translations = 0;                // released translations along axes translation_axis[0..n)
  std::array<int, 3>  translation_axis{{0, 1, 2}};
  Rotation            rotation = Rotation::None;
  std::array<int, 2>  rotation_axis{{0, 1}};             // OneAxis: [0]; TwoAxes: [0] then [1] (rotation about a_[0], then about the carried a_[1])
  Dependence          dependence     = Dependence::None; // translation along a_dependent_axis = f(phi) - f(0)
  int                 dependent_axis = 0;
  double              coefficient    = 0.0; // Linear: f = c phi (pitch, pinion radius); EccentricCam: f = R cos(phi)
  double              profile_period = 0.0; // Table: periodic cubic spline through (knots, values)
  std::vector<double> profile_knots, profile_values, profile_second;
  // A driven released coordinate: q_k(t) = drive_value * function(t) (k indexes translations, then rotations).
  int    driven_coordinate = -1;
  double drive_value       = 0.0;
  int    drive_function    = -1;    // -1: ramp f(t) = t
  bool   drive_by_rate     = false; // q'(t) = drive_value * function(t), q(0) = 0
  // The driven coordinate as the input names it per unit of the released one: 1, or the dependent
  // translation's coefficient (pitch, radius) when a screw or rack is driven by its translation,
  // whose drive_force is then the force along it, Q_phi / coefficient.
  double     drive_coordinate_scale = 1.0;
  bool       drive_by_translation   = false; // a screw or rack driven by its translation (drive_force in N)
  SourceMark mark;
};

// What a probe records every step: a point moving with a node's frame (position x + Lambda offset;
// offset in global axes at the reference configuration, the centre of mass for a rigid body's
// probe), the reaction of a node's supports, or the section forces of an element.
struct Probe {
  enum class Kind { Point, Reaction, Element };
  std::string name;
  Kind        kind    = Kind::Point;
  int         node    = -1;           // Point, Reaction
  Vec3        offset  = Vec3::Zero(); // Point, m
  int         element = -1;           // Element: index into Model::elements
  SourceMark  mark;
};

// A force element (docs/input.md, force_elements): on a joint's released coordinate (a spring,
// linear or tabulated, a linear damper and an actuator following a function of time), an axial
// spring-damper between two nodes, or a bushing between two nodes.
struct SpringLaw {
  bool                present    = false;
  double              stiffness  = 0.0;    // N/m or N m/rad
  double              free_value = 0.0;    // m or rad: the coordinate (length) at which the force vanishes
  std::vector<double> deflections, forces; // tabulated f(x - free_value) when non-empty
};
struct ForceElement {
  enum class Kind { Coordinate, SpringDamper, Bushing };
  std::string        name;
  int                number = -1; // in the whole model (kept by the distributed model)
  Kind               kind   = Kind::Coordinate;
  int                joint = -1, coordinate = -1; // Coordinate: the joint and its released coordinate
  std::array<int, 2> nodes{{-1, -1}};             // SpringDamper, Bushing
  SpringLaw          spring;                      // Coordinate, SpringDamper
  double             damping           = 0.0;     // Coordinate, SpringDamper: N s/m or N m s/rad
  bool               has_actuator      = false;   // Coordinate
  double             actuator          = 0.0;     // N or N m at function value 1
  int                actuator_function = -1;      // -1: ramp f(t) = t
  // Bushing: 6x6 stiffness and damping in bushing axes (translations, then rotations), the axes.
  Eigen::Matrix<double, 6, 6> bushing_stiffness = Eigen::Matrix<double, 6, 6>::Zero(), bushing_damping = Eigen::Matrix<double, 6, 6>::Zero();
  Mat3                        axes = Mat3::Identity();
  SourceMark                  mark;
};

// A result an example must reproduce (docs/input.md, expected): the solver ignores it; the test
// suite compares it with the result file.
struct ExpectedResult {
  std::string series;            // a /history series
  double      time = -1.0;       // the row at this time, or -1 with `statistic`
  std::string statistic;         // max, min, final, range, max_abs
  bool        has_value = false; // value +- tolerance
  double      value = 0.0, tolerance = 0.0, relative_tolerance = 0.0;
  bool        has_below = false, has_above = false;
  double      below = 0.0, above = 0.0;
  SourceMark  mark;
};

// Static analysis: the loads are multiplied by their functions of the pseudo-time t in
// [0, end_time]; the default function is the ramp f(t) = t, so t is the load factor.
// Dynamic analysis: t is time, the steps are time steps, and `integrator` selects the scheme.
struct AnalysisSettings {
  AnalysisType     type            = AnalysisType::Static;           // model/analysis_types.hpp
  TimeSchemeKind   integrator      = TimeSchemeKind::EnergyMomentum; // dynamic only; schemes/time_scheme.hpp
  double           spectral_radius = 0.9;                            // rho_infinity of genalpha, in [0, 1]
  EnergyCorrection em_correction   = EnergyCorrection::Resultants;   // the correction vector of em (schemes/time_scheme.hpp)
  ReactionPoint    reactions       = ReactionPoint::Consistent;      // where dynamics reports reactions (docs/joints.md)
  double           end_time        = 1.0;
  double           initial_step    = 0.1;
  double           min_step        = 1e-6;
  double           max_step        = 1.0;   // DefaultMaxStep unless max_step_given
  bool             max_step_given  = false; // by the input or -analysis_max_step: else DefaultMaxStep
  // Dynamics: > 0 controls the step by the local error estimate (docs/dynamics.md, step size and
  // accuracy), the error of a step relative to its motion; 0: no error control.
  double step_tolerance         = 0.0;
  double growth_factor          = 1.5; // step multiplier after easy steps
  int    easy_iterations        = 5;   // a step converged in <= this many iterations is easy
  int    easy_steps_to_grow     = 2;   // consecutive easy steps before growing
  double max_rotation_increment = 1.0; // rad: a step whose |omega| exceeds it is halved
  int    max_newton_iterations  = 25;
  double newton_rtol            = 1e-10;
  double newton_atol            = 1e-50;
  // Modified Newton: the factored tangent is kept while every iteration reduces the residual at
  // least by this factor (in [0, 1); 0: a new tangent every iteration), also into the next step
  // when it has the same length and the last iteration contracted (docs/solvers.md).
  double jacobian_reuse = 0.0;
  // Dynamics, and statics without `stability`: a chain of joints deeper than this keeps every
  // condensation_depth-th slave that is a master as a relay node in the linear solve (DofMap), so
  // that a long chain costs linear time; 0 condenses every chain whole (docs/solvers.md).
  int condensation_depth = 8;
  // Newton's linear solver (docs/solvers.md, "Large networks in statics"): direct, or GMRES with
  // algebraic multigrid on the nodes' rigid-body modes.
  LinearSolverKind linear_solver = LinearSolverKind::Direct;
  // Its direct factorisation: by the tangent's structure, or MUMPS always (docs/solvers.md).
  DirectSolverChoice  direct_solver = DirectSolverChoice::Auto;
  std::vector<double> output_times; // steps are shortened to hit these exactly
  // Dynamic analyses: a static stage first (equilibrium under the loads at t = 0, reached in
  // load steps starting at 1/static_stage_steps), then the motion from it.
  bool static_stage       = false;
  int  static_stage_steps = 1;
  // Initial velocities: projected (drives, given velocities and the least strain rate of the
  // beams, docs/input.md) or given (as written, others at rest).
  bool project_initial_velocities = true;
  // Path following in statics (docs/stability.md). control: what the steps advance (model/
  // analysis_types.hpp). Arc length: psi weighs the load factor in the constraint (0:
  // cylindrical), desired_iterations steer the arc length, max_steps bounds a path that never
  // reaches end_time. Displacement control: the node DOF (ux..rz) or joint coordinate (tx..rz
  // along/about the joint axes) named by control_node or control_joint and control_dof follows
  // control_value * t.
  PathControl control            = PathControl::Load;
  double      arc_length_psi     = 0.0;
  int         desired_iterations = 5;
  int         max_steps          = 1000;
  std::string control_node, control_joint;
  int         control_dof   = -1; // 0..5: ux uy uz rx ry rz, or the joint's tx ty tz rx ry rz
  double      control_value = 1.0;
  // Per converged static step: the negative pivots and lowest eigenvalue of the tangent, critical
  // points named (docs/stability.md).
  bool stability = true;
  // Eigenanalyses: how many eigenvalues, the shift of shift-and-invert for modes ((rad/s)^2;
  // NaN: chosen automatically) and whether a static equilibrium under the loads at end_time is
  // computed first (the modes or buckling loads about that preloaded state).
  int        eigenvalues = 6;
  double     shift       = std::numeric_limits<double>::quiet_NaN();
  bool       preload     = false;
  SourceMark mark;
};

// The largest step where neither the input nor -analysis_max_step gives one: statics 1; dynamics
// initial_step, since the controller grows a step after easy Newton iterations, which say nothing
// about the time-integration error (a linear oscillator grew to a step of one period with no
// warning), or end_time under step_tolerance, whose error estimate then sets the step.
inline double DefaultMaxStep(const AnalysisSettings &a)
{
  if (a.type != AnalysisType::Dynamic) return 1.0;
  return a.step_tolerance > 0.0 ? std::max(a.end_time, a.initial_step) : a.initial_step;
}

struct OutputSettings {
  std::string file;               // HDF5 output; default: input file name with .h5, in the working directory
  int         every          = 1; // write every n-th converged step (the last step is always written)
  int         progress_every = 1; // a progress line every n-th converged step
  // ... and at most one per so many seconds of wall time (0: no limit); the first and the last
  // step's lines, and those naming a new critical point, are always printed.
  double progress_interval = 1.0;
  // Wall-time seconds between flushes of buffered history rows to the file (0: every step); a
  // killed run loses at most this much (docs/output.md).
  double flush_interval = 10.0;
  // Syntax of the XDMF sidecar (docs/output.md): "xdmf3" (ParaView's default readers) or "xdmf2"
  // (ParaView's "XDMF Reader", VisIt).
  std::string xdmf = "xdmf3";
  // Checkpoints for restarts (docs/options.md): every n converged steps and/or every so many
  // seconds of wall time (0: never); file default: the output file with .ckpt.h5.
  int         checkpoint_every     = 0;
  double      checkpoint_wall_time = 0.0;
  std::string checkpoint_file;
  SourceMark  mark;
};

struct Model {
  std::string                             input_file;
  std::string                             input_text; // copy of the input, stored in the output for provenance
  std::string                             mesh_file;  // the HDF5 mesh file read (`mesh:`, as opened: relative to the input's directory), or empty
  std::vector<TimeFunction>               functions;
  std::vector<Section>                    sections;
  std::vector<Node>                       nodes;
  std::vector<Beam>                       beams;
  std::vector<BeamElement>                elements;
  std::vector<NodeSet>                    node_sets;
  std::vector<Support>                    supports;
  std::vector<NodalLoad>                  nodal_loads;
  std::vector<DistributedLoad>            distributed_loads;
  std::vector<Probe>                      probes;
  std::vector<RigidBody>                  rigid_bodies;
  std::vector<InitialCondition>           initial_conditions;
  std::vector<CoordinateInitialCondition> coordinate_initial_conditions;
  std::vector<Joint>                      joints;
  std::vector<ForceElement>               force_elements;
  std::vector<ExpectedResult>             expected;
  AnalysisSettings                        analysis;
  OutputSettings                          output;
};

// Value at t of the model's function number `function`; -1 is the ramp f(t) = t.
double FunctionValue(const Model &model, int function, double t);
// Its first or second derivative (order 1 or 2) at t, in closed form; where a table or a ramp has a
// kink, the derivative from the right (forward in time, the side of the coming motion), or with
// TimeSide::Before from the left (the end of a step).
double FunctionDerivative(const Model &model, int function, double t, int order, TimeSide side = TimeSide::After);
// Its integral from 0 to t, in closed form.
double FunctionIntegral(const Model &model, int function, double t);
// A driven joint coordinate q(t) (order 0), its rate (1) or acceleration (2): drive_value f(t), or
// with drive_by_rate drive_value times the integral of f from 0 to t.
double DriveCoordinate(const Model &model, const Joint &joint, double t, int order, TimeSide side = TimeSide::After);
// The same for a prescribed DOF's motion per unit value: f(t) and its derivatives, or with
// by_rate the integral of f from 0 and f, f'.
double PrescribedMotion(const Model &model, int function, bool by_rate, double t, int order, TimeSide side = TimeSide::After);

} // namespace msflex
