// The units and descriptions of everything the result file holds, in one place: every dataset of
// /mesh, /frames and /history gets them as its `unit` and `description` attributes, every column
// of the history table its entry of /history/units and /history/descriptions (docs/output.md),
// and the XDMF sidecar puts the unit into the array names ParaView shows ("displacement [m]").
//
// Units are SI strings: "m", "rad", "m/s", "rad/s", "N", "N m", "J", "W", "s", "Hz", "kg",
// "kg m^2", "kg m/s", "kg m^2/s", "(rad/s)^2", "1" for dimensionless numbers, counts and indices,
// "" for text. A dataset whose columns differ in unit lists one unit per column, separated by ", "
// ("N, N, N, N m, N m, N m"); "mixed" marks a single number that adds quantities of different
// units; "N or N m" a generalised force whose unit is that of its coordinate (N on a translation,
// N m on a rotation), which the series' name does not tell.
#pragma once

#include "model/analysis_types.hpp"

#include <string>

namespace msflex {

struct Quantity {
  std::string unit;
  std::string description;
};

// A dataset of the root, /mesh, /frames or /history (`group` "", "mesh", "frames" or "history",
// `name` the dataset's name there). `analysis` sets what time is: s in dynamics; in statics the
// pseudo-time (the load factor under load control), 1; in an eigenanalysis (modes, buckling) the
// mode number, 1. Unknown names give an empty unit and description.
Quantity DatasetQuantity(const std::string &group, const std::string &name, AnalysisType analysis);

// A history series, from its name: the fixed series (time, step, energies, momenta, path following,
// modes, ...) and the series "<name>.<suffix>" of joints, force elements and probes of kind
// reaction or beam, by suffix (a suffix that two kinds write has the same unit in both, and its
// description names both meanings): joints' "<joint>.tx".."<joint>.rz" (m, rad) and "<joint>.tx_rate".. (per s, or per
// unit pseudo-time in statics); "<name>.force_x".."<name>.moment_z" (N, N m) of a joint, a
// bushing or a reaction probe; a coordinate force element's ".force" (N on a translation, N m on
// a rotation: unit "N or N m") and ".power" (W); a spring-damper's ".length" (m) and ".tension"
// (N); a beam probe's ".N1".."M3" (N, N m). Unknown names give an empty unit and a description
// saying so.
Quantity HistoryQuantity(const std::string &name, AnalysisType analysis);

// The history columns of probe `probe`, in the order of its sample (position x y z, displacement
// x y z, rotation w x y z, rotation angle): "<probe>.position.x", ..., "<probe>.rotation_angle".
constexpr int kProbeColumns = 11;
void          ProbeColumnNames(const std::string &probe, std::string names[kProbeColumns]);
// Column `column` (0 .. kProbeColumns - 1) of probe `probe`.
Quantity ProbeColumnQuantity(const std::string &probe, int column);

// The name ParaView shows for an array: "name [unit]", or the bare name for a dimensionless or
// unit-less quantity.
std::string NameWithUnit(const std::string &name, const std::string &unit);

} // namespace msflex
