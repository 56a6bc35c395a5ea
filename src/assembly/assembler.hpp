// Assembly: a thin loop over the force contributors (contributors/contributor.hpp) plus the
// master–slave condensation and the insertion into PETSc objects (MPIAIJ with exact
// preallocation).
//
// The residual rows are the contributors' test quantities condensed through the joints
// (R[unknowns] += rows^T g, rows = N or the conserving map); the tangent is with respect to the
// Newton unknowns: a contributor's spin-form columns are mapped to an independent node's
// (u, omega) by blockdiag(I, H(omega)) and to a slave's master and released coordinates through
// the joints (Muñoz, Jelenić & Crisfield 2003 eq. 5-8), plus the joints' geometric
// stiffness d(N^T g)/d(x_m, theta_m, q) (condensation.cpp). One element loop serves every path:
// an element without slave nodes goes straight into the CSR values of the owned rows, one with
// slave nodes through the nodes' expansions.
//
// The assembler reads and writes the State's increments (the unknowns scattered to every local
// node, ghosts included); the integrator owns the State.
#pragma once

#include "assembly/tangent_structure.hpp"
#include "contributors/contributor.hpp"
#include "dofs/dof_map.hpp"
#include "model/model.hpp"
#include "state/state.hpp"

#include <petscmat.h>
#include <petscvec.h>

#include <algorithm>
#include <string>
#include <vector>

namespace msflex {

class BeamContributor;
class InertiaContributor;

// What the projection of the initial velocities did (Assembler::ProjectInitialVelocities).
struct InitialVelocityReport {
  PetscInt held               = 0;                            // unknowns held at their given velocities (nodes' initial conditions, coordinates' rates)
  PetscInt chosen             = 0;                            // unknowns chosen for the least strain rate
  PetscInt at_rest            = 0;                            // unknowns that nothing determines, left at rest
  double   strain_rate_before = 0.0, strain_rate_after = 0.0; // V^T K V of the beams, before and after (W)
  double   slave_change = 0.0;                                // largest change of a slave's given velocity (m/s or rad/s)
  PetscInt iterations   = 0;                                  // of the conjugate gradients
  bool     solved       = false;                              // false: nothing moves, so no solve was needed
};

class Assembler : public BlockSink {
public:
  Assembler()                             = default;
  Assembler(const Assembler &)            = delete;
  Assembler &operator=(const Assembler &) = delete;
  ~Assembler() override;

  // The matrix with the given pattern, vectors, the ghost scatter and the CSR destinations of the
  // local elements. `contributors` are evaluated in this order; `beams` and `inertia` are among
  // them (the beams for diagnostics, the inertia for the massless groups). Collective.
  PetscErrorCode Setup(MPI_Comm comm, const Model &model, const DofMap &map, MatrixPattern pattern, std::vector<ForceContributor *> contributors,
                       const BeamContributor *beams, const InertiaContributor *inertia, State *state);

