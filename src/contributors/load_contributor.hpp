// External loads (elements/loads.hpp): dead and follower nodal loads on owned nodes, and
// distributed dead loads and gravity on the beam elements (the rigid bodies' weight is the
// rigid-body contributor's). Every load is its value times its function of time, weighted over the
// step by the scheme (schemes/step_equations.hpp).
#pragma once

#include "contributors/beam_contributor.hpp"
#include "elements/loads.hpp"

#include <vector>

namespace msflex {

class LoadContributor : public ForceContributor {
public:
  void        Setup(const Model &model, const DofMap &map, const BeamContributor &beams);
  const char *Name() const override { return "loads"; }

  void BeginStep(const State &state) override;
  bool ActsOnElements() const override { return true; }
  void AddElement(const State &state, size_t k, ElementContribution *out) override;
  bool ActsOnNodes() const override { return true; }
  void AddNode(const State &state, int l, NodeContribution *out) override;
  void AddStepWork(const State &state, double *work) const override;
  void FindNonFiniteData(const State &state, TroubleFindings *findings) const override;

private:
  const Model                 *model_ = nullptr;
  const DofMap                *map_   = nullptr;
  const BeamContributor       *beams_ = nullptr;
  std::vector<Vec3>            line_load_start_, line_load_end_; // per local element: force per length at t_n, t_{n+1}
  std::vector<NodalLoadValues> nodal_load_;                      // per owned node
  // Which local elements carry a distributed load and which owned nodes a nodal load (whatever
  // its function's value): the passes skip the others, which are most nodes of a large model.
  std::vector<char> element_loaded_, node_loaded_;
};

} // namespace msflex
