#include "model/analysis_types.hpp"

namespace msflex {

namespace {
const AnalysisTypeInfo kAnalysisTypes[] = {
    {"static", AnalysisType::Static, "equilibrium under loads and prescribed motions scaled by functions of a pseudo-time (the load factor)"},
    {"dynamic", AnalysisType::Dynamic, "motion in time with the integrator named by 'integrator'"},
    {"modes", AnalysisType::Modes, "natural frequencies and mode shapes (SLEPc), about the reference or a preloaded static equilibrium"},
    {"buckling", AnalysisType::Buckling, "linearised buckling load factors and modes (SLEPc) of the loads at the reference or a preloaded equilibrium"},
};

const PathControlInfo kPathControls[] = {
    {"load", PathControl::Load, "the steps advance the load factor (pseudo-time); Newton stops at a limit point"},
    {"arc_length", PathControl::ArcLength, "Crisfield's arc length: the load factor is an unknown, the steps advance the length of the path"},
    {"displacement", PathControl::Displacement, "one node DOF or joint coordinate follows control_value * t; the load factor is an unknown"},
};
} // namespace

const AnalysisTypeInfo *AnalysisTypes(int *count)
{
  *count = (int)(sizeof(kAnalysisTypes) / sizeof(kAnalysisTypes[0]));
  return kAnalysisTypes;
}

bool AnalysisTypeFromName(const std::string &name, AnalysisType *type)
{
  for (const AnalysisTypeInfo &info : kAnalysisTypes)
    if (name == info.name) {
      *type = info.type;
      return true;
    }
  return false;
}

const char *AnalysisTypeName(AnalysisType type)
{
  for (const AnalysisTypeInfo &info : kAnalysisTypes)
    if (info.type == type) return info.name;
  return "?";
}

std::string AnalysisTypeNameList()
{
  std::string list;
  for (const AnalysisTypeInfo &info : kAnalysisTypes) list += (list.empty() ? "" : ", ") + std::string(info.name);
  return list;
}

const PathControlInfo *PathControls(int *count)
{
  *count = (int)(sizeof(kPathControls) / sizeof(kPathControls[0]));
  return kPathControls;
}

bool PathControlFromName(const std::string &name, PathControl *control)
{
  for (const PathControlInfo &info : kPathControls)
    if (name == info.name) {
      *control = info.control;
      return true;
    }
  return false;
}

const char *PathControlName(PathControl control)
{
  for (const PathControlInfo &info : kPathControls)
    if (info.control == control) return info.name;
  return "?";
}

std::string PathControlNameList()
{
  std::string list;
  for (const PathControlInfo &info : kPathControls) list += (list.empty() ? "" : ", ") + std::string(info.name);
  return list;
}

bool LinearSolverKindFromName(const std::string &name, LinearSolverKind *kind)
{
  if (name != "direct" && name != "multigrid") return false;
  *kind = name == "direct" ? LinearSolverKind::Direct : LinearSolverKind::Multigrid;
  return true;
}

const char *LinearSolverKindName(LinearSolverKind kind) { return kind == LinearSolverKind::Direct ? "direct" : "multigrid"; }

bool DirectSolverChoiceFromName(const std::string &name, DirectSolverChoice *choice)
{
  if (name != "auto" && name != "mumps") return false;
  *choice = name == "auto" ? DirectSolverChoice::Auto : DirectSolverChoice::Mumps;
  return true;
}

const char *DirectSolverChoiceName(DirectSolverChoice choice) { return choice == DirectSolverChoice::Auto ? "auto" : "mumps"; }

bool ReactionPointFromName(const std::string &name, ReactionPoint *point)
{
  if (name == "consistent") *point = ReactionPoint::Consistent;
  else if (name == "scheme") *point = ReactionPoint::Scheme;
  else return false;
  return true;
}

const char *ReactionPointName(ReactionPoint point) { return point == ReactionPoint::Consistent ? "consistent" : "scheme"; }

} // namespace msflex
