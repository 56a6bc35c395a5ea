// Geometrically exact (Reissner–Simo) 3D beam with the strain-invariant interpolation of
// rotations of Jelenić & Crisfield (CMAME 171, 1999), Lagrange elements of 2 or 3 nodes and
// reduced Gauss integration (n_nodes - 1 points).
//
// Kinematics (element node c = reference node: node 0 for 2 nodes, the middle node for 3):
//   psi_a  = log(Lambda_c^T Lambda_a)          local rotation of node a (psi_c = 0)
//   rho_a  = Lambda_c^T (x_a - x_c)            local position of node a (rho_c = 0)
//   Psi(s) = sum_a I_a(s) psi_a,   Lambda(s) = Lambda_c exp(Psi(s))
//   Gamma  = Lambda^T x' = exp(Psi)^T rho',    K = H(Psi)^T Psi'          (material strains)
//   N = C_N (Gamma - Gamma_0),  M = C_M (K - K_0),  C_N = diag(EA, GA2, GA3), C_M = diag(GJ, EI2, EI3)
// For 2 nodes this is the geodesic Lambda(s) = Lambda_1 exp(xi psi_2), identical to Jelenić &
// Crisfield's mid-node reference. Strains depend only on relative rotations and positions, so the
// element is objective (invariant under a superposed rigid motion) and path-independent (total
// Lagrangian in the nodal triads).
//
// Residual and tangent are with respect to nodal displacements and spatial spin variations
// (delta Lambda_a = hat(delta theta_a) Lambda_a): r = d Pi / d(x, theta), K = d r / d(x, theta).
// Kernels are pure functions: no PETSc, no MPI, no allocation.
#pragma once

#include "math/rotation.hpp"
#include "schemes/time_scheme.hpp"

namespace msflex {

constexpr int kBeamMaxNodes = 3;
constexpr int kBeamMaxGauss = 2;
constexpr int kBeamMaxDofs  = 6 * kBeamMaxNodes;

struct BeamSectionStiffness {
  Vec3 axial_shear;     // EA, GA2, GA3
  Vec3 torsion_bending; // GJ, EI2, EI3
};

// Everything about an element that is fixed after set-up (computed from the reference configuration).
struct BeamElementReference {
  int    num_nodes      = 2;
  int    num_gauss      = 1;
  int    reference_node = 0;
  double length         = 0.0;                             // reference arc length
  double weight_jacobian[kBeamMaxGauss]{};                 // Gauss weight * ds/dxi
  double shape[kBeamMaxGauss][kBeamMaxNodes]{};            // I_a at the Gauss points
  double shape_derivative[kBeamMaxGauss][kBeamMaxNodes]{}; // dI_a/ds at the Gauss points
  double nodal_length[kBeamMaxNodes]{};                    // integral of I_a ds (consistent dead loads, lumped rotary inertia)
  double mass_shape[kBeamMaxNodes][kBeamMaxNodes]{};       // integral of I_a I_b ds (consistent translational mass / rhoA)
  Vec3   strain0[kBeamMaxGauss];                           // Gamma_0
  Vec3   curvature0[kBeamMaxGauss];                        // K_0
};

// Strains and stress resultants at the Gauss points (section frame).
struct BeamGaussResults {
  Vec3 strain[kBeamMaxGauss];    // Gamma - Gamma_0
  Vec3 curvature[kBeamMaxGauss]; // K - K_0
  Vec3 force[kBeamMaxGauss];     // N
  Vec3 moment[kBeamMaxGauss];    // M
};

enum class BeamKernelStatus { Ok, DegenerateGeometry, RotationTooLarge };

// Reference data from reference nodal positions and section triads (columns t1, t2, t3).
BeamKernelStatus BeamElementSetup(int num_nodes, const Vec3 *reference_positions, const Mat3 *reference_triads, BeamElementReference *ref);

// Internal forces (residual, 6 per node: force then moment), optionally the tangent (row-major,
// 6n x 6n), the strain energy and the Gauss-point results. `positions` and `triads` are the
// current nodal positions and section triads. Fails (RotationTooLarge) when a relative nodal
// rotation inside the element reaches pi.
BeamKernelStatus BeamInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions, const Mat3 *triads,
                                    double *residual, double *tangent, double *strain_energy, BeamGaussResults *results);
// The same r and K added into `residual` and `tangent` (an element's sum over its contributors,
// which the assembler fills in place: no copy of the 6n x 6n matrix); nothing is added on failure.
BeamKernelStatus BeamAddInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions, const Mat3 *triads,
                                       double *residual, double *tangent, double *strain_energy);