  // Prepares the step whose equations are given: prescribed values, drives, loads.
  PetscErrorCode BeginStep(const StepEquations &equations);
  // Drops the step's increments (StateDiscardStep): the State is back at the start of the step,
  // and what the last residual kept no longer describes it (ForgetIncrements).
  void DiscardStep();
  // Initial guess of the step's unknowns: zero in statics and for initial accelerations, constant
  // velocity in dynamics (u = dt v_n, omega = dt Lambda_n W_n, a released coordinate q = dt q_n').
  PetscErrorCode PredictIncrements(Vec increments);
  // Sets the unknowns of every local node from the global vector (scatter to ghosts); slaves follow.
  // `keep_if_current`: when the values equal those of the last call and the State has not changed
  // otherwise since (ForgetIncrements), the State already holds them and is left as it is (Newton's
  // tangent at the iterate whose residual was just evaluated).
  PetscErrorCode SetIncrements(Vec increments, bool keep_if_current = false);
  // Residual at the current unknowns. *geometry_ok = false when an element cannot be evaluated.
  // `tangent_may_follow`: a tangent at the same unknowns may be asked for next, so em's beam
  // elements keep what their tangent needs of this evaluation (BeamContributor); false where
  // nothing will follow (Newton's residual alone when the solve assembles tangents with residuals).
  PetscErrorCode AssembleResidual(Vec residual, PetscBool *geometry_ok, bool tangent_may_follow = true);
  // Exact tangent at the current unknowns, in every problem and scheme. In the energy-momentum
  // scheme the residual R = R_mc + beta(X) R_corr has the tangent K_mc + beta K_corr (assembled)
  // plus the rank-one term R_corr (grad beta)^T, which couples every element (beta of eq. 20 is a
  // global ratio); RankOneTerm gives its two vectors (the Newton solve applies them by
  // Sherman-Morrison, integrators/newton.cpp).
  PetscErrorCode AssembleJacobian(Mat jacobian, PetscBool *geometry_ok);
  // The residual and the tangent (into the assembler's own matrix) at the current unknowns in one
  // pass: each kernel evaluated once for both, the residual equal to AssembleResidual's. Newton
  // assembles the next tangent with the residual of its line search this way (integrators/newton.cpp),
  // so an iteration costs one pass instead of a residual pass and a tangent pass. In em, whose
  // tangent needs beta of the whole residual first, the elements are visited twice (their forces
  // and beta's sums, keeping each kernel's iterate; then the tangent with beta known), but nodes,
  // free blocks and the residual's assembly once. Not in the initial-acceleration problem.
  bool           CanAssembleResidualWithJacobian() const;
  PetscErrorCode AssembleResidualWithJacobian(Vec residual, PetscBool *geometry_ok);
  // Whether the matrix holds the tangent at the current unknowns from AssembleResidualWithJacobian
  // (the unknowns unchanged and no other matrix assembled since).
  bool JacobianCurrent() const { return tangent_version_ == increments_version_ && tangent_assembly_ == matrix_assemblies_; }
  // The rank-one term a b^T of the last tangent: a = R_corr, b = grad beta in the unknowns;
  // *active = false when there is none (not em, or beta = 0 at round-off).
  void RankOneTerm(Vec *a, Vec *b, bool *active) const
  {
    *a      = rank_one_left_;
    *b      = rank_one_right_;
    *active = rank_one_active_;
  }
  // The condensed mass matrix (eigenanalysis): the tangent of the initial-acceleration problem
  // (the step's equations must be it) without its "acceleration = 0" rows of massless groups, so
  // that a massless DOF keeps a zero row. Into the assembler's own matrix, as AssembleJacobian.
  PetscErrorCode AssembleMassMatrix(Mat mass, PetscBool *geometry_ok);

