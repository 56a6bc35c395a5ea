// Inertia of the beams and of the rigid bodies' rotation: the beams' consistent translational
// inertia per element (elements/beam_mass.hpp) and the rotary inertia lumped to the nodes
// (elements/inertia.hpp): the beams' section inertia rhoJ by nodal quadrature of eq. (17) plus the
// rigid bodies' inertia tensors about their centres of mass (their translational inertia is the
// rigid-body contributor's). Absent in statics. In the initial-acceleration problem a node's
// translations or rotations that carry no mass get the equation "acceleration = 0"
// (elements/massless.hpp).
#pragma once

#include "contributors/beam_contributor.hpp"
#include "elements/massless.hpp"

#include <vector>

namespace msflex {

// Nodal masses that need the whole model: an owned node's rotary inertia collects every element
// touching it, also those assembled on other ranks. Computed before the model is restricted to
// the rank's part (dofs/dof_map.hpp); indexed like the local nodes, which the restriction keeps.
struct NodalMass {
  std::vector<Mat3>           rotary_inertia; // per owned node, body frame
  std::vector<NodeMassGroups> groups;         // per local node: which groups carry mass
};
PetscErrorCode NodalMassCreate(const Model &model, const DofMap &map, NodalMass *mass);

class InertiaContributor : public ForceContributor {
public:
  void        Setup(const Model &model, const DofMap &map, const BeamContributor &beams, NodalMass nodal_mass);
  const char *Name() const override { return "inertia"; }

  bool ActsOnElements() const override { return true; }
  void AddElement(const State &state, size_t k, ElementContribution *out) override;
  bool ActsOnNodes() const override { return true; }
  void AddNode(const State &state, int l, NodeContribution *out) override;
  void AddMomenta(const State &state, Momenta *momenta) const override;
  void FindNonFiniteData(const State &state, TroubleFindings *findings) const override;

  // Sum over this rank's elements, owned nodes and rigid bodies of (|p| / dt)^2, |p| the size of
  // the momenta at the start of the step (rhoA sum_a l_a |v_a| per element, |J|_F |W| per node,
  // m |v| per body): the scale of the momentum differences over dt that an inertial residual is,
  // whose rounding bounds how small that residual can get (Assembler::BeginStep).
  double LocalMomentumRateSquares(const State &state, double dt) const;
  // Sum over this rank's elements, owned nodes and rigid bodies of the squared inertia that the
  // rounding of the configuration meets: (m R)^2 per mass m at positions of size R (`reach`, m)
  // and (|J|_F + m |c|^2)^2 per rotary inertia J and offset c (rotations rounded to about eps rad).
  // Times eps and the scheme's inertia coefficient (1/(beta dt^2), 2/dt^2) it bounds how small an
  // inertial residual can get whatever the momenta: at rest, at a turning point, with small steps.
  double LocalInertiaRoundoffSquares(double reach) const;

  // The equations of the massless groups (initial-acceleration problem): an element's rows
  // dropped, a node's rows replaced; called by the assembler after every contributor has added.
  void DropMasslessElementRows(const State &state, size_t k, ElementContribution *out) const;
  void SetMasslessNodeEquations(const State &state, int l, NodeContribution *out) const;
  // Which of local node l's groups (translations, rotations) carry mass.
  const NodeMassGroups &Groups(int l) const { return mass_.groups[l]; }

private:
  const Model           *model_ = nullptr;
  const DofMap          *map_   = nullptr;
  const BeamContributor *beams_ = nullptr;
  NodalMass              mass_;
};

} // namespace msflex
