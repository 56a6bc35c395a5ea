// Assembly of the global residual and tangent from the element, inertia and load kernels into
// PETSc objects (MPIAIJ with exact preallocation). The residual is in spin form (rows: virtual
// displacements and spins; for the mid-point schemes, the tangent-scaled increments); the
// tangent is with respect to the Newton unknowns (u, omega): stiffness blocks are
// K_spin * blockdiag(I, H(omega)) per node (DESIGN.md §3), inertia blocks are differentiated with
// respect to (u, omega) directly.
//
// Three modes: statics (no scheme), dynamics (a TimeScheme per step), and the initial-acceleration
// problem of the Newmark family (unknowns: accelerations at t, residual: equations of motion at t).
#pragma once

#include "dofs/dof_map.hpp"
#include "elements/beam.hpp"
#include "elements/inertia.hpp"
#include "integrators/time_scheme.hpp"
#include "joints/joint_kinematics.hpp"
#include "model/model.hpp"
#include "state/state.hpp"

#include <petscmat.h>
#include <petscvec.h>

#include <string>
#include <vector>

namespace msflex {

// Per-element mean (over the Gauss points) of strains and stress resultants, section frame.
struct ElementResults {
  Vec3 strain, curvature, force, moment;
};

// Kinetic energy, linear momentum and angular momentum about the origin of the whole model.
struct DynamicsDiagnostics {
  double kinetic_energy   = 0.0;
  Vec3   linear_momentum  = Vec3::Zero();
  Vec3   angular_momentum = Vec3::Zero();
};

class Assembler {
public:
  Assembler()                             = default;
  Assembler(const Assembler &)            = delete;
  Assembler &operator=(const Assembler &) = delete;
  ~Assembler();

  // Element reference data, inertia, preallocated matrix, vectors and the ghost scatter. Collective.
  PetscErrorCode Setup(MPI_Comm comm, const Model &model, const DofMap &map);

  // Prepares the step t_start -> t_end: loads and prescribed increments. `scheme` is null in
  // statics; in dynamics its dt must be t_end - t_start.
  PetscErrorCode BeginStep(double t_start, double t_end, const TimeScheme *scheme);
  // Prepares the initial-acceleration problem at time t (Newmark family).
  PetscErrorCode BeginInitialAcceleration(double t);
  // Initial guess of the step's unknowns: zero in statics, constant velocity in dynamics
  // (u = dt v_n, omega = dt Lambda_n W_n).
  PetscErrorCode PredictIncrements(Vec increments);
  // Sets the unknowns of every local node from the global vector (scatter to ghosts).
  PetscErrorCode SetIncrements(Vec increments);
  // Residual at the current unknowns. *geometry_ok = false when an element cannot be evaluated.
  PetscErrorCode AssembleResidual(Vec residual, PetscBool *geometry_ok);
  // Exact tangent in statics, the Newmark family and the initial-acceleration problem; for the
  // mid-point family the stiffness part is approximated by K(q_{n+1})/2 (a preconditioner for
  // the matrix-free operator, see integrators/newton.hpp).
  PetscErrorCode AssembleJacobian(Mat jacobian, PetscBool *geometry_ok);
  // Accepts the current increments as the new start of step (with velocities and accelerations).
  PetscErrorCode CommitStep();
  // Stores the solved initial accelerations as the start-of-step accelerations.
  PetscErrorCode CommitInitialAcceleration();
  // Forgets the increments (a rejected step).
  PetscErrorCode DiscardStep();
  // Initial velocities from the model's initial conditions and prescribed motions at time t.
  PetscErrorCode SetInitialVelocities(double t);

