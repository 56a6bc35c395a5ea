// Rigid bodies: the translational inertia of the centre of mass, a point at the offset c from its
// node (elements/inertia.hpp: moving with the node's frame in the Newmark family, with its own
// algorithmic velocity in the mid-point family), and the body's weight at
// the centre of mass with the lever arm of the scheme's virtual work (elements/loads.hpp). The
// body's rotary inertia is lumped to its node with the beams' (inertia_contributor.hpp).
#pragma once

#include "contributors/contributor.hpp"

#include <vector>

namespace msflex {

class RigidBodyContributor : public ForceContributor {
public:
  void        Setup(const Model &model, const DofMap &map);
  const char *Name() const override { return "rigid bodies"; }

  void BeginStep(const State &state) override;
  void AddBlocks(const State &state, bool want_tangent, BlockSink *sink) override;
  void AddMomenta(const State &state, Momenta *momenta) const override;
  void AddStepWork(const State &state, double *work) const override;
  void FindNonFiniteData(const State &state, TroubleFindings *findings) const override;
  void FindNonFiniteBlocks(const State &state, const std::vector<char> &node_finite, TroubleFindings *findings) const override;

private:
  // Residual and tangent (spin form) of the body state.bodies[b].
  void BodyForces(const State &state, size_t b, Vec6 *residual, Mat6 *tangent) const;

  const Model      *model_ = nullptr;
  const DofMap     *map_   = nullptr;
  std::vector<Vec3> weight_start_, weight_end_; // per body of the state: m g at the centre of mass at t_n and t_{n+1}
};

} // namespace msflex
