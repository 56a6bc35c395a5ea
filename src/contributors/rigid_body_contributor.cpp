#include "contributors/rigid_body_contributor.hpp"

#include "elements/inertia.hpp"
#include "elements/loads.hpp"

namespace msflex {

void RigidBodyContributor::Setup(const Model &model, const DofMap &map)
{
  model_ = &model;
  map_   = &map;
}

void RigidBodyContributor::BeginStep(const State &state)
{
  const StepEquations &eq = state.equations;
  weight_start_.assign(state.bodies.size(), Vec3::Zero());
  weight_end_.assign(state.bodies.size(), Vec3::Zero());
  for (size_t b = 0; b < state.bodies.size(); ++b)
    for (const DistributedLoad &load : model_->distributed_loads)
      if (load.gravity) {
        weight_start_[b] += FunctionValue(*model_, load.function, eq.t_start) * state.bodies[b].mass * load.force_per_length;
        weight_end_[b] += FunctionValue(*model_, load.function, eq.t_end) * state.bodies[b].mass * load.force_per_length;
      }
}

// Lever arm of the weight: r_{n+1} in statics and the Newmark family, (r_n + r_{n+1})/2 in the
// mid-point family, r_n in the initial-acceleration problem.
void RigidBodyContributor::BodyForces(const State &state, size_t b, Vec6 *residual, Mat6 *tangent) const
{
  const StepEquations  &eq      = state.equations;
  const RigidBodyState &body    = state.bodies[b];
  const NodeState      &s       = state.nodes[body.local_node];
  const Mat3            R_start = QuaternionToMatrix(s.rotation_start);
  const Vec3            r_start = R_start * body.offset, r_end = s.rotation * body.offset;
  residual->setZero();
  if (tangent) tangent->setZero();
  if (eq.Dynamic()) {
    if (eq.Midpoint()) {
      MotionUpdate update;
      OffsetPointMassInertia(eq.scheme, body.mass, body.offset, R_start, s.displacement_increment, s.rotation_increment, body.centre_of_mass, residual, tangent,
                             &update);
    } else {
      // The centre of mass as a point of the node's frame: the Newmark family's stability for a
      // body turning about a held node (elements/inertia.hpp).
      // The node's acceleration as StateUpdateNode made it: the scheme's, or a prescribed motion's.
      // The node's spin likewise: the scheme's, or a prescribed rotation's (NodeSpinUpdate).
      RigidOffsetMassInertia(eq.scheme, body.mass, body.offset, R_start, s.rotation_increment, s.translation_update.acceleration, s.rotation_motion, residual,
                             tangent, s.PrescribedSpin());
    }
    // The kernel differentiates with respect to omega; spins: d omega = H(omega)^{-1} d theta.
    if (tangent) tangent->rightCols<3>() = (tangent->rightCols<3>() * s.rotation_tangent_inverse).eval();
  } else if (eq.InitialAcceleration()) {
    InitialOffsetPointMassInertia(body.mass, r_start, R_start * s.rotation_motion.velocity, s.displacement_increment, s.rotation_increment, residual, tangent);
  }
  const Vec3 weight = eq.LoadWeightStart() * weight_start_[b] + eq.LoadWeightEnd() * weight_end_[b];
  if (weight.isZero(0.0)) return;
  const double arm_start = eq.InitialAcceleration() ? 1.0 : eq.Midpoint() ? 0.5 : 0.0, arm_end = eq.InitialAcceleration() ? 0.0 : eq.Midpoint() ? 0.5 : 1.0;
  Vec6         r;
  Mat6         K;
  OffsetPointWeight(weight, r_start, r_end, arm_start, arm_end, &r, tangent ? &K : nullptr);
  *residual += r;
  if (tangent && arm_end != 0.0) *tangent += K;
}

void RigidBodyContributor::AddBlocks(const State &state, bool want_tangent, BlockSink *sink)
{
  for (size_t b = 0; b < state.bodies.size(); ++b) {
    Vec6      r;
    Mat6      K;
    NodeBlock block;
    block.num_nodes = 1;
    block.nodes[0]  = state.bodies[b].local_node;
    BodyForces(state, b, &r, want_tangent ? &K : nullptr);
    sink->Add(block, r.data(), want_tangent ? K.data() : nullptr);
  }
}

void RigidBodyContributor::AddMomenta(const State &state, Momenta *momenta) const
{
  for (const RigidBodyState &body : state.bodies) {
    const NodeState &s  = state.nodes[body.local_node];
    const Vec3       xc = s.position_start + QuaternionToMatrix(s.rotation_start) * body.offset;
    const Vec3       p  = body.mass * body.centre_of_mass.velocity;
    momenta->kinetic_energy += 0.5 * body.centre_of_mass.velocity.dot(p);
    momenta->linear_momentum += p;
    momenta->angular_momentum += xc.cross(p);
  }
}

void RigidBodyContributor::AddStepWork(const State &state, double *work) const
{
  for (size_t b = 0; b < state.bodies.size(); ++b) {
    const RigidBodyState &body = state.bodies[b];
    const NodeState      &s =
        state.nodes[body.local_node]; // The mean weight over the step times the centre of mass's displacement (as LoadContributor::AddStepWork).
    *work += (0.5 * (weight_start_[b] + weight_end_[b])).dot(s.displacement_increment + (s.rotation - QuaternionToMatrix(s.rotation_start)) * body.offset);
  }
}

void RigidBodyContributor::FindNonFiniteData(const State &state, TroubleFindings *findings) const
{
  for (size_t b = 0; b < state.bodies.size(); ++b) {
    if ((weight_start_[b].allFinite() && weight_end_[b].allFinite()) || !NodeStateFinite(state.nodes[state.bodies[b].local_node])) continue;
    const int node = map_->local_nodes[state.bodies[b].local_node];
    findings->Offer(TroubleSource::RigidBody, map_->global_nodes[node], "the rigid body on " + NodeLabel(*model_, node));
  }
}

void RigidBodyContributor::FindNonFiniteBlocks(const State &state, const std::vector<char> &node_finite, TroubleFindings *findings) const
{
  for (size_t b = 0; b < state.bodies.size(); ++b) {
    if (!node_finite[state.bodies[b].local_node]) continue;
    Vec6 r;
    Mat6 block;
    BodyForces(state, b, &r, &block);
    if (r.allFinite() && block.allFinite()) continue;
    const int node = map_->local_nodes[state.bodies[b].local_node];
    findings->Offer(TroubleSource::RigidBody, map_->global_nodes[node], "the rigid body on " + NodeLabel(*model_, node));
  }
}

} // namespace msflex