  // Magnitude of the forces in the last residual (see newton.hpp). Collective.
  PetscErrorCode ForceScale(double *scale);
  // Residual level at which the internal forces are lost in round-off: 100 eps times the norm of
  // the sections' stiffness (EA, GA, GJ/L, EI/L per element). Fixed after Setup.
  double RoundoffForceLevel() const { return roundoff_force_level_; }
  // Largest |omega| over the nodes of the whole model (collective).
  PetscErrorCode MaxRotationIncrement(double *max_rotation);
  // Element results for the local elements (indexed like DofMap::local_elements) and the total
  // strain energy (collective).
  PetscErrorCode EvaluateResults(std::vector<ElementResults> *results, double *strain_energy);
  // Kinetic energy and momenta of the start-of-step state (collective).
  PetscErrorCode EvaluateDynamics(DynamicsDiagnostics *diagnostics);
  // Work of the external loads over the current increments: sum of u.F + alpha.M, including the
  // reactions that drive prescribed DOFs (collective).
  PetscErrorCode StepExternalWork(double *work);
  // Joint output, collective. EvaluateJointReactions, called at the converged increments (before
  // CommitStep), keeps each joint's transmitted force and moment — the slave's residual: the
  // force and moment (about the slave node, global axes) that the joint exerts on the slave — and
  // the step's mean rates of the released coordinates. JointHistory then gives, per joint, the
  // released coordinates (tx ty tz along, rx ry rz about the joint axes; a free rotation as the
  // rotation vector of the relative rotation in joint axes; a dependent translation under its
  // axis), their rates, force and moment, as history series "<joint>.<quantity>".
  PetscErrorCode EvaluateJointReactions(double dt);
  PetscErrorCode JointHistory(std::vector<std::string> *names, std::vector<double> *values);
  // Numerical trouble, for messages (collective; implemented in assembler_diagnostics.cpp).
  // DescribeNonFinite: after a residual or tangent holding NaN or Inf at the current increments,
  // names where it first appears (element with its number and nodes, node, rigid body or joint);
  // empty when everything is finite. DescribeUnevaluable: the element that cannot be evaluated at
  // the current increments (a relative rotation of its nodes reaches pi); empty when all can.
  // DescribeUnknown: the node or joint coordinate that global unknown `row` belongs to
  // ("node 'arm.3' rz", "joint 'j1' rx").
  PetscErrorCode DescribeNonFinite(std::string *where);
  PetscErrorCode DescribeUnevaluable(std::string *where);
  PetscErrorCode DescribeUnknown(PetscInt row, std::string *what);
  // The energy-momentum scheme's beta of the last residual (0 otherwise).
  double EnergyCorrectionFactor() const { return energy_correction_; }

  // Checkpoints (assembler_state.cpp). The start-of-step state, in records of fixed size:
  // node: position (3), tracked rotation quaternion w x y z (4), translational velocity,
  // acceleration and pseudo-acceleration (9), the same for the rotation in the body frame (9);
  // joint: released coordinates (6), the free rotation's C_n row-major (9); rigid body: motion of
  // its centre of mass (9). ExportState gives the records of what this rank owns with their
  // numbers in the whole model; StateNumbers the numbers of what it needs (every local node and
  // joint, its own rigid bodies) and ImportState takes their records in that order, after which
  // the state is as it was at the checkpoint (any number of ranks).
  static constexpr int kNodeStateSize = 25, kJointStateSize = 15, kRigidBodyStateSize = 9;
  struct StateRecords {
    std::vector<int>    numbers;
    std::vector<double> values;
  };
  void           ExportState(StateRecords *nodes, StateRecords *joints, StateRecords *bodies) const;
  void           StateNumbers(std::vector<int> *nodes, std::vector<int> *joints, std::vector<int> *bodies) const;
  PetscErrorCode ImportState(const std::vector<double> &nodes, const std::vector<double> &joints, const std::vector<double> &bodies);

  Mat                           Jacobian() const { return jacobian_; }
  Vec                           SolutionTemplate() const { return solution_template_; }
  const std::vector<NodeState> &LocalNodes() const { return nodes_; }
  const DofMap                 &Map() const { return *map_; }

private:
  enum class Mode { Static, Dynamic, InitialAcceleration };
  struct LocalRigidBody {
    int          global_index = -1; // number in the whole model (DofMap::global_rigid_bodies)
    int          local_node   = -1;
    double       mass         = 0.0;
    Vec3         offset       = Vec3::Zero(); // centre of mass, node body frame
    MotionState  centre_of_mass;              // motion of the centre of mass, global axes
    MotionUpdate centre_of_mass_update;
    Vec3         gravity_force = Vec3::Zero(); // m g at the centre of mass, weighted in time for the step
  };