  // Magnitude of the forces in the last residual (see newton.hpp). Collective.
  PetscErrorCode ForceScale(double *scale);
  // Residual level at which the forces are lost in round-off: 100 eps times the norm of the
  // sections' stiffness (EA, GA, GJ/L, EI/L per element), fixed after Setup, and in dynamics 100
  // eps times the momenta over dt at the start of the step (BeginStep): an inertial residual is a
  // difference of momenta over dt, which a predictor that moves every node and joint coordinate at
  // its rate can leave at round-off of them (a body spinning freely about its axis).
  double RoundoffForceLevel() const { return std::max({roundoff_force_level_, inertial_roundoff_level_, damping_roundoff_level_}); }
  // Dynamics: a residual that no longer falls and is below this level is at the noise of the
  // inertia terms' rounding (a body at rest or at a turning point with a small step, where the
  // momenta give no floor), and Newton has converged (ForceScaledConvergenceTest). 0 in statics.
  double StagnationLevel() const { return std::max(stagnation_level_, RoundoffForceLevel()); }
  // Largest |omega| over the nodes of the whole model. Collective.
  PetscErrorCode MaxRotationIncrement(double *max_rotation);
  // Work of the external loads over the current increments, plus that of the reactions that drive
  // prescribed DOFs and driven joint coordinates, with the quadrature of the scheme's energy
  // balance: the mid-point family takes the step's (mid-point) reactions times (u, alpha), the
  // Newmark family the trapezoidal rule, the mean of the reactions at both ends of the step times
  // (u, omega), and keeps the end's reactions in the State for the next step. Collective.
  PetscErrorCode StepExternalWork(double *work);
  // Keeps the reactions on prescribed DOFs and drives of the current residual in the State, as
  // the start of the next step's trapezoidal work (after the initial accelerations). Collective.
  PetscErrorCode StoreReactions();
  // Called at the converged increments (before the step is committed): each local joint's
  // transmitted force and moment (the slave's residual: what the joint exerts on the slave, about
  // the slave node, global axes) and the step's mean rates of its released coordinates, into the
  // State's joints. With dt = 0 (the initial accelerations) the coordinates' own rates; with
  // `keep_rates` (the consistent reactions after a step) the rates as they are. Collective.
  PetscErrorCode EvaluateJointReactions(double dt, bool keep_rates = false);
  // The energy-momentum scheme's beta of the last residual (0 otherwise).
  double EnergyCorrectionFactor() const { return energy_correction_; }
  // This rank's strain energy of the beams at the unknowns of the last residual (each element's
  // Pi in the configuration the residual evaluated, Pi_{n+1} in the mid-point schemes), when the
  // State still holds those unknowns: no SetIncrements with other values and no ForgetIncrements
  // since, and every element was evaluable. Saves the history a pass over the elements per step.
  bool LastResidualStrainEnergy(double *local_energy) const
  {
    if (residual_strain_energy_version_ != increments_version_) return false;
    *local_energy = residual_strain_energy_;
    return true;
  }
  // The State changed other than through SetIncrements (a new step, the velocity projection, a
  // discarded step, a state read from a checkpoint): the next SetIncrements starts a new version of
  // the unknowns whatever its values, and what the last residual kept no longer describes the State.
  void ForgetIncrements()
  {
    increments_known_ = false;
    ++increments_version_;
  }

  // Numerical trouble, for messages (collective; diagnostics.cpp). DescribeNonFinite: after a
  // residual or tangent holding NaN or Inf at the current increments, names where it first appears
  // (element with its number and nodes, node, rigid body or joint); empty when everything is
  // finite. DescribeUnevaluable: the element that cannot be evaluated at the current increments (a
  // relative rotation of its nodes reaches pi); empty when all can. DescribeUnknown: the node or
  // joint coordinate that global unknown `row` belongs to ("node 'arm.3' rz", "joint 'j1' rx").
  PetscErrorCode DescribeNonFinite(std::string *where);
  PetscErrorCode DescribeUnevaluable(std::string *where);
  PetscErrorCode DescribeUnknown(PetscInt row, std::string *what);

  Mat Jacobian() const { return jacobian_; }
  // Whether the tangent is banded under RCM (one rank, mean squared envelope up to
  // kBandedEnvelope^2: tangent_structure.hpp), which picks a banded LU (ChooseDirectSolver, core/block_envelope_pc.hpp).
  bool BandedUnderRcm() const { return banded_under_rcm_; }
  // Zeroes the relay nodes' own and force entries of an owned vector (a Newton step: they are not
  // increments of the state, and its norms are those of the condensed unknowns).
  PetscErrorCode ZeroRelayEntries(Vec v) const;
  // Copies the relay nodes' own and force entries of `from` into `to` (owned).
  PetscErrorCode CopyRelayEntries(Vec from, Vec to) const;
  // How many matrices AssembleJacobian has assembled (the tangent, or through AssembleMassMatrix
  // the mass matrix, all into jacobian_): modified Newton keeps a factorisation only while no
  // other matrix was assembled since.
  long long            MatrixAssemblies() const { return matrix_assemblies_; }
  Vec                  SolutionTemplate() const { return solution_template_; }
  const DofMap        &Map() const { return *map_; }
  const State         &CurrentState() const { return *state_; }
  const StepEquations &Equations() const { return state_->equations; }

