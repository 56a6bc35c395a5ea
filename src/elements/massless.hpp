// Massless DOF groups in the initial-acceleration problem. A node's translations (or rotations)
// that no element, rigid body or joint gives mass (rotary inertia) have no equation of motion;
// their acceleration is set to zero instead:
//   r_g = a_g,   dr_g/da_g = I,   every other contribution to the group's rows dropped.
// Pure functions: no PETSc, no MPI, no allocation.
#pragma once

#include "math/rotation.hpp"

#include <Eigen/Core>

namespace msflex {

// Which groups of a node carry mass: [0] translations, [1] rotations.
struct NodeMassGroups {
  bool     translational = false, rotary = false;
  unsigned held = 0; // bit d: DOF d has no unknown (a support fixes or prescribes it); its row is a reaction, kept
};

// Drops the rows of the massless groups of an element's residual (6 per node).
void DropMasslessRows(int num_nodes, const NodeMassGroups *groups, double *residual);

// Replaces the rows of a node's massless groups by the equations a = 0 (residual 6, tangent 6x6
// row-major, columns: the node's accelerations).
void SetMasslessEquations(const NodeMassGroups &groups, const Vec3 &acceleration, const Vec3 &angular_acceleration, double *residual, double *tangent);

} // namespace msflex
