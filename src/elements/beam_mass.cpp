#include "elements/beam_mass.hpp"

namespace msflex {

void BeamConsistentInertia(const BeamElementReference &ref, double rhoA, const Vec3 *accelerations, double coefficient, double *residual, double *tangent)
{
  const int n = ref.num_nodes, nd = 6 * n;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const Vec3 f = rhoA * ref.mass_shape[a][b] * accelerations[b];
      for (int i = 0; i < 3; ++i) residual[6 * a + i] += f(i);
    }
  if (!tangent) return;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      for (int i = 0; i < 3; ++i) tangent[(6 * a + i) * nd + 6 * b + i] += coefficient * rhoA * ref.mass_shape[a][b];
}

void BeamTranslationalMomenta(const BeamElementReference &ref, double rhoA, const Vec3 *positions, const Vec3 *velocities, double *kinetic_energy,
                              Vec3 *linear_momentum, Vec3 *angular_momentum)
{
  for (int a = 0; a < ref.num_nodes; ++a)
    for (int b = 0; b < ref.num_nodes; ++b) {
      const Vec3 p = rhoA * ref.mass_shape[a][b] * velocities[b];
      *kinetic_energy += 0.5 * velocities[a].dot(p);
      *linear_momentum += p;
      *angular_momentum += positions[a].cross(p);
    }
}

} // namespace msflex