  // BlockSink: a free block of a contributor (rigid bodies, force elements).
  void Add(const NodeBlock &block, const double *residual, const double *tangent) override;
  // BlockSink: a generalised force on a joint's released coordinate (force elements).
  void AddCoordinate(int joint, int coordinate, double residual, double tangent) override;

  // The initial velocities of a dynamic analysis at time t (docs/input.md, "initial_conditions"),
  // into the State's motion: every node with an initial condition keeps it (a slave as closely as
  // its joint allows, in the least-squares sense), drives and prescribed supports impose their
  // rates, joint coordinates with an initial rate keep it, and every other velocity is chosen so
  // that the beams start with the least strain rate, min V^T K V with K = sum B^T C B (the
  // sections' material stiffness): what a beam attached to a driven joint does is then a rigid
  // motion with it, and a closed loop's coordinates move consistently. Motions that nothing
  // determines (no strain resists them, nothing given moves them) stay at rest: the minimum-norm
  // correction of the given velocities, by conjugate gradients preconditioned with the LU of
  // K + 1e-8 max(diag K) I (options prefix -velocity_projection_). Collective.
  PetscErrorCode ProjectInitialVelocities(double t, InitialVelocityReport *report);

  // Energy dissipated by the dampers over the current increments (collective).
  PetscErrorCode StepDissipation(double *dissipation);
  // Called at the converged increments: the reaction of the supports at each node of a reaction
  // probe (the node's residual on its fixed and prescribed DOFs, zero on its free ones; global
  // axes), per model probe (zero for the other probes), into State::probe_reactions. Collective.
  PetscErrorCode EvaluateSupportReactions();
  // The unknowns of the initial-acceleration problem that no mass reaches (a zero row of the mass
  // matrix: a massless rotation of a joint's node, a released coordinate that moves nothing with
  // mass, a point mass's node without rotary inertia): their equation becomes acceleration = 0.
  // Found when the initial-acceleration problem begins; the number found in the whole model.
  PetscInt NumMasslessUnknowns() const { return num_massless_unknowns_; }
  // The forces on the unknowns without mass (zero rows, groups without mass) at zero acceleration,
  // relative to all the forces of that residual: 0 where the part of the model without mass is in
  // equilibrium. Within the initial-acceleration problem; it sets the increments to zero. Collective.
  PetscErrorCode MasslessImbalance(double *ratio);

private:
  // AssembleJacobian (residual null) and AssembleResidualWithJacobian.
  PetscErrorCode AssembleTangentPass(Mat jacobian, Vec residual, PetscBool *geometry_ok);
  // A residual's assembly, in AssembleResidual and AssembleTangentPass alike: StartResidual zeroes
  // the vector and what the residual leaves besides it (the reactions on prescribed DOFs, the
  // relays' gathered forces, the force elements' terms on coordinates, the force level);
  // AddContributorBlocks adds the contributors' free blocks to the residual and/or the tangent
  // (either may be null); FinishResidual passes the relays' forces up, assembles the vector and
  // keeps the beams' strain energy of these unknowns (LastResidualStrainEnergy).
  PetscErrorCode StartResidual(Vec residual);
  PetscErrorCode AddContributorBlocks(Vec residual, Mat jacobian);
  PetscErrorCode FinishResidual(Vec residual, double strain_energy, PetscBool geometry_ok);
  // The element loop's evaluation of local element k by every element contributor.
  // `combined_beta` (em with beta known): the elements' tangents are K_mc + beta K_corr.
  // keep_iterate: the contribution carries the unknowns' version (ElementContribution::iterate_key),
  // so that em's beam kernels may keep or reuse what a residual evaluation computed.
  // beams_only: the beam contributor alone (em's sums of beta, to which no other contributor adds).
  void EvaluateElement(size_t k, bool want_tangent, ElementContribution *out, const double *combined_beta = nullptr, bool keep_iterate = true,
                       bool beams_only = false);
  // em: beta of eq. (20) at the current unknowns from one visit of every element, which keeps each
  // beam kernel's iterate for the tangent pass that follows; *all_ok = false (alike on every rank)
  // when an element cannot be evaluated somewhere. Collective.
  PetscErrorCode EnergyCorrectionOfElements(PetscBool *all_ok);
  // em: beta, its denominator and the version they belong to, from the global sums of the
  // elements' work mismatch, correction work and internal-work scale (BetaOfWorkSums).
  void AdoptEnergyCorrection(const double global_sums[3]);
  // The node loop's evaluation of owned node l by every node contributor.
  void EvaluateNode(int l, bool want_tangent, NodeContribution *out);
  // Per local node, whether it is a slave (its expansion goes through its joint).
  bool IsSlave(int l) const { return state_->node_joint[l] >= 0; }
  // With node blocks (the tangent is BAIJ of block size 6, and every matrix assembled is it or a
  // duplicate): the block indices of `n` nodes' unknowns `indices` (6 each; -1 for a node without
  // unknowns, which MatSetValuesBlocked skips) when they are whole aligned blocks; else false
  // (entry by entry).
  bool NodeBlockIndices(int n, const PetscInt *indices, PetscInt *block_indices) const;
  // Per local node, whether it is condensed: a slave that is not a relay node (DofMap). A relay
  // expands like an independent node onto its own DOFs (spins, no H); its joint's expansion
  // (onto DofMap::relay_unknowns) is kept in expansion_rows_/expansion_columns_ for the coupling.
  bool IsCondensed(int l) const { return IsSlave(l) && !map_->IsRelay(l); }

