// The direct solver of a banded tangent stored by node blocks (SEQBAIJ with blocks of 6, one rank):
// msflex's block envelope LU (core/block_envelope_lu.hpp) in RCM order of the node blocks, as a
// PCSHELL named "block LU". It factors a 1000-element chain in about half the time of PETSc's own
// BAIJ LU (docs/performance.md) where the envelope holds little more than the fill (BlockLUSuits),
// pivots inside the 6x6 diagonal blocks as PETSc's does, and
// reports an exactly singular diagonal block as the preconditioner's failure
// (PC_FACTOR_NUMERIC_ZEROPIVOT) instead of raising an error. The ordering and the envelope are
// kept while the matrix and its nonzero pattern stay.
#pragma once

#include <petscksp.h>

#include <string>

namespace msflex {

// Whether `matrix` is what the block LU factors: SEQBAIJ with blocks of 6.
PetscErrorCode BlockLUFits(Mat matrix, bool *fits);

// The blocks below the diagonal that the envelope of `matrix` (SEQBAIJ, 6) holds in RCM order,
// over those an LU with fill only where elimination creates it holds (CountBlockEnvelope).
PetscErrorCode BlockLUEnvelopeOverFill(Mat matrix, double *ratio);
// Above this ratio the envelope's extra work eats the block LU's faster arithmetic: factor and
// solve against PETSc's BAIJ LU in RCM order on about 1000 node blocks (docs/performance.md), a
// chain, a ladder frame and grid strips up to 16 wide (ratio 1.00-1.02) 0.46-0.61 of PETSc's time,
// combs of 300 x 3, 200 x 5 and 100 x 10 nodes (ratios 1.66, 3.37, 7.9) 0.84, 1.9 and 6.7 times it.
constexpr double kBlockLUEnvelopeOverFill = 1.5;

// Whether the block LU should factor `matrix` for a PC of options prefix `prefix`: it fits, no
// option names PETSc's PC or factorisation settings for that prefix (-<prefix>pc_type,
// -<prefix>pc_factor_*), and its envelope holds at most kBlockLUEnvelopeOverFill times the
// blocks of a sparse LU. One rank's matrix; the RCM ordering is computed here.
PetscErrorCode BlockLUSuits(Mat matrix, const char *prefix, bool *suits);

// Makes `pc` the block LU above. `-pc_type` or `-pc_factor_mat_solver_type` in the options replace it.
PetscErrorCode PCSetBlockLU(PC pc);

// Whether `pc` is that solver.
PetscErrorCode PCIsBlockLU(PC pc, bool *is_block_lu);
// Whether `pc` is that solver, and if its last factorisation met a singular diagonal block, which
// (`detail`).
PetscErrorCode BlockLUDescribeFailure(PC pc, bool *is_block_lu, std::string *detail);

// The direct solver that fits (docs/solvers.md, measured in docs/performance.md): on one rank, a
// tangent that is banded under RCM (chains, trees, slender frames: Assembler::BandedUnderRcm, given as `banded`) is
// factored fastest by a banded LU in RCM order without the multifrontal set-up (8-10x faster than
// MUMPS on a 1000-element chain): msflex's block LU when it is stored by node blocks and its
// envelope holds little more than the LU's fill (core/block_envelope_pc.hpp: about half the time of
// PETSc's BAIJ LU on chains, frames and strips), else PETSc's own LU;
// everything else (3D networks, whose fronts BLAS-3 handles, and every parallel run) by MUMPS, a
// dense tangent by LAPACK.
// Newton's tangent and the projection of the initial velocities choose so; options given with the
// PC's prefix (-pc_type, -pc_factor_*) replace the choice.
PetscErrorCode ChooseDirectSolver(bool banded, Mat tangent, PC pc);
// Whether the PC still factors by the banded LU that ChooseDirectSolver set (msflex's block LU, or
// PETSc's LU), no option given with its prefix (-pc_type, -pc_factor_mat_solver_type, read after
// the choice) having named another.
PetscErrorCode BandedLUByStructure(PC pc, bool *answer);
// From the PC's next set-up on, MUMPS factors (LU in its own ordering): where a banded LU, which
// does not pivot between nodes, failed. The factors held are dropped.
PetscErrorCode PCUseMumps(PC pc);

} // namespace msflex
