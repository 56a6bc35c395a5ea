// The registry of analysis types: the one place that names them, read by the input reader, the
// options, -help and the documentation test.
#pragma once

#include <string>

namespace msflex {

enum class AnalysisType { Static, Dynamic, Modes, Buckling };

struct AnalysisTypeInfo {
  const char  *name;
  AnalysisType type;
  const char  *description;
};

const AnalysisTypeInfo *AnalysisTypes(int *count);
// Parses a registered name; false for anything else.
bool        AnalysisTypeFromName(const std::string &name, AnalysisType *type);
const char *AnalysisTypeName(AnalysisType type);
// "static, dynamic": the registered names, for messages.
std::string AnalysisTypeNameList();
// Eigenanalyses (modes, buckling): one eigenvalue problem about the reference configuration or
// about a static equilibrium computed first (app/run_eigen.cpp), no step loop of their own.
inline bool IsEigenAnalysis(AnalysisType type) { return type == AnalysisType::Modes || type == AnalysisType::Buckling; }
// Analyses that need a static equilibrium to exist: the statics' mechanism check applies.
inline bool NeedsStaticStiffness(AnalysisType type, bool preload)
{
  return type == AnalysisType::Static || type == AnalysisType::Buckling || (type == AnalysisType::Modes && preload);
}

// Where a dynamic analysis reports reactions (joints' forces and drive forces, reaction probes):
// from the accelerations that satisfy the equations of motion in each converged state, at its
// time (Consistent), or from the scheme's own equations (Scheme: the step's mid-point in mc and
// em, t_end with the scheme's accelerations in the Newmark family); docs/joints.md.
enum class ReactionPoint { Consistent, Scheme };
// "consistent" or "scheme"; false for anything else.
bool        ReactionPointFromName(const std::string &name, ReactionPoint *point);
const char *ReactionPointName(ReactionPoint point);

// The registry of path-following controls of static analyses (analysis.control): what drives the
// steps and which quantity is the unknown besides the configuration.
enum class PathControl { Load, ArcLength, Displacement };

struct PathControlInfo {
  const char *name;
  PathControl control;
  const char *description;
};

const PathControlInfo *PathControls(int *count);
bool                   PathControlFromName(const std::string &name, PathControl *control);
const char            *PathControlName(PathControl control);
std::string            PathControlNameList();

// How Newton's linear systems are solved (analysis.linear_solver): a sparse direct factorisation,
// or GMRES preconditioned by smoothed-aggregation algebraic multigrid built on the rigid-body modes
// of the nodes (for large beam networks, where the fill of a direct factorisation grows faster
// than the model; docs/solvers.md).
enum class LinearSolverKind { Direct, Multigrid };

bool        LinearSolverKindFromName(const std::string &name, LinearSolverKind *kind);
const char *LinearSolverKindName(LinearSolverKind kind);

// Which direct factorisation solves Newton's systems (analysis.direct_solver; docs/solvers.md):
// `auto` chooses by the tangent's structure (on one rank a tangent banded under reverse
// Cuthill-McKee goes to a banded LU in that order, which does not pivot between nodes: a step on
// which Newton fails with it is tried again with MUMPS, which keeps the rest of the run if it
// converges there; everything else to MUMPS); `mumps` always MUMPS.
// A dense tangent (small models) goes to msflex's dense LU either way.
enum class DirectSolverChoice { Auto, Mumps };

bool        DirectSolverChoiceFromName(const std::string &name, DirectSolverChoice *choice);
const char *DirectSolverChoiceName(DirectSolverChoice choice);

} // namespace msflex
