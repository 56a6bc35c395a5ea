#include "app/command_line.hpp"

#include "core/errors.hpp"
#include "model/analysis_types.hpp"
#include "model/joint_kinds.hpp"
#include "model/model.hpp"
#include "schemes/time_scheme.hpp"

#include <petscsnes.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <strings.h>
#include <vector>

namespace msflex {

namespace {

// The list: settings.cpp and partition.cpp read these names and take their descriptions from
// here (OptionDescription), so an option read without an entry aborts every run.
const OptionInfo kOptions[] = {
    {"-analysis_type", "TYPE", "analysis type: static, dynamic, modes or buckling (msflex -h describes them)"},
    {"-analysis_integrator", "NAME", "time integrator of a dynamic analysis: newmark, genalpha, mc or em"},
    {"-analysis_spectral_radius", "R", "rho_infinity of genalpha, in [0, 1]"},
    {"-analysis_em_correction", "resultants|forces", "em's correction vector: resultants (N_d, M_d) or forces (N_d, 0)"},
    {"-analysis_reactions", "consistent|scheme", "dynamics' reactions: from the accelerations of each converged state, or the scheme's own"},
    {"-analysis_end_time", "T", "final time (dynamics) or load factor (statics)"},
    {"-analysis_initial_step", "DT", "first step size"},
    {"-analysis_min_step", "DT", "smallest step before the run gives up"},
    {"-analysis_max_step", "DT", "largest step"},
    {"-analysis_growth_factor", "F", "step growth after easy steps, >= 1"},
    {"-analysis_easy_iterations", "N", "Newton iterations of an easy step"},
    {"-analysis_easy_steps_to_grow", "N", "easy steps in a row before the step grows"},
    {"-analysis_max_newton_iterations", "N", "Newton iterations per step"},
    {"-analysis_step_tolerance", "TOL", "dynamics: local error per step relative to its motion (0: no error control)"},
    {"-analysis_max_rotation_increment", "RAD", "largest nodal rotation per step, in (0, pi)"},
    {"-analysis_newton_rtol", "TOL", "Newton relative residual tolerance"},
    {"-analysis_newton_atol", "TOL", "Newton absolute residual tolerance"},
    {"-analysis_jacobian_reuse", "F", "keep the factored tangent while each iteration cuts the residual by F, in [0, 1); 0: off"},
    {"-analysis_condensation_depth", "N",
     "dynamics, statics without stability: a relay node every N joints down a chain of joints (linear time); 0: condense whole chains"},
    {"-analysis_linear_solver", "direct|multigrid", "Newton's linear solver: a direct factorisation, or GMRES with algebraic multigrid (large networks)"},
    {"-analysis_direct_solver", "auto|mumps",
     "direct factorisation: auto picks by the tangent (one rank: dense LU for small models, a banded LU - msflex's block LU or PETSc's - "
     "for banded ones; MUMPS otherwise and after a failed solve); mumps: MUMPS always"},
    {"-analysis_output_times", "T1,T2,...", "times the steps must land on (replaces the input's list)"},
    {"-analysis_control", "NAME", "path control of a static analysis: load, arc_length or displacement"},
    {"-analysis_arc_length_psi", "PSI", "weight of the load factor in the arc-length constraint (0: cylindrical)"},
    {"-analysis_desired_iterations", "N", "corrector iterations the arc length aims at"},
    {"-analysis_max_steps", "N", "steps before an arc-length run stops"},
    {"-analysis_control_node", "NODE", "node of displacement control"},
    {"-analysis_control_joint", "JOINT", "joint of displacement control"},
    {"-analysis_control_dof", "DOF", "DOF (ux..rz) or joint coordinate (tx..rz) of displacement control"},
    {"-analysis_control_value", "V", "controlled coordinate per unit pseudo-time"},
    {"-analysis_stability", "", "negative pivots and critical points of the static path"},
    {"-analysis_eigenvalues", "N", "eigenvalues of a modes or buckling analysis"},
    {"-analysis_shift", "S", "shift of shift-and-invert for modes, (rad/s)^2"},
    {"-analysis_preload", "", "eigenanalysis about the static equilibrium at end_time"},
    {"-analysis_static_stage", "", "dynamic analyses: static equilibrium under the loads at t = 0 first"},
    {"-analysis_static_stage_steps", "N", "load steps of the static stage"},
    {"-analysis_initial_velocities", "projected|given", "initial velocities projected on the joints and drives, or as given"},
    {"-output_file", "FILE.h5", "result file (default: the input's output.file, or <input name>.h5)"},
    {"-output_every", "N", "write a frame every N-th converged step"},
    {"-output_overwrite", "", "replace an existing result file"},
    {"-output_xdmf", "xdmf3|xdmf2", "syntax of the .xmf sidecar: xdmf3 (ParaView's default readers) or xdmf2 (ParaView's XDMF Reader, VisIt)"},
    {"-output_flush_interval", "S", "seconds of wall time between flushes of the result file (default 10; 0: every frame and row)"},
    {"-file_read_timeout", "S",
     "seconds a read of an existing file's text attributes may take before the run stops (a damaged file; default 30, at most 86400)"},
    {"-progress_every", "N", "a progress line every N steps"},
    {"-progress_interval", "S", "at most one progress line per S seconds of wall time (0: no limit)"},
    {"-quiet", "", "no progress lines and no summary"},
    {"-checkpoint_every", "N", "converged steps between checkpoints (0: none)"},
    {"-checkpoint_wall_time", "S", "seconds of wall time between checkpoints (0: none)"},
    {"-checkpoint_file", "FILE", "checkpoint file (default: <output>.ckpt.h5)"},
    {"-partitioner", "metis|simple", "node partitioning over MPI ranks (default: metis on more than one rank)"},
};

// Options read by PETSc only in PetscFinalize, after the check of what is left: not unused.
const char *const kReadAtFinalize[] = {"log_view",    "log_view_memory", "log_view_gpu_time", "log_all",      "log_trace",    "memory_view",
                                       "malloc_dump", "malloc_view",     "options_view",      "options_left", "objects_dump", "citations"};

// msflex's prefixes, as normalised names (no dash, '_' for '-').
const char *const kPrefixes[] = {"analysis_", "output_", "checkpoint_", "partition", "progress", "quiet", "restart"};

std::string Normalise(const std::string &name)
{
  size_t start = 0;
  while (start < name.size() && name[start] == '-') ++start;
  std::string out = name.substr(start);
  for (char &c : out) c = c == '-' ? '_' : (char)std::tolower((unsigned char)c);
  return out;
}

// The name as the user typed it: PETSc stores "-name" as "name" and "--name" as "-name".
std::string Typed(const char *stored) { return std::string("-") + stored; }

bool IsRestartOption(const std::string &normalised) { return normalised == "restart"; }

// An msflex option spelt exactly (PETSc names are case-insensitive): read later in the run
// (-partitioner, at set-up) or not at all by this kind of run; never a misspelling.
bool IsListedOption(const std::string &typed)
{
  for (const OptionInfo &option : kOptions)
    if (strcasecmp(option.name, typed.c_str()) == 0) return true;
  return false;
}

bool ReadAtFinalize(const std::string &normalised)
{
  for (const char *name : kReadAtFinalize)
    if (normalised == name) return true;
  return false;
}

} // namespace

const OptionInfo *MsflexOptions(int *count)
{
  *count = (int)(sizeof(kOptions) / sizeof(kOptions[0]));
  return kOptions;
}

const char *OptionDescription(const char *name)
{
  for (const OptionInfo &option : kOptions)
    if (std::strcmp(option.name, name) == 0) return option.description;
  fprintf(stderr, "msflex: internal error: option %s is read but not in the option list (src/app/command_line.cpp)\n", name);
  std::abort();
}

int OptionNameDistance(const std::string &a_name, const std::string &b_name)
{
  const std::string a = Normalise(a_name), b = Normalise(b_name);
  const size_t      n = a.size(), m = b.size();
  std::vector<int>  d((n + 1) * (m + 1));
  auto              at = [m, &d](size_t i, size_t j) -> int              &{ return d[i * (m + 1) + j]; };
  for (size_t i = 0; i <= n; ++i) at(i, 0) = (int)i;
  for (size_t j = 0; j <= m; ++j) at(0, j) = (int)j;
  for (size_t i = 1; i <= n; ++i)
    for (size_t j = 1; j <= m; ++j) {
      at(i, j) = std::min({at(i - 1, j) + 1, at(i, j - 1) + 1, at(i - 1, j - 1) + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) at(i, j) = std::min(at(i, j), at(i - 2, j - 2) + 1);
    }
  return at(n, m);
}

const OptionInfo *NearestOption(const std::string &name, int *distance)
{
  const OptionInfo *best = nullptr;
  *distance              = 1 << 30;
  for (const OptionInfo &option : kOptions) {
    const int d = OptionNameDistance(name, option.name);
    if (d < *distance) {
      *distance = d;
      best      = &option;
    }
  }
  return best;
}

bool LooksLikeMsflexOption(const std::string &name)
{
  const std::string normalised = Normalise(name);
  for (const char *prefix : kPrefixes)
    if (normalised.compare(0, std::strlen(prefix), prefix) == 0) return true;
  int distance;
  NearestOption(name, &distance);
  return distance <= 2;
}

std::string DescribeBadOptionValue()
{
  // The kind of value an option takes, from its argument in the list.
  enum class Kind { Flag, Integer, Real, Reals, Choice, Text };
  const auto kind_of = [](const char *argument) {
    if (!argument[0]) return Kind::Flag;
    if (std::strchr(argument, '|')) return Kind::Choice; // "metis|simple"
    if (std::strcmp(argument, "N") == 0) return Kind::Integer;
    if (std::strcmp(argument, "T1,T2,...") == 0) return Kind::Reals;
    for (const char *real : {"T", "DT", "F", "RAD", "TOL", "S", "PSI", "V", "R"})
      if (std::strcmp(argument, real) == 0) return Kind::Real;
    return Kind::Text; // names and choices: their readers say which are valid
  };
  // Conversions report through PETSc's error handler: returned quietly, not printed.
  const auto reads = [](PetscErrorCode (*convert)(const char *, void *), const std::string &text, void *value) {
    if (PetscPushErrorHandler(PetscReturnErrorHandler, nullptr) != PETSC_SUCCESS) return false;
    const PetscErrorCode status = convert(text.c_str(), value);
    (void)PetscPopErrorHandler();
    return status == PETSC_SUCCESS;
  };
  const auto real    = [](const char *s, void *v) { return PetscOptionsStringToReal(s, static_cast<PetscReal *>(v)); };
  const auto integer = [](const char *s, void *v) { return PetscOptionsStringToInt(s, static_cast<PetscInt *>(v)); };
  const auto logical = [](const char *s, void *v) { return PetscOptionsStringToBool(s, static_cast<PetscBool *>(v)); };
  for (const OptionInfo &option : kOptions) {
    const Kind  kind = kind_of(option.argument);
    const char *raw  = nullptr;
    PetscBool   set  = PETSC_FALSE;
    if (PetscOptionsFindPair(nullptr, nullptr, option.name, &raw, &set) != PETSC_SUCCESS || !set) continue;
    // (Names and files too: -checkpoint_file alone said "the checkpoint file name is empty".)
    if (!raw && kind != Kind::Flag) return std::string(option.name) + " needs a value (" + option.argument + ")";
    if (kind == Kind::Text) continue;
    const std::string text = raw ? raw : "";
    const std::string head = std::string(option.name) + ": '" + text + "' ";
    PetscReal         r;
    PetscInt          n;
    PetscBool         b;
    switch (kind) {
    case Kind::Flag:
      if (!text.empty() && !reads(logical, text, &b)) return head + "is not a logical value (true/false, yes/no, 1/0, or no value)";
      break;
    case Kind::Integer: {
      if (!reads(integer, text, &n)) return head + "is not an integer";
      // PetscOptionsStringToInt wraps a value past 32 bits (99999999999 read as 1215752191).
      errno                   = 0;
      char           *end     = nullptr;
      const long long decimal = std::strtoll(text.c_str(), &end, 10);
      if (end && *end == '\0' && (errno == ERANGE || decimal > std::numeric_limits<int>::max() || decimal < std::numeric_limits<int>::min()))
        return head + "is out of range (integers here lie within +-" + std::to_string(std::numeric_limits<int>::max()) + ")";
      break;
    }
    case Kind::Real:
      if (!reads(real, text, &r)) return head + "is not a number";
      break;
    case Kind::Reals:
      for (size_t start = 0; start <= text.size();) {
        const size_t end = std::min(text.find(',', start), text.size());
        if (!reads(real, text.substr(start, end - start), &r)) return head + "is not a comma-separated list of numbers";
        start = end + 1;
      }
      break;
    case Kind::Choice: {
      std::vector<std::string> choices;
      for (const char *c = option.argument; *c;) {
        const char *bar = std::strchr(c, '|');
        choices.emplace_back(c, bar ? (size_t)(bar - c) : std::strlen(c));
        c = bar ? bar + 1 : c + std::strlen(c);
      }
      if (std::none_of(choices.begin(), choices.end(), [&](const std::string &c) { return strcasecmp(c.c_str(), text.c_str()) == 0; })) {
        std::string list;
        for (size_t i = 0; i < choices.size(); ++i) list += (i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + choices[i];
        return std::string(option.name) + " must be " + list + ", got '" + text + "'";
      }
      break;
    }
    case Kind::Text:
      break;
    }
  }
  return "";
}

std::string StrayArgument(int argc, char **argv, bool restart)
{
  // A negative number is a value, not an option.
  const auto is_option    = [](const char *word) { return word[0] == '-' && !(std::isdigit((unsigned char)word[1]) || word[1] == '.'); };
  bool       after_option = false, input_seen = restart;
  for (int i = 1; i < argc; ++i) {
    if (is_option(argv[i])) after_option = true;
    else if (after_option) after_option = false; // the option's value (--restart's too)
    else if (!input_seen) input_seen = true;     // the input file
    else return argv[i];
  }
  return "";
}

std::string NearestLongArgument(const std::string &word)
{
  for (const char *name : {"--help", "--version", "--restart"})
    if (OptionNameDistance(word, name) <= 2) return name;
  return "";
}

std::string HelpText()
{
  std::string text = "msflex: flexible mechanisms of geometrically exact beams.\n\n"
                     "Usage: msflex INPUT.yaml [options]\n"
                     "       msflex --restart CHECKPOINT.h5 [options]   continue a run from its checkpoint\n"
                     "       msflex -h | --help                       this help\n"
                     "       msflex --version                         the version and git commit\n"
                     "       msflex INPUT.yaml -help                  run, listing every option as the run reads it (PETSc's too)\n\n"
                     "msflex options (the input's values are the defaults; docs/options.md):\n";
  for (const OptionInfo &option : kOptions) {
    std::string left = std::string("  ") + option.name + (option.argument[0] ? std::string(" ") + option.argument : std::string());
    left.resize(std::max<size_t>(left.size() + 1, 42), ' ');
    text += left + option.description + "\n";
  }
  text += "A misspelt msflex option is an error; an option nothing reads is reported at the end of the run.\n"
          "Solver options (-snes_*, -ksp_*, -pc_*, -eps_*) are PETSc's and SLEPc's; the default is Newton with a safeguarded step and the\n"
          "direct LU that -analysis_direct_solver auto picks (docs/solvers.md).\n";
  int  count;
  auto column = [](const char *name, size_t width) { return std::string("  ") + name + std::string(width - std::min(width - 1, std::strlen(name)), ' '); };
  text += "\nAnalysis types (analysis.type, -analysis_type):\n";
  for (const AnalysisTypeInfo *info = AnalysisTypes(&count), *end = info + count; info != end; ++info)
    text += column(info->name, 14) + info->description + "\n";
  text += "Path controls of static analyses (analysis.control, -analysis_control):\n";
  for (const PathControlInfo *info = PathControls(&count), *end = info + count; info != end; ++info) text += column(info->name, 14) + info->description + "\n";
  text += "Integrators (analysis.integrator, -analysis_integrator):\n";
  for (const IntegratorInfo *info = Integrators(&count), *end = info + count; info != end; ++info) text += column(info->name, 14) + info->description + "\n";
  text += "Joint kinds (joints: type):\n";
  for (const JointKindInfo *info = JointKinds(&count), *end = info + count; info != end; ++info) text += column(info->name, 14) + info->description + "\n";
  return text;
}

PetscErrorCode CheckMsflexOptionsUsed(MPI_Comm comm)
{
  PetscInt    count;
  char      **names, **values;
  std::string message;
  PetscFunctionBeginUser;
  PetscCall(PetscOptionsLeftGet(nullptr, &count, &names, &values));
  for (PetscInt i = 0; i < count; ++i) {
    const std::string typed = Typed(names[i]);
    if (IsRestartOption(Normalise(typed)) || IsListedOption(typed) || !LooksLikeMsflexOption(typed)) continue;
    int               distance;
    const OptionInfo *nearest = NearestOption(typed, &distance);
    message += std::string(message.empty() ? "" : "; ") + "unknown option " + typed + "; did you mean " + nearest->name + "?";
  }
  PetscCall(PetscOptionsLeftRestore(nullptr, &count, &names, &values));
  PetscCheck(message.empty(), comm, PETSC_ERR_USER_INPUT, "%s (msflex -h lists the options)", message.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

// A factorisation's ordering option (-pc_factor_mat_ordering_type) names a registered ordering:
// PETSc takes any name and fails inside the first factorisation, with a trace.
static PetscErrorCode CheckOrderingOption(MPI_Comm comm, const char *prefix)
{
  char      name[256];
  PetscBool set;
  PetscFunctionBeginUser;
  PetscCall(PetscOptionsGetString(nullptr, prefix, "-pc_factor_mat_ordering_type", name, sizeof name, &set));
  if (!set) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MatInitializePackage());
  PetscErrorCode (*ordering)(Mat, MatOrderingType, IS *, IS *) = nullptr;
  PetscCall(PetscFunctionListFind(MatOrderingList, name, &ordering));
  PetscCheck(ordering, comm, PETSC_ERR_USER_INPUT,
             "bad option: -%spc_factor_mat_ordering_type: no ordering named '%s' (natural, nd, 1wd, rcm, qmd, rowlength, ...)", prefix ? prefix : "", name);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CheckSolverOptions(MPI_Comm comm, const AnalysisSettings &analysis)
{
  SNES      snes;
  KSP       ksp, path_ksp;
  PC        pc;
  Mat       jacobian;
  PetscReal atol, rtol, stol;
  PetscInt  max_iterations, max_evaluations;
  PetscFunctionBeginUser;
  // The defaults of src/integrators/newton.cpp (NewtonSolverCreate), so that only what the options
  // change is tried, and -help lists the values the run uses.
  PetscCall(SNESCreate(comm, &snes));
  PetscCall(SNESSetType(snes, SNESNEWTONLS));
  PetscCall(SNESSetTolerances(snes, analysis.newton_atol, analysis.newton_rtol, 1e-12, analysis.max_newton_iterations, PETSC_DEFAULT));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPSetType(ksp, KSPPREONLY));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, PCLU));
  MSFLEX_CALL_READING_OPTIONS(comm, SNESSetFromOptions(snes));
  // PETSc takes negative tolerances and iteration limits, and fails later ("solver returned
  // without setting converged reason", a trace) or never converges.
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &max_iterations, &max_evaluations));
  PetscCall(SNESDestroy(&snes));
  PetscCheck(max_iterations >= 1, comm, PETSC_ERR_USER_INPUT, "bad option: -snes_max_it must be at least 1, got %" PetscInt_FMT, max_iterations);
  const struct {
    const char *name;
    PetscReal   value;
  } tolerances[] = {{"-snes_atol", atol}, {"-snes_rtol", rtol}, {"-snes_stol", stol}};
  for (const auto &tolerance : tolerances)
    PetscCheck(tolerance.value >= 0.0, comm, PETSC_ERR_USER_INPUT, "bad option: %s must not be negative, got %.6g", tolerance.name, (double)tolerance.value);
  for (const char *prefix : {(const char *)nullptr, "path_"}) PetscCall(CheckOrderingOption(comm, prefix));
  PetscCall(MatCreate(comm, &jacobian));
  PetscCall(MatSetSizes(jacobian, PETSC_DECIDE, PETSC_DECIDE, 1, 1));
  PetscCall(MatSetOptionsPrefix(jacobian, "jacobian_"));
  MSFLEX_CALL_READING_OPTIONS(comm, MatSetFromOptions(jacobian));
  PetscCall(MatDestroy(&jacobian));
  PetscCall(KSPCreate(comm, &path_ksp));
  PetscCall(KSPSetOptionsPrefix(path_ksp, "path_"));
  MSFLEX_CALL_READING_OPTIONS(comm, KSPSetFromOptions(path_ksp));
  PetscCall(KSPDestroy(&path_ksp));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode WarnOptionsLeft(MPI_Comm comm)
{
  PetscInt count;
  char   **names, **values;
  PetscFunctionBeginUser;
  PetscCall(PetscOptionsLeftGet(nullptr, &count, &names, &values));
  for (PetscInt i = 0; i < count; ++i) {
    const std::string typed = Typed(names[i]), normalised = Normalise(typed);
    if (IsRestartOption(normalised) || ReadAtFinalize(normalised)) continue;
    PetscCall(
        PetscFPrintf(comm, PETSC_STDERR, "msflex: warning: option %s%s%s was not used\n", typed.c_str(), values[i] ? " " : "", values[i] ? values[i] : ""));
  }
  PetscCall(PetscOptionsLeftRestore(nullptr, &count, &names, &values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