  // Condensation (condensation.cpp). Expansions of the slave nodes from their joints' maps
  // (masters first), after every change of the increments.
  void UpdateExpansions();
  // The expansion of an independent node: its spin variation in its free unknowns (6 x m).
  void IndependentExpansion(int local_node, double *rows, double *columns) const;
  // Expansion of any local node into rows/columns (6 x m, m = DofMap::node_unknowns size).
  void NodeExpansion(int local_node, const double **rows, const double **columns, double *scratch_rows, double *scratch_columns) const;
  // Adds a node's residual g (6) through its expansion: R[unknowns] += rows^T g; records the
  // force level, the work of prescribed DOFs and the slaves' residuals.
  PetscErrorCode AddNodeResidual(Vec residual, int local_node, const double *g);
  // Adds a node's 6x6 spin-form block through its expansion.
  PetscErrorCode AddNodeBlock(Mat jacobian, int local_node, const Mat6 &block);
  // A node's spin-form block with its spin columns taken to the node's own unknowns (a node that
  // is not condensed).
  Mat6 NodeBlockInUnknowns(int local_node, const Mat6 &block) const;
  // AddNodeBlock into the owned CSR values of the tangent (node_csr_destinations_), else through it.
  PetscErrorCode AddDirectNodeBlock(Mat jacobian, int local_node, const Mat6 &block, PetscScalar *diagonal_values);
  // Adds a node's spin-form 6-vector to v through its expansion's rows (R[unknowns] += rows^T g)
  // or columns (the gradient of a scalar: b[unknowns] += columns^T g).
  enum class Through { Rows, Columns };
  PetscErrorCode AddNodeVector(Vec v, int local_node, const double *g, Through through);
  // Adds a matrix (spin form, 6n x 6n) coupling local nodes, some of them slaves, through the
  // nodes' expansions.
  PetscErrorCode AddExpandedMatrix(Mat jacobian, int num_nodes, const int *local_nodes, const double *K_spin);
  // Adds an element matrix (spin form) of an element without slave nodes straight into the CSR
  // values: columns mapped by blockdiag(I, H(omega)) per node (identity for accelerations).
  PetscErrorCode AddDirectElementMatrix(Mat target, size_t k, double *K_spin, PetscScalar *diagonal_values, PetscScalar *off_diagonal_values);
  // em's exact tangent: the rank-one term's vectors and, `with_matrix`, the correction's own matrix
  // (same pattern as the tangent), each made once when first needed.
  PetscErrorCode SetupEnergyCorrectionTangent(bool with_matrix);
  // Geometric stiffness of every local joint for the slave residuals gathered in slave_residual_.
  PetscErrorCode AddJointGeometricStiffness(Mat jacobian);
  // Slave residuals with what each slave passes on to its master along the chains (deepest first).
  void PropagateSlaveResiduals();
  // The generalised reaction on local joint j's driven coordinate (0 for a joint without a drive):
  // its slave's residual mapped on the coordinate plus what the force elements added on the
  // coordinate's row, this rank's share of the current residual's by-products.
  double DriveReaction(size_t j) const;
  // What a residual at the current unknowns leaves besides the vector: the reactions on prescribed
  // DOFs (prescribed_residual_), the force elements' terms on coordinates (coordinate_residual_) and
  // the slave residuals propagated along the chains. Newton's last residual left them at the
  // converged unknowns as a rule; otherwise a residual pass makes them. Collective.
  PetscErrorCode CurrentResidualByProducts();
  // Relay nodes. The residual: the force gathered on each relay (relay_force_) passes through its
  // joint's rows to its anchor's unknowns, deepest relays first, so that the residual is the
  // condensed one and zero on the relays' own rows. The matrix: per owned relay s, with U its
  // relay_unknowns, R and C its joint's rows and columns and lambda its force unknowns,
  //   [s, lambda] = -I,  [lambda, s] = -I,  [lambda, U] = C,  [U, lambda] = R^T,
  // i.e. (K du)_s = lambda, du_s = C du_U and lambda's share R^T lambda on U: eliminating du_s and
  // lambda gives the condensed tangent (symmetric where R = C).
  PetscErrorCode FinishRelayForces(Vec residual);
  // Removes from `empty_rows` (owned, of a matrix without the relay coupling) the rows reached
  // through relay nodes and the relays' own rows (the velocity projection's rows left at rest).
  PetscErrorCode DropRelayReachedRows(std::vector<PetscInt> *empty_rows) const;
  PetscErrorCode AddRelayCoupling(Mat matrix);
  // Adds `values` (over node_unknowns of a node whose anchor may be a relay) to v: the anchor
  // relay's share (the first 6) into its gathered force, the rest into v.
  PetscErrorCode AddThroughAnchor(Vec v, int anchor, PetscInt m, const PetscInt *unknowns, const double *values);
  PetscErrorCode CreateCsrDestinations();
  // The zero rows of the initial-acceleration problem's mass matrix (NumMasslessUnknowns).
  PetscErrorCode FindMasslessUnknowns();
  // The owned global rows of the assembled tangent whose largest entry is below 1e-14 of the
  // tangent's largest: unknowns that no term reaches.
  PetscErrorCode EmptyRowsOfJacobian(std::vector<PetscInt> *rows) const;
  // Replaces the massless rows of the initial-acceleration problem by acceleration = 0.
  PetscErrorCode SetMasslessResidualRows(Vec residual);
  // The six rigid-body modes in the unknowns (u = t + w x (X - centroid), omega = w at every
  // independent node, zero on joint coordinates), orthonormalised: the near-null space that
  // algebraic multigrid (-pc_type gamg) needs for beams.
  PetscErrorCode AttachRigidBodyModes();

