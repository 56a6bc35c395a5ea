// Reading and validating the YAML model (schema: docs/input.md).
// Nothing here throws: every failure becomes an InputError naming file, line and column.
#pragma once

#include "model/model.hpp"

#include <mpi.h>

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
//
// `comm`: the ranks that read the model together (collective over it; MPI_COMM_SELF, or MPI not
// initialised, reads alone). Rank 0 reads the input file and sends its text to the others; the
// datasets of a mesh file are read in slices of rows, one per rank, which the ranks then share.
// Every rank ends with the same model, or the same failure (a failure on one rank only is reported
// on the others as having happened there).
bool ReadModelFile(const std::string &path, Model *model, InputError *error, MPI_Comm comm = MPI_COMM_SELF);
// Same, from text; `file_label` is the name used in messages and stored as Model::input_file.
bool ReadModelString(const std::string &text, const std::string &file_label, Model *model, InputError *error, MPI_Comm comm = MPI_COMM_SELF);

// The reader's checks of the model against its analysis type (a mechanism free to move as a rigid
// body cannot be solved in statics; a follower load has no place in a symmetric eigenproblem), for
// an analysis type or preload that an option changed after reading (-analysis_type, -analysis_preload).
// Returns false and fills *error when the model fails them. Never throws.
bool CheckModelForAnalysisType(const Model &model, AnalysisType type, bool preload, InputError *error);

// The reader's checks of the analysis settings that refer to the rest of the model (the node DOF
// or joint coordinate of displacement control), for settings changed after reading (options).
// Returns false and fills *error when they fail. Never throws.
bool CheckAnalysisSettings(const Model &model, InputError *error);
// ux uy uz rx ry rz (a node's DOF) or tx ty tz rx ry rz (a joint's coordinate) -> 0..5; else -1.
int PathControlDof(const std::string &name);
// "" when `name` (a control_dof) fits what is controlled (a joint: tx ty tz rx ry rz; a node: ux uy
// uz rx ry rz), else why not: a joint's ux drove its translation along a1 without a word.
std::string PathControlDofMismatch(const std::string &name, bool joint);

} // namespace msflex
