#include "model/analysis_types.hpp"

namespace msflex {

namespace {
const AnalysisTypeInfo kAnalysisTypes[] = {
    {"static", AnalysisType::Static, "equilibrium under loads and prescribed motions scaled by functions of a pseudo-time (the load factor)"},
    {"dynamic", AnalysisType::Dynamic, "motion in time with the integrator named by 'integrator'"},
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

} // namespace msflex