  MPI_Comm                        comm_  = MPI_COMM_NULL;
  const Model                    *model_ = nullptr;
  const DofMap                   *map_   = nullptr;
  State                          *state_ = nullptr;
  std::vector<ForceContributor *> contributors_, element_contributors_, node_contributors_;
  const BeamContributor          *beams_   = nullptr;
  const InertiaContributor       *inertia_ = nullptr;

  // Joints: per local joint, the slot of each released coordinate in ghosted_increments_ (-1 when driven).
  std::vector<std::array<PetscInt, kJointMaxReleased>> joint_slots_;
  // Per local slave node: rows and columns of its expansion (6 x m, row-major), m = number of
  // unknowns it depends on: R[unknowns] += rows^T g_spin, d(spin)/dX = columns.
  std::vector<std::vector<double>> expansion_rows_, expansion_columns_;
  std::vector<Vec6>                slave_residual_;              // per local node: spin residual gathered on slaves
  std::vector<Vec6>                relay_force_;                 // per local node: force gathered on a relay (residual pass)
  std::vector<int>                 relay_anchor_;                // per local node: the relay its expansion ends on, or -1
  std::vector<int>                 relay_joints_;                // local joints whose slave is a relay, masters first
  std::vector<PetscInt>            relay_rows_;                  // DofMap::OwnedRelayRows, as offsets into the owned rows
  bool                             skip_relay_coupling_ = false; // FindMasslessUnknowns: the mass matrix alone
  bool                             node_blocks_         = false; // the tangent is BAIJ with blocks of 6 (Setup)
  bool                             banded_under_rcm_    = false; // BandedUnderRcm (Setup)
  std::vector<Vec6>                slave_correction_residual_;   // per local node: em's correction vector gathered on slaves
  Vec                              joint_output_ = nullptr;      // 12 per joint slot (DofMap::joint_slot): reaction (6), rates (6)
  std::vector<double>              expansion_scratch_;           // work space for expanded blocks
  std::vector<double>              expansion_product_scratch_;   // a block times a column map, 6 x unknowns
  std::vector<double>              joint_geometric_scratch_;     // work space of AddJointGeometricStiffness
  std::vector<PetscInt>            expanded_indices_scratch_;    // work space: an expanded element's unknowns
  // Per local element: the residual and em's correction vector of the residual's first pass.
  std::vector<double> element_force_scratch_, element_correction_scratch_;
  std::vector<char>   element_has_slave_; // per local element
  // Where the free blocks of the contributors go (BlockSink::Add): the residual being assembled or
  // the tangent being assembled (one is null), and whether every block could be evaluated.
  Vec  block_residual_ = nullptr;
  Mat  block_jacobian_ = nullptr;
  bool block_trouble_  = false;

