// Force contributors: every force that acts in msflex (beam elements, inertia, loads, rigid
// bodies, and force elements as they come) sits behind this one interface. A contributor reads the
// State and the step's equations (schemes/step_equations.hpp) and supplies its residual, its
// tangent, its energy and work, and its mid-point (conserving) form through the scheme's
// coefficients; it knows nothing of joints, PETSc matrices or other ranks. The assembler
// (assembly/assembler.hpp) loops over the contributors, condenses slave nodes and inserts into
// PETSc objects.
//
// Conventions of every contribution:
//  - residual: 6 per node, force then moment (spatial); internal and inertial forces enter with a
//    plus sign, external loads with a minus sign; rows are the scheme's test quantities (virtual
//    displacements and spins, or (u, alpha) in the mid-point family);
//  - tangent: row-major, columns = the nodes' end-of-step variations in spin form (delta x,
//    delta theta with delta Lambda = hat(delta theta) Lambda); the assembler maps them to the
//    unknowns (delta theta = H(omega) delta omega, and through the joints for slaves). In the
//    initial-acceleration problem the columns are the nodes' accelerations.
//
// Three topologies: per beam element (the assembler's one element loop, contributions summed into
// one element block), per owned node (summed into one nodal block), and free blocks of any nodes
// (rigid bodies, force elements), each inserted as it comes.
#pragma once

#include "elements/beam.hpp"
#include "state/state.hpp"

#include <Eigen/Core>

#include <limits>
#include <string>
#include <vector>

namespace msflex {

using Mat6 = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;

// What the element contributors accumulate for one beam element.
struct ElementContribution {
  int    num_nodes    = 2;
  bool   want_tangent = false;
  bool   evaluable    = true; // false: the element cannot be evaluated (a relative rotation reaches pi)
  double residual[kBeamMaxDofs];
  double tangent[kBeamMaxDofs * kBeamMaxDofs];
  // Energy-momentum scheme (eq. 18-20): the correction vector, weighted by the global beta, and
  // the element's share of beta's numerator (work mismatch) and denominator (correction work), and
  // the scale of its internal work and energies for the round-off test (the sum of |u| |f| over its
  // nodes and of |Pi_n| + |Pi_{n+1}|: the magnitudes whose rounding the mismatch carries).
  double correction[kBeamMaxDofs];
  double work_mismatch = 0.0, correction_work = 0.0, work_scale = 0.0;
  // Strain energy of the element in the configuration evaluated (the end of the step; in the
  // mid-point schemes Pi_{n+1}), which the residual pass keeps for the history (Assembler).
  double strain_energy = 0.0;
  // em's exact linearisation (with a tangent in the energy-momentum scheme): the correction's
  // tangent K_corr, and the spin-form gradients of beta's numerator (the work mismatch
  // Pi_{n+1} - Pi_n - W_mc) and denominator (the correction's work W_corr), W = sum u.f + alpha.m.
  bool   want_energy_terms = false;
  double tangent_correction[kBeamMaxDofs * kBeamMaxDofs];
  double mismatch_gradient[kBeamMaxDofs], correction_work_gradient[kBeamMaxDofs];
  // em with beta known (the residual's at the same unknowns): the tangent takes K_mc + beta K_corr
  // at once, tangent_correction stays unused and the gradients leave out K_corr's part
  // (mismatch_gradient - beta correction_work_gradient is still grad M - beta grad C). Null otherwise.
  const double *combined_beta = nullptr;
  // The version of the unknowns being evaluated (the Assembler's; -1: unknown). A contributor may
  // keep what a residual evaluation computed for a tangent evaluation at the same version.
  long long iterate_key = -1;

  void Clear(int nodes, bool tangent_wanted, bool energy_terms_wanted = false, const double *beta = nullptr);
};

// What the node contributors accumulate for one owned node.
struct NodeContribution {
  double residual[6];
  Mat6   tangent;
  bool   want_tangent = false;

