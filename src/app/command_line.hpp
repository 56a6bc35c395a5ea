// The command line: the one list of msflex's own options (name, argument, description), from
// which -h/--help, the descriptions of -help and the check of misspelt options are all built;
// and the checks of what the command line left unused (docs/options.md, "Checking options").
#pragma once

#include <petscsys.h>

#include <string>

namespace msflex {

struct AnalysisSettings;

struct OptionInfo {
  const char *name;        // with its dash: "-analysis_end_time"
  const char *argument;    // "" for a flag
  const char *description; // one line
};

// Every option msflex itself reads (PETSc's and SLEPc's are theirs), in the order of the help.
const OptionInfo *MsflexOptions(int *count);

// The description of the msflex option `name` (with its prefix and dash). An option that is not
// in the list is a programming error: it aborts, so that the list cannot fall behind the code.
const char *OptionDescription(const char *name);

// Optimal-string-alignment distance (insertions, deletions, substitutions and transpositions of
// neighbours, each 1), case-insensitive, between option names with their leading dashes dropped
// and '-' read as '_'.
int OptionNameDistance(const std::string &a, const std::string &b);

// The msflex option nearest to `name` and its distance.
const OptionInfo *NearestOption(const std::string &name, int *distance);

// Whether an option that nothing read looks like one of msflex's: it starts with one of msflex's
// prefixes (-analysis_, -output_, -checkpoint_, -partition, -progress, -quiet, -restart, also
// spelt with '-') or is within two edits of an msflex option.
bool LooksLikeMsflexOption(const std::string &name);

// The msflex option whose value the command line gives in a form its kind does not take (a real,
// an integer, a logical value, a list of reals), as a line naming the option and the value:
// "-analysis_end_time: 'abc' is not a number"; empty when every value reads. For the
// message of a failed read of the settings (PETSc's own names the value alone).
std::string DescribeBadOptionValue();

// A word of the command line that is neither the input file (the first word, without --restart),
// an option nor an option's value (the word after an option): "msflex a.yaml b.yaml", or an input
// given to a restart, which takes its input from the checkpoint. Empty when there is none.
std::string StrayArgument(int argc, char **argv, bool restart);

// For a word starting with "--" that msflex does not know: the nearest of --help, --version,
// --restart within two edits ("--verison": "--version"), else empty.
std::string NearestLongArgument(const std::string &word);

// msflex's help: usage, the options and the registered choices (analysis types, path controls,
// integrators, joint kinds).
std::string HelpText();

// Set-up is over and msflex's options are read: every option nothing read that looks like
// msflex's is an error (PETSC_ERR_USER_INPUT) naming the nearest msflex option. Collective.
PetscErrorCode CheckMsflexOptionsUsed(MPI_Comm comm);

// Before anything is written: the values of the solver options that PETSc objects read (-snes_*,
// -ksp_*, -pc_*, -jacobian_mat_*, -path_ksp_*, -path_pc_*), tried on throw-away objects set up
// with the analysis' Newton tolerances (so that -help lists the values the run uses), so that a
// bad one (a negative tolerance or iteration limit, an unknown ordering included) is one line and
// exit 1 before a result file exists. Collective.
PetscErrorCode CheckSolverOptions(MPI_Comm comm, const AnalysisSettings &analysis);

// The end of a run: one warning line on rank 0 for every option nothing read. Collective.
PetscErrorCode WarnOptionsLeft(MPI_Comm comm);

} // namespace msflex