  // A joint whose slave node is local: its geometry and released coordinates.
  struct LocalJoint {
    int              local_index  = -1; // index into DofMap::local_joints (and joints_)
    int              local_slave  = -1;
    int              local_master = -1; // -1: the ground
    JointGeometry    geometry;
    JointCoordinates start; // at the start of the step (a free rotation keeps C_n, q = 0)
    double           increment[kJointMaxReleased] = {0, 0, 0, 0, 0, 0};
    PetscInt         slot[kJointMaxReleased]      = {-1, -1, -1, -1, -1, -1}; // in ghosted_increments_, -1 when driven
    JointMatrix      rows_map;                                                // the map of the residual rows: N, or the conserving map (mid-point)
    double           released_test[kJointMaxReleased] = {0, 0, 0, 0, 0, 0};   // the test quantities of the released coordinates
    // Output of an owned joint (EvaluateJointReactions): force and moment on the slave, mean rates
    // of the released coordinates over the last step.
    Vec6                                  reaction = Vec6::Zero();
    std::array<double, kJointMaxReleased> rate{};
  };
  const Joint &ModelJoint(const LocalJoint &J) const { return model_->joints[map_->local_joints[J.local_index]]; }
  // Slave residuals with what each slave passes on to its master along the chains (deepest first).
  void PropagateSlaveResiduals();

  PetscErrorCode ApplyPrescribedValues(double t_start, double t_end);
  // Slave configurations from their masters and joints (masters first), and their expansions.
  void UpdateSlaves();
  // The expansion of an independent node: its spin variation in its free unknowns (6 x m).
  void IndependentExpansion(int local_node, double *rows, double *columns) const;
  // Expansion of any local node into rows/columns (6 x m, m = DofMap::node_unknowns size).
  void NodeExpansion(int local_node, const double **rows, const double **columns, double *scratch_rows, double *scratch_columns) const;
  // Adds a node's spin residual g (6) through its expansion: R[unknowns] += rows^T g.
  PetscErrorCode AddNodeVector(Vec residual, int local_node, const double *g);
  // Adds a node's 6x6 block (d residual / d(u, omega) of that node) through its expansion.
  PetscErrorCode AddNodeBlock(Mat jacobian, int local_node, const Mat6 &block);
  // Adds an element matrix (spin form, already H-scaled for independent nodes' own columns) of an
  // element touching slave nodes, through the nodes' expansions.
  PetscErrorCode AddExpandedElementMatrix(Mat jacobian, const BeamElement &element, const double *K_spin);
  // Geometric stiffness of every local joint for the slave residuals gathered in slave_residual_.
  PetscErrorCode AddJointGeometricStiffness(Mat jacobian);
  PetscErrorCode ComputeLoads(double t_start, double t_end);
  PetscErrorCode CreateCsrDestinations();
  // The six rigid-body modes in the unknowns (u = t + w x (X - centroid), omega = w at every
  // independent node, zero on joint coordinates), orthonormalised: the near-null space that
  // algebraic multigrid (-pc_type gamg) needs for beams.
  PetscErrorCode AttachRigidBodyModes();
  PetscErrorCode AddElementMatrix(size_t local_element, const PetscInt *indices, int num_dofs, const double *values, PetscScalar *diagonal_values,
                                  PetscScalar *off_diagonal_values);
  PetscErrorCode ElementForces(size_t k, double *force, double *correction, double *work_mismatch, double *correction_work, double *work_scale, PetscBool *ok);
  void           NodalForces(PetscInt l, double *force, Mat6 *tangent);
  PetscErrorCode RigidBodyForces(LocalRigidBody *body, Vec6 *force, Mat6 *tangent);
  void           UpdateDerivedState(NodeState *state) const;
  double         FunctionValue(int function, double t) const;
  double         FunctionDerivative(int function, double t, int order) const;
  // Current nodal positions and section triads of an element (and the nodes' H(omega) if asked).
  void ElementConfiguration(const BeamElement &element, Vec3 *positions, Mat3 *triads, const Mat3 **rotation_tangents) const;
  void ElementStartConfiguration(const BeamElement &element, Vec3 *positions, Mat3 *triads) const;

