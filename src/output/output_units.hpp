// The units and descriptions of everything the result file holds, in one place: every dataset of
// /mesh, /frames and /history gets them as its `unit` and `description` attributes, every column
// of the history table its entry of /history/units and /history/descriptions (docs/output.md),
// and the XDMF sidecar puts the unit into the array names ParaView shows ("displacement [m]").
//
// Units are SI strings: "m", "rad", "m/s", "rad/s", "N", "N m", "J", "s", "kg", "kg m^2",
// "kg m/s", "kg m^2/s", "1" for dimensionless numbers, counts and indices, "" for text. A dataset
// whose columns differ in unit lists one unit per column, separated by ", " ("N, N, N, N m, N m,
// N m"); "mixed" marks a single number that adds quantities of different units.
#pragma once

#include <string>

namespace msflex {

struct Quantity {
  std::string unit;
  std::string description;
};

// A dataset of the root, /mesh, /frames or /history (`group` "", "mesh", "frames" or "history",
// `name` the dataset's name there). `dynamic`: the analysis is dynamic (time in s) rather than static (pseudo-time, the
// load factor, dimensionless). Unknown names give an empty unit and description.
Quantity DatasetQuantity(const std::string &group, const std::string &name, bool dynamic);

// A history series, from its name: the fixed series (time, step, energies, momenta, ...), and the joint
// series "<joint>.<coordinate>" (tx..tz m, rx..rz rad), "<joint>.<coordinate>_rate" (per s, or per unit
// load factor in statics) and "<joint>.force_x".."<joint>.moment_z" (N, N m). Unknown names give an
// empty unit and a description saying so.
Quantity HistoryQuantity(const std::string &name, bool dynamic);

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