  void Clear(bool tangent_wanted);
};

// A block of a free-topology contributor (one or more nodes).
struct NodeBlock {
  static constexpr int kMaxNodes = 2;
  int                  num_nodes = 1;
  int                  nodes[kMaxNodes]; // local node indices
};

// Receives the free blocks of a contributor (implemented by the assembler).
class BlockSink {
public:
  virtual ~BlockSink() = default;
  // residual: 6 per node; tangent: (6n)^2 row-major, or null when no tangent was asked for.
  virtual void Add(const NodeBlock &block, const double *residual, const double *tangent) = 0;
  // A generalised force on released coordinate `coordinate` of local joint `joint` (State::joints):
  // its row is the coordinate's (the released test quantity p in the mid-point family), its
  // tangent d residual / d(the coordinate's increment); a driven coordinate has no unknown, and
  // its residual goes to the drive's reaction. `tangent` is ignored when none was asked for.
  virtual void AddCoordinate(int joint, int coordinate, double residual, double tangent) = 0;
};

// One value of a history series that a contributor records (output/results.hpp gathers them on
// rank 0): its name and its place in the series' order (e.g. the force element's number in the
// whole model, then the quantity).
struct HistoryValue {
  long long   order = 0;
  std::string name;
  double      value = 0.0;
};

// Kinetic energy, linear momentum and angular momentum about the origin.
struct Momenta {
  double kinetic_energy   = 0.0;
  Vec3   linear_momentum  = Vec3::Zero();
  Vec3   angular_momentum = Vec3::Zero();
};

// Where numerical trouble starts (assembly/diagnostics.cpp): each finding has a key that orders
// sources upstream first (a node's own unknowns feed the joints that place their slaves, both feed
// the loads and elements), then by the number in the whole model; the lowest key wins, and of
// equal keys the first offered.
enum class TroubleSource : long long { NodeIncrement = 0, Joint, NodeLoad, Element, NodeForces, RigidBody, ForceElement };
struct TroubleFindings {
  static constexpr long long kNone = std::numeric_limits<long long>::max();
  long long                  key   = kNone;
  std::string                text;
  void                       Offer(TroubleSource source, long long global_index, std::string description)
  {
    const long long candidate = ((long long)source << 40) + global_index;
    if (candidate < key) key = candidate, text = std::move(description);
  }
};

// Names for messages: "node 'arm.3'"; "element 12 (nodes 'arm.3', 'arm.4')" with the element's
// number in the whole model (its row in the output file) and its nodes' names, which survive the
// restriction of the model to a rank's part.
std::string NodeLabel(const Model &model, int node);
std::string ElementLabel(const Model &model, const DofMap &map, int element);

class ForceContributor {
public:
  virtual ~ForceContributor()      = default;
  virtual const char *Name() const = 0;

  // Prepares the step whose equations the state holds (loads and their time weights).
  virtual void BeginStep(const State &state) {}

  // Element topology: adds the forces of local element k to `out`.
  virtual bool ActsOnElements() const { return false; }
  virtual void AddElement(const State &state, size_t k, ElementContribution *out) {}
  // Node topology: adds the forces on owned node l to `out`.
  virtual bool ActsOnNodes() const { return false; }
  virtual void AddNode(const State &state, int l, NodeContribution *out) {}
  // Free topology: sends every block to the sink.
  virtual void AddBlocks(const State &state, bool want_tangent, BlockSink *sink) {}

  // Energies and work for the history, summed over what this rank holds: the stored (strain)
  // energy of the current configuration, the momenta of the start-of-step state, and the work of
  // the external loads over the step's increments (u.F + alpha.M).
  virtual void AddStoredEnergy(const State &state, double *energy) const {}
  virtual void AddMomenta(const State &state, Momenta *momenta) const {}
  virtual void AddStepWork(const State &state, double *work) const {}
  // The energy the contributor's dampers dissipate over the step's increments (their force times
  // the change of what they resist), summed over what this rank holds.
  virtual void AddStepDissipation(const State &state, double *dissipation) const {}
  // Viscous coefficients times the size of what rounds in the rates they multiply, summed in
  // squares over this rank's elements: the residual's round-off floor from damping is eps times its
  // square root times the coefficient that turns an increment into a rate (Assembler::BeginStep).
  virtual double LocalDampingRoundoffSquares() const { return 0.0; }
  // Whether the stored energy is a spring's (history `spring_energy`) rather than the beams'.
  virtual bool StoresSpringEnergy() const { return false; }

  // Motion the contributor keeps of its own: StartMotion after the initial velocities (and again
  // after the initial accelerations) are in the state, CommitStep at the converged increments of a
  // step before the state commits them (history of damped strains, the forces recorded for the
  // output).
  virtual void StartMotion(State *state) {}
  virtual void CommitStep(State *state) {}
  // History values of this rank's elements at the last committed step (or the start); their names
  // only `with_names` (the first row: the names are gathered once, and building them for every
  // row of a small model's step cost more than the values).
  virtual void AddHistory(const State &state, bool with_names, std::vector<HistoryValue> *values) const {}

  // Numerical trouble in the contributor's data (loads, inertia) rather than in its forces, and
  // in the forces of its free blocks whose nodes are finite (node_finite: per local node).
  virtual void FindNonFiniteData(const State &state, TroubleFindings *findings) const {}
  virtual void FindNonFiniteBlocks(const State &state, const std::vector<char> &node_finite, TroubleFindings *findings) const {}
};

} // namespace msflex