  MPI_Comm                          comm_  = MPI_COMM_NULL;
  const Model                      *model_ = nullptr;
  const DofMap                     *map_   = nullptr;
  Mode                              mode_  = Mode::Static;
  TimeScheme                        scheme_;
  std::vector<BeamElementReference> element_references_; // per local element
  std::vector<BeamSectionStiffness> section_stiffness_;  // per section
  std::vector<NodeState>            nodes_;              // per local node
  std::vector<Mat3>                 node_inertia_;       // per owned node: body-frame rotary inertia (beams lumped + rigid bodies)
  std::vector<LocalRigidBody>       rigid_bodies_;       // rigid bodies on owned nodes
  std::vector<LocalJoint>           joints_;             // like DofMap::local_joints
  std::vector<int>                  node_local_joint_;   // per local node: index into joints_ if it is a slave, else -1
  // Per local slave node: rows and columns of its expansion (6 x m, row-major), m = number of
  // unknowns it depends on: R[unknowns] += rows^T g_spin, d(spin)/dX = columns.
  std::vector<std::vector<double>> expansion_rows_, expansion_columns_;
  std::vector<Vec6>                slave_residual_;         // per local node: spin residual gathered on slaves
  Vec                              joint_output_ = nullptr; // 12 per joint slot (DofMap::joint_slot): reaction (6), rates (6)
  std::vector<std::string>         joint_history_names_;    // rank 0: the joint series of the history, gathered once
  bool                             joint_history_named_ = false;
  std::vector<double>              expansion_scratch_;        // work space for expanded blocks
  std::vector<double>              joint_geometric_scratch_;  // work space of AddJointGeometricStiffness
  std::vector<PetscInt>            expanded_indices_scratch_; // work space: an expanded element's unknowns
  // Per local node: whether its translations / rotations carry mass. In the initial-acceleration
  // problem a massless group gets zero acceleration instead of a singular equation.
  std::vector<char> has_translational_mass_, has_rotary_inertia_;

  // External loads of the step: per local element the distributed load per length, per owned
  // node the dead force and moment (already weighted in time) and the follower loads in the body
  // frame at the start and end of the step with their weights (statics and the Newmark family:
  // end values only; mid-point family: the mean of both ends).
  double              load_weight_start_ = 0.0, load_weight_end_ = 1.0;
  std::vector<Vec3>   element_line_load_;
  std::vector<Vec3>   dead_force_, dead_moment_;
  std::vector<Vec3>   follower_force_start_, follower_moment_start_, follower_force_end_, follower_moment_end_;
  double              local_force_squares_  = 0.0; // sum of squared contributions in the last residual
  double              energy_correction_    = 0.0; // em's beta in the last residual
  double              roundoff_force_level_ = 0.0;
  double              prescribed_work_      = 0.0;                         // work of the reactions on prescribed DOFs in the last residual (local)
  std::vector<double> element_force_scratch_, element_correction_scratch_; // per local element, kBeamMaxDofs each

  Mat                   jacobian_           = nullptr;
  Vec                   solution_template_  = nullptr;
  Vec                   ghosted_increments_ = nullptr; // sequential: the free DOFs of the local nodes
  Vec                   scratch_residual_   = nullptr; // for residual evaluations outside Newton
  VecScatter            to_ghosted_         = nullptr;
  std::vector<PetscInt> ghosted_slot_; // per local node and DOF: index in ghosted_increments_, -1 if constrained

  // Direct assembly into the CSR value arrays of the owned rows (the pattern is fixed by exact
  // preallocation, so the position of every element-matrix entry is computed once). Per local
  // element, per entry (row-major): kCsrSkip (constrained row or column), kCsrOtherRank (row
  // owned by another rank: goes through MatSetValues), an index >= 0 into the diagonal block's
  // values, or kCsrOffDiagonal - index for the off-diagonal block. Empty when the matrix type
  // is not AIJ: then everything goes through MatSetValues.
  static constexpr PetscInt kCsrSkip = -1, kCsrOtherRank = -2, kCsrOffDiagonal = -3;
  std::vector<PetscInt>     csr_destinations_;
  std::vector<size_t>       csr_destination_offsets_;                                 // per local element + 1: where its entries start
  Mat                       diagonal_block_ = nullptr, off_diagonal_block_ = nullptr; // borrowed from jacobian_
};

} // namespace msflex
