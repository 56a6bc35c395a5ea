// libFuzzer target for the YAML input reader (built and run by scripts/fuzz-input).
//
// Feeds the fuzzer's bytes to ReadModelString and checks what "bad input never crashes" promises
// beyond the absence of sanitizer reports: the reader returns (no exception escapes, no abort);
// a failure is one located line, "file:line:column: error: message", that is not an internal
// error; and an accepted model only holds indices in range and finite numbers, so that nothing
// downstream can be led astray. A broken promise aborts, which libFuzzer reports as a crash with
// the input that caused it.
//
// MPI is not initialised here: the reader then reads alone (ReaderContext::comm is not used).
#include "io/input_reader.hpp"

#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

// Relative `mesh:` paths resolve against the directory of the label, which does not exist, so the
// fuzzer exercises the mesh-file errors without reading files of the machine.
const std::string kLabel = "/nonexistent-msflex-fuzz/input.yaml";

[[noreturn]] void Broken(const std::string &what, const std::string &detail)
{
  std::fprintf(stderr, "fuzz_input_reader: %s: %s\n", what.c_str(), detail.c_str());
  std::abort();
}

// Inputs that only ask for a big model (`elements: 9999999`: millions of nodes, which the reader
// rightly builds) are skipped: their run time and memory say nothing about robustness. Skipped is
// an input whose integer literals (decimal, or hexadecimal as yaml-cpp also reads them; not the
// digits of a number with a '.' or an exponent) add up to more than kIntegerBudget.
constexpr double kIntegerBudget = 300000;

bool AsksForBigModel(const std::string &text)
{
  const auto word_character = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_'; };
  double     sum            = 0.0;
  for (size_t at = 0; at < text.size();) {
    if (!word_character(text[at])) {
      ++at;
      continue;
    }
    size_t end = at;
    while (end < text.size() && word_character(text[end])) ++end;
    const std::string word = text.substr(at, end - at);
    at                     = end;
    const bool hexadecimal =
        word.size() > 2 && word[0] == '0' && (word[1] == 'x' || word[1] == 'X') && word.find_first_not_of("0123456789abcdefABCDEF", 2) == std::string::npos;
    const bool decimal = word.find_first_not_of("0123456789") == std::string::npos;
    if (!hexadecimal && !decimal) continue;
    double value = 0.0;
    for (size_t k = hexadecimal ? 2 : 0; k < word.size() && value <= kIntegerBudget; ++k)
      value = value * (hexadecimal ? 16 : 10) + (std::isdigit(static_cast<unsigned char>(word[k])) ? word[k] - '0' : std::tolower(word[k]) - 'a' + 10);
    sum += value;
    if (sum > kIntegerBudget) return true;
  }
  return false;
}

bool InRange(int index, size_t size) { return index >= 0 && static_cast<size_t>(index) < size; }

void CheckNodeList(const std::vector<int> &nodes, size_t node_count, const char *what)
{
  for (int node : nodes)
    if (!InRange(node, node_count)) Broken("accepted model", std::string(what) + " refers to node " + std::to_string(node));
}

void CheckFunction(int function, size_t function_count, const char *what)
{
  if (function != -1 && !InRange(function, function_count)) Broken("accepted model", std::string(what) + " refers to function " + std::to_string(function));
}

