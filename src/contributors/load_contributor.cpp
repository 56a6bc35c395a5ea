#include "contributors/load_contributor.hpp"

namespace msflex {

namespace {

bool AllFinite(const Vec3 &v) { return v.allFinite(); }

bool AllFinite(const NodalLoadValues &load)
{
  return AllFinite(load.dead_force_start) && AllFinite(load.dead_moment_start) && AllFinite(load.dead_force_end) && AllFinite(load.dead_moment_end) &&
         AllFinite(load.follower_force_start) && AllFinite(load.follower_moment_start) && AllFinite(load.follower_force_end) &&
         AllFinite(load.follower_moment_end);
}

} // namespace

void LoadContributor::Setup(const Model &model, const DofMap &map, const BeamContributor &beams)
{
  model_ = &model;
  map_   = &map;
  beams_ = &beams;
  line_load_start_.assign(map.local_elements.size(), Vec3::Zero());
  line_load_end_.assign(map.local_elements.size(), Vec3::Zero());
  nodal_load_.assign(map.num_owned_nodes, NodalLoadValues{});
  element_loaded_.assign(map.local_elements.size(), 0);
  node_loaded_.assign(map.num_owned_nodes, 0);
  for (const DistributedLoad &load : model.distributed_loads)
    for (int e : load.elements)
      if (map.element_to_local[e] >= 0) element_loaded_[map.element_to_local[e]] = 1;
  for (const NodalLoad &load : model.nodal_loads)
    for (int node : load.nodes) {
      const int l = map.node_to_local[node];
      if (l >= 0 && l < map.num_owned_nodes) node_loaded_[l] = 1;
    }
}

void LoadContributor::BeginStep(const State &state)
{
  const Model         &model = *model_;
  const DofMap        &map   = *map_;
  const StepEquations &eq    = state.equations;
  std::fill(line_load_start_.begin(), line_load_start_.end(), Vec3::Zero());
  std::fill(line_load_end_.begin(), line_load_end_.end(), Vec3::Zero());
  for (const DistributedLoad &load : model.distributed_loads) {
    const double f0 = FunctionValue(model, load.function, eq.t_start), f1 = FunctionValue(model, load.function, eq.t_end);
    for (int e : load.elements) {
      const int k = map.element_to_local[e];
      if (k < 0) continue;
      const double scale = load.gravity ? model.sections[model.elements[e].section].rhoA : 1.0;
      line_load_start_[k] += f0 * scale * load.force_per_length;
      line_load_end_[k] += f1 * scale * load.force_per_length;
    }
  }
  std::fill(nodal_load_.begin(), nodal_load_.end(), NodalLoadValues{});
  for (const NodalLoad &load : model.nodal_loads) {
    const double f0 = FunctionValue(model, load.function, eq.t_start), f1 = FunctionValue(model, load.function, eq.t_end);
    for (int node : load.nodes) {
      const int l = map.node_to_local[node];
      if (l < 0 || l >= map.num_owned_nodes) continue;
      NodalLoadValues &values = nodal_load_[l];
      if (load.follower) {
        values.follower_force_start += f0 * load.force, values.follower_moment_start += f0 * load.moment;
        values.follower_force_end += f1 * load.force, values.follower_moment_end += f1 * load.moment;
      } else {
        values.dead_force_start += f0 * load.force, values.dead_moment_start += f0 * load.moment;
        values.dead_force_end += f1 * load.force, values.dead_moment_end += f1 * load.moment;
      }
    }
  }
}

void LoadContributor::AddElement(const State &state, size_t k, ElementContribution *out)
{
  if (!element_loaded_[k]) return;
  const StepEquations &eq = state.equations;
  BeamLineLoad(beams_->References()[k], eq.LoadWeightStart() * line_load_start_[k] + eq.LoadWeightEnd() * line_load_end_[k], out->residual);
}

// Follower loads have a tangent except in the initial-acceleration problem, whose unknowns are
// accelerations (the configuration does not move).
void LoadContributor::AddNode(const State &state, int l, NodeContribution *out)
{
  if (!node_loaded_[l]) return;
  const StepEquations &eq = state.equations;
  const NodeState     &s  = state.nodes[l];
  Vec6                 r;
  Mat6                 K;
  const bool           tangent = out->want_tangent && !eq.InitialAcceleration();
  NodalLoadForces(nodal_load_[l], eq.LoadWeightStart(), eq.LoadWeightEnd(), QuaternionToMatrix(s.rotation_start), s.rotation, &r, tangent ? &K : nullptr);
  for (int i = 0; i < 6; ++i) out->residual[i] += r(i);
  if (tangent) out->tangent += K;
}

// The work of the loads over the step with the quadrature the scheme's energy balance uses: the
// mean of the loads at both ends of the step times the increments (u, and alpha in the mid-point
// family, omega in the Newmark family): exact for the mid-point family's discrete energy identity
// and the trapezoidal rule of Newmark (exact for linear systems).
void LoadContributor::AddStepWork(const State &state, double *work) const
{
  const Model         &model = *model_;
  const DofMap        &map   = *map_;
  const StepEquations &eq    = state.equations;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    if (!element_loaded_[k]) continue;
    const BeamElement &element = model.elements[map.local_elements[k]];
    const Vec3         q       = 0.5 * (line_load_start_[k] + line_load_end_[k]);
    for (int a = 0; a <= element.order; ++a)
      *work += beams_->References()[k].nodal_length[a] * q.dot(state.nodes[map.node_to_local[element.nodes[a]]].displacement_increment);
  }
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (!node_loaded_[l]) continue;
    const NodeState &s = state.nodes[l];
    Vec6             r;
    NodalLoadForces(nodal_load_[l], 0.5, 0.5, QuaternionToMatrix(s.rotation_start), s.rotation, &r, nullptr);
    Vec3 rotation = s.rotation_increment;
    if (eq.Midpoint()) TangentScaledIncrement(s.rotation_increment, &rotation, nullptr);
    *work += -r.head<3>().dot(s.displacement_increment) - r.tail<3>().dot(rotation);
  }
}

void LoadContributor::FindNonFiniteData(const State &state, TroubleFindings *findings) const
{
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (AllFinite(nodal_load_[l])) continue;
    const int node = map.local_nodes[l];
    findings->Offer(TroubleSource::NodeLoad, map.global_nodes[node], NodeLabel(model, node) + ", in its load");
  }
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    if (AllFinite(line_load_start_[k]) && AllFinite(line_load_end_[k])) continue;
    const int          e            = map.local_elements[k];
    const BeamElement &element      = model.elements[e];
    bool               nodes_finite = true;
    for (int a = 0; a <= element.order; ++a) nodes_finite = nodes_finite && NodeStateFinite(state.nodes[map.node_to_local[element.nodes[a]]]);
    if (!nodes_finite) continue; // a non-finite node is named upstream
    findings->Offer(TroubleSource::Element, map.global_elements[e], ElementLabel(model, map, e) + ", in its distributed load");
  }
}

} // namespace msflex