// Mid-point internal forces of the momentum- and energy-conserving schemes (Muñoz, Jelenić &
// Crisfield 2003, eq. 17-19, for this element): with local coordinates q = (rho_a, psi_a) at the
// start (n) and end (n+1) of the step, q_mid = (q_n + q_{n+1})/2 and stresses S = (N, M),
//   h_mc   = sum_gp wJ D(q_mid)^T (S_n + S_{n+1})/2,   h_corr = sum_gp wJ D(q_mid)^T (S_{n+1} - S_n)
//   F = T*^T h,  T*: (u_a, alpha_a) -> local increments, built at x_{n+1/2}, with
//   Lambda_{c,n+1/2} = (Lambda_{c,n} + Lambda_{c,n+1})/2 and H^{-1}(psi_mid):
//   delta rho_a = Lambda_{c,n+1/2}^T (u_a - u_c + hat(d_{a,n+1/2}) alpha_c)   (exact for the increments)
//   delta psi_a = H^{-1}(psi_{a,mid}) Lambda_{c,n+1/2}^T (alpha_a - alpha_c)
// T* annihilates rigid motions about x_{n+1/2}, so F_mc and F_corr carry no net force and no net
// moment about the mid-point configuration: momenta are conserved. The energy scheme adds
// beta F_corr with beta chosen so that the work equals the change of strain energy (eq. 20).
// Eq. (19) builds the correction from the force resultants alone, q_k(N_d, 0); by default msflex
// uses the whole difference (N_d, M_d), and the paper's form is selectable (`correction`): with
// N_d alone the correction does almost no work while a beam mainly bends, so beta grows large
// (docs/dynamics.md compares the two).
//
// Outputs, 6 per node (force then moment), every one but force_mc optional (nullptr):
//   force_mc, force_correction   F_mc and F_corr (mc has no use for F_corr, and without it the
//       kernel skips its gradient unless a tangent of the correction is asked for)
//   tangent_mc, tangent_correction   K_mc = dF_mc/d(x, theta)_{n+1}, K_corr = dF_corr/d(x, theta)_{n+1}
//       (row-major 6n x 6n; columns: nodal displacement variations and spatial spin variations
//       delta Lambda_{a,n+1} = hat(delta theta_a) Lambda_{a,n+1} of the END of the step, the start
//       held fixed: the convention of BeamInternalForces' tangent). Exact: every dependence on the
//       end state is differentiated (S_{n+1}, q_mid, Lambda_{c,n+1/2}, d_{a,n+1/2}, H^{-1}(psi_mid)).
//   end_residual   r_{n+1} = d Pi_{n+1}/d(x, theta)_{n+1}, the end-point internal forces (equal to
//       BeamInternalForces' residual at the end state), for the linearisation of em's beta
//   strain_energy_start, strain_energy_end   Pi_n and Pi_{n+1}
// A tangent in incremental rotation vectors omega_a (Lambda_{a,n+1} = exp(hat(omega_a)) Lambda_{a,n})
// multiplies the spin columns of node a by H(omega_a) from the right, as for the end-point tangent.
// `correction`: Resultants builds F_corr (and K_corr) from the whole stress difference (N_d, M_d),
// the default; Forces from (N_d, 0) as in eq. (19) (analysis.em_correction, docs/dynamics.md).
// `combined_beta`: em with beta known; tangent_mc then receives K_mc + beta K_corr, built once
// from blocks that combine both (they are linear in the weight of the material part and in the
// stresses of the geometric part), at about the cost of K_mc alone; tangent_correction is ignored.
// `start`: the start of the step as BeamMidpointStartState made it (positions_start and
// triads_start are then not read and may be null), else it is computed from them.
struct BeamMidpointStart;
BeamKernelStatus BeamMidpointInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions_start,
                                            const Mat3 *triads_start, const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction,
                                            double *tangent_mc, double *tangent_correction, double *end_residual, double *strain_energy_start,
                                            double *strain_energy_end, EnergyCorrection correction = EnergyCorrection::Resultants,
                                            const double *combined_beta = nullptr, const BeamMidpointStart *start = nullptr);

