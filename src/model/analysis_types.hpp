// The registry of analysis types: the one place that names them, read by the input reader, the
// options, -help and the documentation test.
#pragma once

#include <string>

namespace msflex {

enum class AnalysisType { Static, Dynamic };

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

} // namespace msflex