// What the solver takes for granted of a model the reader accepted.
void CheckModel(const msflex::Model &model)
{
  const size_t nodes = model.nodes.size(), sections = model.sections.size(), functions = model.functions.size();
  if (model.beams.empty() && model.rigid_bodies.empty()) Broken("accepted model", "no beams and no rigid bodies");
  for (const msflex::Node &node : model.nodes)
    if (!node.position.allFinite()) Broken("accepted model", "node '" + node.name + "' has a non-finite position");
  for (const msflex::Section &section : model.sections)
    if (!(section.EA > 0 && section.GA2 > 0 && section.GA3 > 0 && section.GJ > 0 && section.EI2 > 0 && section.EI3 > 0 &&
          std::isfinite(section.EA + section.GA2 + section.GA3 + section.GJ + section.EI2 + section.EI3) && section.rhoA >= 0 && std::isfinite(section.rhoA) &&
          section.rhoJ.allFinite() && (section.rhoJ.array() >= 0).all()))
      Broken("accepted model", "section '" + section.name + "' has a non-positive or non-finite property");
  for (const msflex::BeamElement &element : model.elements) {
    if (!InRange(element.section, sections)) Broken("accepted model", "an element refers to section " + std::to_string(element.section));
    if (!InRange(element.beam, model.beams.size())) Broken("accepted model", "an element refers to beam " + std::to_string(element.beam));
    if (element.order < 1 || element.order > 2) Broken("accepted model", "an element has order " + std::to_string(element.order));
    for (int a = 0; a <= element.order; ++a) {
      if (!InRange(element.nodes[a], nodes)) Broken("accepted model", "an element refers to node " + std::to_string(element.nodes[a]));
      const msflex::Mat3 &triad = element.reference_triads[a];
      if (!triad.allFinite() || (triad.transpose() * triad - msflex::Mat3::Identity()).norm() > 1e-9 || triad.determinant() < 0)
        Broken("accepted model", "an element has a reference triad that is not a rotation");
    }
    if ((model.nodes[element.nodes[0]].position - model.nodes[element.nodes[element.order]].position).norm() == 0.0)
      Broken("accepted model", "an element has zero length");
  }
  for (const msflex::Beam &beam : model.beams) {
    CheckNodeList(beam.nodes, nodes, "a beam");
    for (int element : beam.elements)
      if (!InRange(element, model.elements.size())) Broken("accepted model", "beam '" + beam.name + "' refers to element " + std::to_string(element));
  }
  for (const msflex::NodeSet &set : model.node_sets) CheckNodeList(set.nodes, nodes, "a set");
  for (const msflex::Support &support : model.supports) {
    CheckNodeList(support.nodes, nodes, "a support");
    CheckFunction(support.function, functions, "a support");
    for (double value : support.values)
      if (!std::isfinite(value)) Broken("accepted model", "a support prescribes a non-finite value");
  }
  for (const msflex::NodalLoad &load : model.nodal_loads) {
    CheckNodeList(load.nodes, nodes, "a nodal load");
    CheckFunction(load.function, functions, "a nodal load");
    if (!load.force.allFinite() || !load.moment.allFinite()) Broken("accepted model", "a nodal load is not finite");
  }
  for (const msflex::DistributedLoad &load : model.distributed_loads) {
    for (int element : load.elements)
      if (!InRange(element, model.elements.size())) Broken("accepted model", "a distributed load refers to element " + std::to_string(element));
    CheckFunction(load.function, functions, "a distributed load");
    if (!load.force_per_length.allFinite()) Broken("accepted model", "a distributed load is not finite");
  }
  for (const msflex::Probe &probe : model.probes)
    if (!InRange(probe.node, nodes)) Broken("accepted model", "probe '" + probe.name + "' refers to node " + std::to_string(probe.node));
  for (const msflex::RigidBody &body : model.rigid_bodies)
    if (!InRange(body.node, nodes) || !(body.mass > 0) || !std::isfinite(body.mass) || !body.inertia.allFinite() || !body.offset.allFinite())
      Broken("accepted model", "a rigid body has a bad node, mass, inertia or offset");
  for (const msflex::InitialCondition &condition : model.initial_conditions) {
    CheckNodeList(condition.nodes, nodes, "an initial condition");
    if (!condition.velocity.allFinite() || !condition.angular_velocity.allFinite() || !condition.center.allFinite())
      Broken("accepted model", "an initial condition is not finite");
  }
  std::vector<int> slave_of(nodes, 0);
  for (const msflex::Joint &joint : model.joints) {
    if (!(joint.master == -1 || InRange(joint.master, nodes)) || !InRange(joint.slave, nodes) || joint.master == joint.slave)
      Broken("accepted model", "joint '" + joint.name + "' has a bad master or slave");
    if (++slave_of[joint.slave] > 1) Broken("accepted model", "a node is the slave of two joints");
    if (!joint.axes.allFinite() || (joint.axes.transpose() * joint.axes - msflex::Mat3::Identity()).norm() > 1e-9 || joint.axes.determinant() < 0)
      Broken("accepted model", "joint '" + joint.name + "' has axes that are not a rotation");
    CheckFunction(joint.drive_function, functions, "a joint drive");
    if (!std::isfinite(joint.coefficient) || !std::isfinite(joint.drive_value)) Broken("accepted model", "joint '" + joint.name + "' is not finite");
  }
  const msflex::AnalysisSettings &analysis = model.analysis;
  if (!(analysis.end_time > 0 && analysis.initial_step > 0 && analysis.min_step > 0 && analysis.max_step > 0 && analysis.newton_rtol > 0 &&
        analysis.newton_atol >= 0 && analysis.jacobian_reuse >= 0 && analysis.jacobian_reuse < 1 && analysis.condensation_depth >= 0 &&
        analysis.growth_factor >= 1 && analysis.min_step <= analysis.initial_step && analysis.initial_step <= analysis.max_step &&
        std::isfinite(analysis.end_time + analysis.max_step + analysis.growth_factor)))
    Broken("accepted model", "bad analysis settings");
  if (model.output.every < 1 || model.output.file.empty()) Broken("accepted model", "bad output settings");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  const std::string text(reinterpret_cast<const char *>(data), size);
  if (AsksForBigModel(text)) return -1; // not added to the corpus
  msflex::Model      model;
  msflex::InputError error;
  if (msflex::ReadModelString(text, kLabel, &model, &error)) {
    CheckModel(model);
    return 0;
  }
  const std::string line = error.Format();
  if (error.file != kLabel) Broken("message names another file", line);
  if (error.line <= 0 || error.column <= 0) Broken("message without line and column", line);
  if (error.message.empty()) Broken("empty message", line);
  if (line.find_first_of("\n\r") != std::string::npos) Broken("message of more than one line", line);
  // An exception other than the reader's own and yaml-cpp's (ReadModelString's last resort).
  if (error.message.rfind("internal error while reading the input", 0) == 0) Broken("internal error", line);
  return 0;
}
