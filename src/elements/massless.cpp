#include "elements/massless.hpp"

namespace msflex {

void DropMasslessRows(int num_nodes, const NodeMassGroups *groups, double *residual)
{
  for (int a = 0; a < num_nodes; ++a)
    for (int i = 0; i < 3; ++i) {
      if (!groups[a].translational && !(groups[a].held >> i & 1u)) residual[6 * a + i] = 0.0;
      if (!groups[a].rotary && !(groups[a].held >> (3 + i) & 1u)) residual[6 * a + 3 + i] = 0.0;
    }
}

void SetMasslessEquations(const NodeMassGroups &groups, const Vec3 &acceleration, const Vec3 &angular_acceleration, double *residual, double *tangent)
{
  for (int g = 0; g < 2; ++g) {
    if (g == 0 ? groups.translational : groups.rotary) continue;
    const Vec3 &unknown = g == 0 ? acceleration : angular_acceleration;
    for (int i = 0; i < 3; ++i) {
      if (groups.held >> (3 * g + i) & 1u) continue; // a reaction's row
      residual[3 * g + i] = unknown(i);
      if (!tangent) continue;
      for (int j = 0; j < 6; ++j) tangent[(3 * g + i) * 6 + j] = (j == 3 * g + i) ? 1.0 : 0.0;
    }
  }
}

} // namespace msflex