  // Force elements on released coordinates: per local joint, what they added to each coordinate's
  // row in the last residual (a driven coordinate's goes into the drive's work).
  std::vector<std::array<double, kJointMaxReleased>> coordinate_residual_;
  // Initial-acceleration problem: the owned rows without mass, and the unknowns of the last SetIncrements.
  std::vector<PetscInt> massless_rows_;
  PetscInt              num_massless_unknowns_ = 0;
  Vec                   last_increments_       = nullptr;
  // Reaction probes: per local node, its probe's slot (-1: none), and the sums being collected.
  std::vector<int>  reaction_slot_;
  std::vector<Vec6> reaction_sums_;
  // Per local node: a slave whose chain of masters holds a reaction probe or a prescribed DOF, to
  // which AddNodeResidual passes its residual (N_m^T g along the chain).
  std::vector<char> passes_to_master_;
  bool              collect_reactions_ = false;

  double roundoff_force_level_            = 0.0;
  double global_inertia_roundoff_squares_ = 0.0; // InertiaContributor::LocalInertiaRoundoffSquares, summed
  double stagnation_level_                = 0.0;
  double joint_lever_arm_                 = 0.0; // the model's reach when it has joints (BeginStep's stagnation level), else 0
  // The floors' parts that scale with the reach R (the largest |coordinate| of a node): rounding of
  // positions, eps R, in the strains and the inertia. Set up with the reference's reach; a model
  // that travels far (a slider 1 km along its prismatic joint) raises them at BeginStep: Newton
  // was asked for residuals below the rounding of coordinates there, and stalled.
  double            stiffness_roundoff_squares_ = 0.0, position_roundoff_squares_per_reach_ = 0.0; // global sums, the latter at R = 1
  double            inertia_roundoff_squares_per_reach_ = 0.0, inertia_roundoff_squares_fixed_ = 0.0;
  double            setup_reach_ = 0.0, reach_ = 0.0;
  bool              has_joints_ = false;
  void              SetRoundoffReach(double reach);
  double            inertial_roundoff_level_ = 0.0;  // of the step (BeginStep; 0 outside dynamics)
  double            damping_roundoff_level_  = 0.0;  // of the step: viscous forces on rounded strain rates (BeginStep)
  double            global_damping_squares_  = 0.0;  // sum of LocalDampingRoundoffSquares over the ranks
  double            local_force_squares_     = 0.0;  // sum of squares of every node vector added in the last residual
  std::vector<Vec6> prescribed_residual_;            // per local node: the last residual's entries on prescribed DOFs (the reactions this rank assembled)
  bool              mass_matrix_only_       = false; // AssembleMassMatrix: no equations for massless groups
  double            energy_correction_      = 0.0;   // em's beta of the last residual
  double            energy_correction_work_ = 0.0;   // em: the correction's work (beta's denominator) of the last residual
  // Versions of the unknowns: increments_version_ grows whenever SetIncrements sets values other
  // than the last ones (set_increments_) or the State changes otherwise; energy_correction_version_
  // is the version at which the last residual computed beta.
  long long increments_version_ = 0, energy_correction_version_ = -1, residual_strain_energy_version_ = -1;
  double    residual_strain_energy_ = 0.0; // this rank's, at residual_strain_energy_version_
  long long matrix_assemblies_      = 0;
  // The version of the unknowns whose tangent AssembleResidualWithJacobian left in jacobian_, and
  // matrix_assemblies_ after it (JacobianCurrent).
  long long tangent_version_ = -1, tangent_assembly_ = -1;
  // The version whose residual by-products (CurrentResidualByProducts) the last pass left, and
  // whether slave_residual_ is propagated along the chains already.
  long long by_products_version_    = -1;
  bool      by_products_propagated_ = false;
  bool      increments_known_       = false;
  Vec       set_increments_         = nullptr;

