// Typed reads of YAML values for the input reader (private to src/io/).
//
// Every helper either returns a validated value or throws InputFailure located at the offending
// node. InputFailure never leaves the reader: ReadModelString converts it into an InputError. The
// exception keeps the many small readers free of error plumbing.
#pragma once

#include "math/rotation.hpp"
#include "model/model.hpp"

#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <string>
#include <vector>

namespace msflex::input_detail {

struct InputFailure {
  int         line   = 0; // 1-based; 0 when unknown
  int         column = 0; // 1-based; 0 when unknown
  std::string message;
};

[[noreturn]] void FailAt(const YAML::Mark &mark, const std::string &message);
[[noreturn]] void FailAt(const SourceMark &mark, const std::string &message);

// 'text', as it goes into a one-line message: control characters are escaped (\n, \t, \x01) and
// a text longer than kQuotedLength bytes is cut short with "...".
std::string             Quote(const std::string &text);
inline constexpr size_t kQuotedLength = 100;
// The message with its control characters escaped, so that it prints as one line.
std::string OneLine(const std::string &message);
// Where a YAML syntax error is, for its message: ", at 'the line'" (long lines shortened around
// the column, with a hint when tabs indent it) or ", at the end of the input"; "" without a mark.
std::string SyntaxErrorContext(const std::string &text, const YAML::Mark &mark);
std::string FormatNumber(double number);    // shortest readable form, e.g. 0.5 or 1e-06
std::string FormatVec3(const Vec3 &vector); // [x, y, z] with FormatNumber
// How a value reads in a message: 'abc', a list, a mapping or an empty value.
std::string DescribeValue(const YAML::Node &value);
// Where a value is, for messages: its own mark, or for an empty value that of its key (yaml-cpp
// marks an empty value where the next token starts).
YAML::Mark ValueMark(const YAML::Node &value);

// A YAML stream: its first document and where each document's root node starts. Unlike
// YAML::LoadAll this never loops forever: yaml-cpp 0.7 produces an empty document again and again,
// without consuming anything, at a ',' outside [...] and {...}; such a stream is a syntax error
// (YAML::ParserException) at that token.
struct YamlStream {
  YAML::Node              first; // null when the stream has no document
  std::vector<YAML::Mark> roots; // one per document
};
YamlStream LoadYamlStream(const std::string &text);

// Single values; `key` names the value in messages.
double      ReadNumber(const YAML::Node &value, const std::string &key); // finite
double      ReadPositiveNumber(const YAML::Node &value, const std::string &key);
double      ReadNonNegativeNumber(const YAML::Node &value, const std::string &key);
int         ReadInteger(const YAML::Node &value, const std::string &key, int minimum);
bool        ReadBool(const YAML::Node &value, const std::string &key);
std::string ReadString(const YAML::Node &value, const std::string &key);          // non-empty scalar
Vec3        ReadVec3(const YAML::Node &value, const std::string &key);            // 3 finite numbers
Vec3        ReadNonNegativeVec3(const YAML::Node &value, const std::string &key); // 3 finite numbers >= 0
// A point in space (m): 3 numbers of magnitude at most kMaxCoordinate (see PositionProblem).
Vec3        ReadPosition(const YAML::Node &value, const std::string &key);
int         ReadDofName(const YAML::Node &value, const std::string &key); // ux..rz -> DOF_UX..DOF_RZ
const char *DofName(int dof);

// "" when `name` can begin the names of history series in the result file (a probe's columns
// <name>.position.x, a joint's <name>.tx, ...; docs/output.md) and still be one component of an
// HDF5 path, for tools that file series by name; else what is wrong: it is empty, is ".", or
// contains '/' or a NUL character.
std::string OutputNameProblem(const std::string &name);

// The largest coordinate of a point (m). Distances between points then stay far from overflow even
// when cubed; without a bound, a node at 1e200 would give beams NaN triads (|x|^2 overflows).
inline constexpr double kMaxCoordinate = 1e100;
// "" for a point whose coordinates are all at most kMaxCoordinate in magnitude, else the problem.
std::string PositionProblem(const Vec3 &position);

// The items of a list. An absent or empty (null) optional list has no items.
std::vector<YAML::Node> ReadOptionalList(const YAML::Node *value, const std::string &key);
// A present, non-empty list.
std::vector<YAML::Node> ReadNonEmptyList(const YAML::Node &value, const std::string &key);

// A name as written in the input, with its location for messages.
struct NameReference {
  std::string name;
  YAML::Mark  mark;
};
// A single name or a non-empty list of names.
std::vector<NameReference> ReadNameList(const YAML::Node &value, const std::string &key);

// One YAML mapping, read key by key. The constructor rejects non-mappings and duplicate keys;
// RequireOnlyKeys rejects unknown keys (typos would otherwise be silently ignored).
class MappingReader {
public:
  struct Entry {
    std::string key;
    YAML::Node  key_node;
    YAML::Node  value;
  };

  // `kind` names the mapping in messages ("section", "'analysis'"); when the mapping has a scalar
  // `name` key the description becomes e.g. "section 'steel'".
  MappingReader(const YAML::Node &mapping, const std::string &kind);
  MappingReader(const YAML::Node &mapping, const std::string &kind, std::initializer_list<const char *> allowed_keys);

  void RequireOnlyKeys(std::initializer_list<const char *> allowed_keys) const;
  void RequireOnlyKeys(const std::vector<const char *> &allowed_keys) const;

  const std::vector<Entry> &Entries() const { return entries_; }
  const std::string        &Description() const { return description_; }
  const YAML::Mark         &Mark() const { return mark_; }

  bool              Has(const std::string &key) const { return Find(key) != nullptr; }
  const YAML::Node *Find(const std::string &key) const; // nullptr when absent
  const YAML::Node &Required(const std::string &key) const;

  double      Number(const std::string &key) const;
  double      Number(const std::string &key, double fallback) const;
  double      PositiveNumber(const std::string &key) const;
  double      PositiveNumber(const std::string &key, double fallback) const;
  double      NonNegativeNumber(const std::string &key, double fallback) const;
  int         Integer(const std::string &key, int minimum) const;
  int         Integer(const std::string &key, int minimum, int fallback) const;
  bool        Bool(const std::string &key, bool fallback) const;
  std::string String(const std::string &key) const;
  std::string String(const std::string &key, const std::string &fallback) const;
  Vec3        Vector(const std::string &key) const;
  Vec3        Vector(const std::string &key, const Vec3 &fallback) const;

private:
  const Entry *FindEntry(const std::string &key) const;

  std::vector<Entry> entries_;
  std::string        description_;
  YAML::Mark         mark_;
};

} // namespace msflex::input_detail
