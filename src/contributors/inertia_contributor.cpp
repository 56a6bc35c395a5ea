#include "contributors/inertia_contributor.hpp"

#include "elements/beam_mass.hpp"
#include "elements/inertia.hpp"

#include <cmath>

namespace msflex {

namespace {

// Body-frame rotary inertia that an element lumps to its node a by nodal quadrature of eq. (17):
// integral of I_a ds times the section inertia rhoJ turned from the section into the node frame.
Mat3 LumpedRotaryInertia(const BeamElementReference &ref, const BeamElement &element, const Section &section, int a)
{
  const Mat3 &T0 = element.reference_triads[a];
  return ref.nodal_length[a] * (T0 * section.rhoJ.asDiagonal() * T0.transpose());
}

bool AllFinite(const Mat3 &m) { return m.allFinite(); }

} // namespace

PetscErrorCode NodalMassCreate(const Model &model, const DofMap &map, NodalMass *mass)
{
  PetscFunctionBeginUser;
  mass->rotary_inertia.assign(map.num_owned_nodes, Mat3::Zero());
  for (size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement &element = model.elements[e];
    if (model.sections[element.section].rhoJ.isZero(0.0)) continue;
    BeamElementReference ref;
    bool                 have_reference = false;
    for (int a = 0; a <= element.order; ++a) {
      const int l = map.node_to_local[element.nodes[a]];
      if (l < 0 || l >= map.num_owned_nodes) continue;
      if (!have_reference) {
        PetscCall(BeamElementReferenceOf(model, (int)e, &ref));
        have_reference = true;
      }
      mass->rotary_inertia[l] += LumpedRotaryInertia(ref, element, model.sections[element.section], a);
    }
  }
  mass->groups.assign(map.local_nodes.size(), NodeMassGroups{});
  for (const BeamElement &element : model.elements) {
    const Section &section = model.sections[element.section];
    for (int a = 0; a <= element.order; ++a) {
      const int l = map.node_to_local[element.nodes[a]];
      if (l < 0) continue;
      if (section.rhoA > 0.0) mass->groups[l].translational = true;
      if (!section.rhoJ.isZero(0.0)) mass->groups[l].rotary = true;
    }
  }
  for (const RigidBody &body : model.rigid_bodies) {
    const int l = map.node_to_local[body.node];
    if (l < 0) continue;
    if (body.mass > 0.0) mass->groups[l].translational = mass->groups[l].rotary = true; // with an offset, the mass also resists rotation
    if (!body.inertia.isZero(0.0)) mass->groups[l].rotary = true;
    if (l < map.num_owned_nodes) mass->rotary_inertia[l] += body.inertia;
  }
  // A support's DOF has no unknown: its row is the support's reaction, which dropping it lost (a
  // massless anchor's reaction to a stretched spring read 0 at t = 0, and the work of a prescribed
  // massless support was missed in the first step).
  for (size_t l = 0; l < map.local_nodes.size(); ++l)
    for (int d = 0; d < 6; ++d)
      if (map.node_dofs[map.local_nodes[l]][d] < 0) mass->groups[l].held |= 1u << d;
  // Joints carry inertia between their nodes: never replace the equations of a master or a slave.
  for (const Joint &joint : model.joints)
    for (int node : {joint.master, joint.slave}) {
      const int l = node >= 0 ? map.node_to_local[node] : -1;
      if (l >= 0) mass->groups[l].translational = mass->groups[l].rotary = true;
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

void InertiaContributor::Setup(const Model &model, const DofMap &map, const BeamContributor &beams, NodalMass nodal_mass)
{
  model_ = &model;
  map_   = &map;
  beams_ = &beams;
  mass_  = std::move(nodal_mass);
}

void InertiaContributor::AddElement(const State &state, size_t k, ElementContribution *out)
{
  const StepEquations &eq = state.equations;
  if (!eq.Inertial()) return;
  const BeamElement &element = model_->elements[map_->local_elements[k]];
  const double       rhoA    = model_->sections[element.section].rhoA;
  if (!(rhoA > 0.0)) return;
  // The accelerations: the unknowns themselves in the initial-acceleration problem, else what the
  // scheme derives from the increments.
  Vec3 accelerations[kBeamMaxNodes];
  for (int a = 0; a <= element.order; ++a) {
    const NodeState &s = state.nodes[map_->node_to_local[element.nodes[a]]];
    accelerations[a]   = eq.InitialAcceleration() ? s.displacement_increment : s.translation_update.acceleration;
  }
  BeamConsistentInertia(beams_->References()[k], rhoA, accelerations, eq.InertiaCoefficient(), out->residual, out->want_tangent ? out->tangent : nullptr);
}

void InertiaContributor::AddNode(const State &state, int l, NodeContribution *out)
{
  const StepEquations &eq = state.equations;
  const NodeState     &s  = state.nodes[l];
  const Mat3          &J  = mass_.rotary_inertia[l];
  if (eq.Dynamic() && !J.isZero(0.0)) {
    Vec3                    moment;
    Mat3                    moment_tangent;
    MotionUpdate            update;
    const RotationIncrement increment{s.rotation_increment, s.rotation, s.rotation_tangent, s.tangent_scaled_increment, s.tangent_scaled_derivative};
    RotationalInertia(eq.scheme, J, QuaternionToMatrix(s.rotation_start), increment, s.rotation_motion, &moment, out->want_tangent ? &moment_tangent : nullptr,
                      &update, s.PrescribedSpin());
    for (int i = 0; i < 3; ++i) out->residual[3 + i] += moment(i);
    // The kernel differentiates with respect to omega; spins: d omega = H(omega)^{-1} d theta.
    if (out->want_tangent) out->tangent.block<3, 3>(3, 3) += moment_tangent * s.rotation_tangent_inverse;
  } else if (eq.InitialAcceleration()) {
    Vec3 moment;
    Mat3 moment_tangent;
    InitialRotationalInertia(J, QuaternionToMatrix(s.rotation_start), s.rotation_motion.velocity, s.rotation_increment, &moment,
                             out->want_tangent ? &moment_tangent : nullptr);
    for (int i = 0; i < 3; ++i) out->residual[3 + i] += moment(i);
    if (out->want_tangent) out->tangent.block<3, 3>(3, 3) += moment_tangent;
  }
}

double InertiaContributor::LocalMomentumRateSquares(const State &state, double dt) const
{
  double squares = 0.0;
  for (size_t k = 0; k < map_->local_elements.size(); ++k) {
    const BeamElement &element  = model_->elements[map_->local_elements[k]];
    const double       rhoA     = model_->sections[element.section].rhoA;
    double             momentum = 0.0;
    for (int a = 0; a <= element.order; ++a)
      momentum += rhoA * beams_->References()[k].nodal_length[a] * state.nodes[map_->node_to_local[element.nodes[a]]].translation_motion.velocity.norm();
    squares += std::pow(momentum / dt, 2);
  }
  for (PetscInt l = 0; l < map_->num_owned_nodes; ++l)
    squares += std::pow(mass_.rotary_inertia[l].norm() * state.nodes[l].rotation_motion.velocity.norm() / dt, 2);
  for (const RigidBodyState &body : state.bodies) squares += std::pow(body.mass * state.nodes[body.local_node].translation_motion.velocity.norm() / dt, 2);
  return squares;
}

double InertiaContributor::LocalInertiaRoundoffSquares(double reach) const
{
  double squares = 0.0;
  for (size_t k = 0; k < map_->local_elements.size(); ++k) {
    const BeamElement &element = model_->elements[map_->local_elements[k]];
    const double       rhoA    = model_->sections[element.section].rhoA;
    for (int a = 0; a <= element.order; ++a) squares += std::pow(rhoA * beams_->References()[k].nodal_length[a] * reach, 2);
  }
  for (PetscInt l = 0; l < map_->num_owned_nodes; ++l) squares += std::pow(mass_.rotary_inertia[l].norm(), 2);
  for (const RigidBody &body : model_->rigid_bodies) {
    const int l = map_->node_to_local[body.node];
    if (l < 0 || l >= map_->num_owned_nodes) continue;
    squares += std::pow(body.mass * reach, 2) + std::pow(body.mass * body.offset.squaredNorm(), 2);
  }
  return squares;
}

void InertiaContributor::DropMasslessElementRows(const State &state, size_t k, ElementContribution *out) const
{
  const BeamElement &element = model_->elements[map_->local_elements[k]];
  NodeMassGroups     groups[kBeamMaxNodes];
  for (int a = 0; a <= element.order; ++a) groups[a] = mass_.groups[map_->node_to_local[element.nodes[a]]];
  DropMasslessRows(element.order + 1, groups, out->residual);
}

void InertiaContributor::SetMasslessNodeEquations(const State &state, int l, NodeContribution *out) const
{
  const NodeState &s = state.nodes[l];
  SetMasslessEquations(mass_.groups[l], s.displacement_increment, s.rotation_increment, out->residual, out->want_tangent ? out->tangent.data() : nullptr);
}

void InertiaContributor::AddMomenta(const State &state, Momenta *momenta) const
{
  for (size_t k = 0; k < map_->local_elements.size(); ++k) {
    const BeamElement &element = model_->elements[map_->local_elements[k]];
    Vec3               positions[kBeamMaxNodes], velocities[kBeamMaxNodes];
    for (int a = 0; a <= element.order; ++a) {
      const NodeState &s = state.nodes[map_->node_to_local[element.nodes[a]]];
      positions[a]       = s.position_start;
      velocities[a]      = s.translation_motion.velocity;
    }
    BeamTranslationalMomenta(beams_->References()[k], model_->sections[element.section].rhoA, positions, velocities, &momenta->kinetic_energy,
                             &momenta->linear_momentum, &momenta->angular_momentum);
  }
  for (PetscInt l = 0; l < map_->num_owned_nodes; ++l) {
    const NodeState &s  = state.nodes[l];
    const Vec3       JW = mass_.rotary_inertia[l] * s.rotation_motion.velocity;
    momenta->kinetic_energy += 0.5 * s.rotation_motion.velocity.dot(JW);
    momenta->angular_momentum += QuaternionToMatrix(s.rotation_start) * JW;
  }
}

void InertiaContributor::FindNonFiniteData(const State &state, TroubleFindings *findings) const
{
  if (!state.equations.Inertial()) return;
  for (PetscInt l = 0; l < map_->num_owned_nodes; ++l) {
    if (AllFinite(mass_.rotary_inertia[l])) continue;
    const int node = map_->local_nodes[l];
    findings->Offer(TroubleSource::NodeForces, map_->global_nodes[node], NodeLabel(*model_, node) + ", in its rotary inertia");
  }
}

} // namespace msflex
