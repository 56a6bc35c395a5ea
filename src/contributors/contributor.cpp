#include "contributors/contributor.hpp"

#include <algorithm>

namespace msflex {

void ElementContribution::Clear(int nodes, bool tangent_wanted, bool energy_terms_wanted, const double *beta)
{
  const int nd      = 6 * nodes;
  num_nodes         = nodes;
  want_tangent      = tangent_wanted;
  want_energy_terms = tangent_wanted && energy_terms_wanted;
  combined_beta     = tangent_wanted ? beta : nullptr;
  evaluable         = true;
  iterate_key       = -1;
  std::fill(residual, residual + nd, 0.0);
  std::fill(correction, correction + nd, 0.0);
  if (want_tangent) std::fill(tangent, tangent + nd * nd, 0.0);
  if (want_energy_terms) {
    if (!combined_beta) std::fill(tangent_correction, tangent_correction + nd * nd, 0.0);
    std::fill(mismatch_gradient, mismatch_gradient + nd, 0.0);
    std::fill(correction_work_gradient, correction_work_gradient + nd, 0.0);
  }
  work_mismatch = correction_work = work_scale = strain_energy = 0.0;
}

void NodeContribution::Clear(bool tangent_wanted)
{
  want_tangent = tangent_wanted;
  std::fill(residual, residual + 6, 0.0);
  if (want_tangent) tangent.setZero();
}

std::string NodeLabel(const Model &model, int node) { return "node '" + model.nodes[node].name + "'"; }

std::string ElementLabel(const Model &model, const DofMap &map, int element)
{
  const BeamElement &e     = model.elements[element];
  std::string        label = "element " + std::to_string(map.global_elements[element]) + " (nodes ";
  for (int a = 0; a <= e.order; ++a) label += (a > 0 ? ", '" : "'") + model.nodes[e.nodes[a]].name + "'";
  return label + ")";
}

} // namespace msflex