  Mat                   jacobian_            = nullptr;
  Mat                   correction_jacobian_ = nullptr; // em: K_corr, the pattern of jacobian_
  Vec                   rank_one_left_ = nullptr, rank_one_right_ = nullptr, beta_gradient_correction_ = nullptr;
  bool                  rank_one_active_    = false;
  Vec                   solution_template_  = nullptr;
  Vec                   ghosted_increments_ = nullptr; // sequential: the free DOFs of the local nodes
  Vec                   scratch_residual_   = nullptr; // for residual evaluations outside Newton
  VecScatter            to_ghosted_         = nullptr;
  std::vector<PetscInt> ghosted_slot_; // per local node and DOF: index in ghosted_increments_, -1 if constrained

  // Direct assembly into the CSR value arrays of the owned rows (the pattern is fixed by exact
  // preallocation, so the position of every element-matrix entry is computed once). Per local
  // element, per entry (AIJ) or per node block (BAIJ with node blocks), row-major: kCsrSkip
  // (constrained row or column), kCsrOtherRank (row owned by another rank: goes through
  // MatSetValues), an index >= 0 into the diagonal block's values (a BAIJ block's first entry), or
  // kCsrOffDiagonal - index for the off-diagonal block. Empty for other matrix types: then
  // everything goes through MatSetValues.
  static constexpr PetscInt kCsrSkip = -1, kCsrOtherRank = -2, kCsrOffDiagonal = -3;
  std::vector<PetscInt>     csr_destinations_;
  std::vector<size_t>       csr_destination_offsets_; // per local element + 1: where its entries start
  // The same for the 6x6 block of each owned node that is not condensed (36 entries per node,
  // row-major, or 1 block, all in the diagonal block); a node whose first entry is kCsrOtherRank goes through
  // AddNodeBlock. Empty with csr_destinations_.
  std::vector<PetscInt> node_csr_destinations_;
  size_t                NodeDestinationCount() const { return node_blocks_ ? 1 : 36; } // per node in node_csr_destinations_
  // block (6x6 of BAIJ, stored column by column) += the 6x6 whose rows start row_stride apart at rows.
  static void AddToStoredBlock(const double *rows, int row_stride, double *block);
  Mat         diagonal_block_ = nullptr, off_diagonal_block_ = nullptr; // borrowed from jacobian_
};

} // namespace msflex
