// The static equations and their linearisation about the current state of a mechanical system,
// with the load factor lambda (the pseudo-time at which loads, prescribed motions and drives are
// evaluated) as a variable of its own (docs/stability.md):
//
//   R(x, lambda)        residual of the step from the committed state at lambda_n, increments x
//   q = -dR/dlambda     the load pattern: the external loads' rate, including the reactions of
//                       prescribed motions and drives scaled by the same functions; a forward
//                       difference, exact for loads linear in lambda (the default ramp)
//   K                   the tangent at the committed state (omega = 0: H = I), loads at lambda
//   M                   the condensed mass matrix (tangent of the initial-acceleration problem,
//                       massless DOFs with zero rows)
//   K_sigma             the geometric stiffness of linearised buckling: the rate of the tangent
//                       with the stresses and loads along a path direction u (increments per unit
//                       load factor), in the configuration x itself. The strain rate e' of every
//                       Gauss point is the central difference of the strains of the states x +- eps u
//                       (objective strains: no frame terms); then K_sigma = K(x; prestrain e',
//                       loads at lambda + 1) - K(x; loads at lambda), which is exact because the
//                       tangent at a fixed configuration is linear in the stresses and loads. The
//                       configuration's own rate (the "initial displacement" terms, large where
//                       the shear or axial stiffness is) is left out, as in classical linearised
//                       buckling.
//
// Every function leaves the system's state at the committed configuration, but the step's
// equations and increments changed: begin a step before solving again.
#pragma once

#include "assembly/mechanical_system.hpp"

namespace msflex {

// R(x, lambda) of the static step from lambda_n (x null: zero increments), with the force scale
// of this residual and whether every element could be evaluated (collective).
PetscErrorCode StaticResidual(MechanicalSystem &system, double lambda_n, double lambda, Vec x, Vec residual, PetscBool *ok, double *force_scale);
// q = -(R(x, lambda + h) - residual) / h, `residual` being R(x, lambda); the state is left at
// (x, lambda) with its equations, ready for the tangent. Collective.
PetscErrorCode StaticLoadPattern(MechanicalSystem &system, double lambda_n, double lambda, Vec x, Vec residual, Vec q);
// K about the committed state at load factor lambda, copied into K (same layout as the
// assembler's matrix, e.g. MatDuplicate of it). Collective.
PetscErrorCode EquilibriumTangent(MechanicalSystem &system, double lambda, Mat K);
// M at the committed state, copied into M. Collective.
PetscErrorCode MassMatrix(MechanicalSystem &system, double lambda, Mat M);
// K_sigma along the direction `direction` (increments per unit load factor, e.g. K^{-1} q) by a
// central difference with the step eps; copied into K_sigma. Collective.
PetscErrorCode GeometricStiffness(MechanicalSystem &system, const Model &model, const DofMap &map, double lambda, Vec direction, double eps, Mat K_sigma);

// Weights of the unknowns in path norms: 1 for translations and length-type joint coordinates,
// length^2 for rotations and angle-type joint coordinates. Collective.
PetscErrorCode UnknownWeights(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, double length, Vec weights);
// The diagonal of the model's bounding box (m), a length to weigh rotations by. Collective.
PetscErrorCode ModelLength(MPI_Comm comm, const Model &model, const DofMap &map, double *length);
// Entry `row` of a distributed vector, on every rank (row < 0: 0). Collective.
PetscErrorCode VecEntry(Vec v, PetscInt row, double *value);

} // namespace msflex