// What the mid-point kernel needs of the start of the step, which stays fixed through the step's
// Newton iterations: the local coordinates (rho_a, psi_a)_n, the section triad of the reference node
// Lambda_{c,n}, the offsets d_{a,n} = x_{a,n} - x_{c,n}, and at each Gauss point
// (E^T rho', H^T psi')_n, the strains without the reference's (Gamma_0, K_0) taken off (so that a
// prestrain set later still applies). BeamMidpointStartState fails (RotationTooLarge) as the kernel
// would at that state.
struct BeamMidpointStart {
  Vec3 rho[kBeamMaxNodes], psi[kBeamMaxNodes], d[kBeamMaxNodes];
  Mat3 triad_c;
  Vec3 strain[kBeamMaxGauss], curvature[kBeamMaxGauss];
};
BeamKernelStatus BeamMidpointStartState(const BeamElementReference &ref, const Vec3 *positions_start, const Mat3 *triads_start, BeamMidpointStart *start);

// em's Newton tangent always follows a residual at the same unknowns (SNES evaluates the residual,
// then asks for the tangent there, and beta of that residual enters it). What the mid-point
// kernel's residual computes and its tangent needs again can therefore be kept between the two
// calls: BeamMidpointResidualKeeping fills a BeamMidpointIterate, BeamMidpointTangentOfIterate
// builds the tangent from it, and together they give what one BeamMidpointInternalForces call
// with the tangent gives, bit for bit, at about the cost of that call alone.
//   per Gauss point: Psi, Psi', rho' interpolated at the mid-point and at the end of the step,
//     their Rodrigues forms (exp and H; the mid-point's with second derivatives), the shift vectors
//     u of the Jacobians A, B (JacobianShift), and the stresses S_mid = (S_n + S_{n+1})/2, S_d;
//   per node other than the reference node c (slot o for the o-th of them in node order): the maps
//     Tbar (Lbar = (Lambda_{c,n} + Lambda_{c,n+1})/2, dbar_a, H^{-1}(psi_mid)^T, Lbar H^{-1}(psi_mid)^T)
//     and T_{n+1} (Lambda_{c,n+1}, d_a, P_a = H^{-1}(psi_{a,n+1}) Lambda_c^T), and the local
//     gradients h (of F_mc) and k (of F_corr).
// It is kept per element between two visits of every element (em's beta is global), so it holds
// no slot for the reference node, whose maps are the identity, and no copy of Lambda_c^T: at
// 10^4 elements the iterates leave the caches, and their size is then the tangent visit's cost.
template <int NN> struct BeamMidpointIterate {
  struct Point {
    double        wJ, x, x1; // Gauss weight times ds/dxi; |Psi|^2 at the mid-point and at the end
    Vec3          Psi, dPsi, drho, Psi1, dPsi1, drho1;
    RodriguesForm Fe, Fh, Fe1, Fh1;
    Vec3          ue, uh, ue1, uh1;
    Vec3          N_mid, M_mid, N_d, M_d;
  } point[NN - 1];
  Mat3          Lbar, L;
  Vec3          d[NN - 1], dbar[NN - 1], psi_mid[NN - 1];
  Mat3          P[NN - 1], HinvT_mid[NN - 1], PbarT[NN - 1];
  RodriguesForm Finv_mid[NN - 1];
  Vec3          h_rho[NN - 1], h_psi[NN - 1], k_rho[NN - 1], k_psi[NN - 1];
};
// The residual outputs of BeamMidpointInternalForces (force_mc, force_correction, end_residual,
// the two energies; all but the forces optional) and the iterate for the tangent. `start` as there
// (required here). NN must be ref.num_nodes.
template <int NN>
BeamKernelStatus BeamMidpointResidualKeeping(const BeamElementReference &ref, const BeamSectionStiffness &section, const BeamMidpointStart &start,
                                             const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction, double *end_residual,
                                             double *strain_energy_start, double *strain_energy_end, EnergyCorrection correction,
                                             BeamMidpointIterate<NN> *iterate);
// The tangents of BeamMidpointInternalForces from a kept iterate: K_mc + beta K_corr into
// tangent_mc with combined_beta, else K_mc and K_corr apart (either may be null).
template <int NN>
void BeamMidpointTangentOfIterate(const BeamElementReference &ref, const BeamSectionStiffness &section, const BeamMidpointIterate<NN> &iterate,
                                  EnergyCorrection correction, const double *combined_beta, double *tangent_mc, double *tangent_correction);

// The forces and energies alone (no tangents, no end residual): the call above with nullptr for those.
BeamKernelStatus BeamMidpointInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions_start,
                                            const Mat3 *triads_start, const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction,
                                            double *strain_energy_start, double *strain_energy_end);

} // namespace msflex
