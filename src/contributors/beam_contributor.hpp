// The beam elements' internal forces (elements/beam.hpp): at t_{n+1} in statics and the Newmark
// family, the mid-point forces of eq. (17)-(19) in the mid-point family with em's correction
// vector and its share of beta (eq. 20); none in the initial-acceleration problem, where the
// configuration is the start state (whose internal forces are evaluated, but have no tangent).
// Also the element results of the output (strains and stress resultants) and the strain energy.
#pragma once

#include "contributors/contributor.hpp"
#include "dofs/dof_map.hpp"
#include "model/model.hpp"

#include <petscsys.h>

#include <vector>

namespace msflex {

// Per-element mean (over the Gauss points) of strains and stress resultants, section frame.
struct ElementResults {
  Vec3 strain, curvature, force, moment;
};

class BeamContributor : public ForceContributor {
public:
  // Reference data of every local element (a degenerate element is an input error).
  PetscErrorCode Setup(const Model &model, const DofMap &map);
  const char    *Name() const override { return "beam elements"; }

  bool ActsOnElements() const override { return true; }
  // Mid-point schemes: what the kernel needs of the step's start, once per step (BeamMidpointStart).
  void BeginStep(const State &state) override;
  void AddElement(const State &state, size_t k, ElementContribution *out) override;
  void AddStoredEnergy(const State &state, double *energy) const override;

  // Element results for the local elements and their strain energy; false when an element cannot
  // be evaluated.
  bool Results(const State &state, std::vector<ElementResults> *results, double *strain_energy) const;
  // The results of the local elements `only` (local indices) alone, in *results sized for every
  // local element (the others zero): the history's element probes at a step without a frame.
  bool ResultsOf(const State &state, const std::vector<int> &only, std::vector<ElementResults> *results) const;
  // The strain energy of the local elements in the current configuration alone (false: an element
  // could not be evaluated).
  bool StrainEnergy(const State &state, double *strain_energy) const;
  // The end-point tangent of element k (spin form), for diagnostics; false when it cannot be evaluated.
  bool EndPointTangent(const State &state, size_t k, double *residual, double *tangent) const;

  const std::vector<BeamElementReference> &References() const { return references_; }
  // Residual level at which the internal forces are lost in round-off: 100 eps times the norm of
  // the local sections' stiffness (EA, GA, GJ/L, EI/L per element); summed over ranks by the caller.
  double LocalStiffnessSquares() const;

  // Linearised buckling (integrators/linearization.hpp): the strains (Gamma - Gamma_0, K - K_0) of
  // every Gauss point of the local elements in the current configuration (false when an element
  // cannot be evaluated), and initial strains added to them: the reference strains become
  // Gamma_0 - prestrain, K_0 - prestrain, so that a configuration carries the stresses of its own
  // strains plus the prestrain's, until ClearPrestrain.
  struct GaussStrains {
    Vec3 strain[kBeamMaxGauss], curvature[kBeamMaxGauss];
  };
  bool GaussStrainsOf(const State &state, std::vector<GaussStrains> *strains) const;
  void AddPrestrain(const std::vector<GaussStrains> &prestrain);
  void ClearPrestrain();

  // Current (or start-of-step) nodal positions and section triads of local element k.
  void Configuration(const State &state, size_t k, Vec3 *positions, Mat3 *triads) const;
  void StartConfiguration(const State &state, size_t k, Vec3 *positions, Mat3 *triads) const;

private:
  // Element k's end-point internal forces in the current configuration, for their energy and
  // (gauss not null) Gauss-point results; false when it cannot be evaluated.
  bool EndPointForces(const State &state, size_t k, double *energy, BeamGaussResults *gauss) const;
  // Element k's results (means over its Gauss points) and strain energy; false: not evaluable.
  bool ElementResultOf(const State &state, size_t k, ElementResults *out, double *energy) const;

  const Model                      *model_ = nullptr;
  const DofMap                     *map_   = nullptr;
  std::vector<BeamElementReference> references_;            // per local element
  std::vector<BeamSectionStiffness> sections_;              // per section
  std::vector<BeamElementReference> unstrained_references_; // the references without prestrain, while there is one
  // Per local element, the start of the step of the mid-point schemes (BeginStep), and whether it
  // holds (empty outside a mid-point step; false for an element the kernel cannot evaluate there).
  std::vector<BeamMidpointStart> midpoint_start_;
  std::vector<char>              midpoint_start_ok_;
  // em: per local element, what its last residual evaluation computed that the tangent at the same
  // unknowns needs again (the version `key`, -1: nothing kept). SNES assembles em's tangent right
  // after the residual at the same iterate, so the tangent pass does only the tangent's own work.
  struct KeptMidpoint {
    long long key  = -1;
    int       slot = 0; // into kept_two_ or kept_three_, by the element's number of nodes
    double    energy_start, energy_end;
  };
  // The kernel's iterate with the forces it gave, in one record of the element's size (read back
  // whole by the tangent's visit).
  template <int NN> struct KeptIterate {
    BeamMidpointIterate<NN> iterate;
    double                  force[6 * NN], correction[6 * NN], end_residual[6 * NN];
  };
  std::vector<KeptMidpoint>   kept_;
  std::vector<KeptIterate<2>> kept_two_;
  std::vector<KeptIterate<3>> kept_three_;
};

// Reference data of element e of a model (shared by the set-up of beams and nodal masses).
PetscErrorCode BeamElementReferenceOf(const Model &model, int e, BeamElementReference *ref);

} // namespace msflex
