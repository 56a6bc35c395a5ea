// Reading and validating the YAML model (schema: docs/input.md).
// Nothing here throws: every failure becomes an InputError naming file, line and column.
#pragma once

#include "model/model.hpp"

#include <string>

namespace msflex {

struct InputError {
  std::string file;
  int         line   = 0; // 1-based; 0 when unknown
  int         column = 0; // 1-based; 0 when unknown
  std::string message;
  // "file:line:column: error: message"
  std::string Format() const;
};

// Reads, expands (beam lines and arcs into nodes and elements) and validates a model file.
// Returns true on success; on failure returns false and fills *error. Never throws.
bool ReadModelFile(const std::string &path, Model *model, InputError *error);
// Same, from text; `file_label` is the name used in messages and stored as Model::input_file.
bool ReadModelString(const std::string &text, const std::string &file_label, Model *model, InputError *error);

} // namespace msflex
