#include "io/input_yaml_util.hpp"

#include <yaml-cpp/eventhandler.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <utility>

namespace msflex::input_detail {

namespace {

const std::array<const char *, 6> kDofNames{{"ux", "uy", "uz", "rx", "ry", "rz"}};

std::string JoinKeys(const std::vector<const char *> &keys)
{
  std::string joined;
  for (const char *key : keys) {
    if (!joined.empty()) joined += ", ";
    joined += key;
  }
  return joined;
}

// A decimal number (as strtod reads it, to the end) too large for a double.
bool IsOutOfRangeNumber(const std::string &scalar)
{
  if (scalar.empty() || std::isspace(static_cast<unsigned char>(scalar.front()))) return false;
  char *end           = nullptr;
  errno               = 0;
  const double number = std::strtod(scalar.c_str(), &end);
  return errno == ERANGE && std::isinf(number) && end == scalar.c_str() + scalar.size();
}

// Records where each document starts and where its root node is, and builds nothing.
class DocumentMarks : public YAML::EventHandler {
public:
  std::vector<YAML::Mark> starts, roots;

  void OnDocumentStart(const YAML::Mark &mark) override
  {
    starts.push_back(mark);
    root_seen_ = false;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark &mark, YAML::anchor_t) override { Node(mark); }
  void OnAlias(const YAML::Mark &mark, YAML::anchor_t) override { Node(mark); }
  void OnScalar(const YAML::Mark &mark, const std::string &, YAML::anchor_t, const std::string &) override { Node(mark); }
  void OnSequenceStart(const YAML::Mark &mark, const std::string &, YAML::anchor_t, YAML::EmitterStyle::value) override { Node(mark); }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark &mark, const std::string &, YAML::anchor_t, YAML::EmitterStyle::value) override { Node(mark); }
  void OnMapEnd() override {}

private:
  void Node(const YAML::Mark &mark)
  {
    if (!root_seen_) roots.push_back(mark);
    root_seen_ = true;
  }
  bool root_seen_ = false;
};

} // namespace

YamlStream LoadYamlStream(const std::string &text)
{
  std::istringstream stream(text);
  YAML::Parser       parser(stream);
  DocumentMarks      marks;
  while (parser.HandleNextDocument(marks)) {
    const size_t count = marks.starts.size();
    // A document that starts where the previous one did consumed nothing: yaml-cpp is stuck.
    if (count >= 2 && marks.starts[count - 1].pos == marks.starts[count - 2].pos) {
      const YAML::Mark &mark    = marks.starts[count - 1];
      const bool        in_text = mark.pos >= 0 && static_cast<size_t>(mark.pos) < text.size();
      const std::string token   = in_text ? Quote(std::string(1, text[static_cast<size_t>(mark.pos)])) : "token";
      throw YAML::ParserException(mark, "unexpected " + token + (token == "','" ? " outside [...] and {...}" : ""));
    }
  }
  YamlStream result;
  result.roots = std::move(marks.roots);
  if (!result.roots.empty()) result.first = YAML::Load(text); // the first document only
  return result;
}

void FailAt(const YAML::Mark &mark, const std::string &message)
{
  // yaml-cpp counts from 0 and uses -1 for "no position".
  if (mark.is_null()) throw InputFailure{0, 0, OneLine(message)};
  throw InputFailure{mark.line + 1, mark.column + 1, OneLine(message)};
}

void FailAt(const SourceMark &mark, const std::string &message) { throw InputFailure{mark.line, mark.column, OneLine(message)}; }

// The length of the valid UTF-8 sequence of two to four bytes at text[at] (0: none there).
static size_t Utf8SequenceLength(const std::string &text, size_t at)
{
  const unsigned char lead = static_cast<unsigned char>(text[at]);
  size_t              length;
  unsigned            low = 0x80, high = 0xbf; // the allowed range of the second byte
  if (lead >= 0xc2 && lead <= 0xdf) length = 2;
  else if (lead >= 0xe0 && lead <= 0xef) {
    length = 3;
    if (lead == 0xe0) low = 0xa0;
    if (lead == 0xed) high = 0x9f; // no surrogates
  } else if (lead >= 0xf0 && lead <= 0xf4) {
    length = 4;
    if (lead == 0xf0) low = 0x90;
    if (lead == 0xf4) high = 0x8f;
  } else return 0;
  if (at + length > text.size()) return 0;
  for (size_t k = 1; k < length; ++k) {
    const unsigned char byte = static_cast<unsigned char>(text[at + k]);
    if (byte < (k == 1 ? low : 0x80) || byte > (k == 1 ? high : 0xbf)) return 0;
  }
  return length;
}

std::string OneLine(const std::string &message)
{
  std::string line;
  line.reserve(message.size());
  for (size_t at = 0; at < message.size(); ++at) {
    const char          character = message[at];
    const unsigned char byte      = static_cast<unsigned char>(character);
    if (byte >= 0x80) {
      // Valid UTF-8 passes as it is; any other byte (a binary file given as input) is escaped, so
      // that the message stays text.
      if (const size_t length = Utf8SequenceLength(message, at); length > 0) {
        line.append(message, at, length);
        at += length - 1;
      } else {
        static const char digits[] = "0123456789abcdef";
        line += "\\x";
        line += digits[byte >> 4];
        line += digits[byte & 15];
      }
    } else if (byte >= 0x20 && byte != 0x7f) {
      line += character;
    } else if (character == '\n') {
      line += "\\n";
    } else if (character == '\t') {
      line += "\\t";
    } else if (character == '\r') {
      line += "\\r";
    } else {
      static const char digits[] = "0123456789abcdef";
      line += "\\x";
      line += digits[byte >> 4];
      line += digits[byte & 15];
    }
  }
  return line;
}

namespace {

// The first `length` bytes of `text`, not cutting a UTF-8 sequence in two.
size_t Utf8Prefix(const std::string &text, size_t length)
{
  if (length >= text.size()) return text.size();
  while (length > 0 && (static_cast<unsigned char>(text[length]) & 0xc0) == 0x80) --length;
  return length;
}

} // namespace

std::string Quote(const std::string &text)
{
  if (text.size() <= kQuotedLength) return "'" + OneLine(text) + "'";
  return "'" + OneLine(text.substr(0, Utf8Prefix(text, kQuotedLength - 3))) + "...'";
}

std::string SyntaxErrorContext(const std::string &text, const YAML::Mark &mark)
{
  if (mark.is_null() || mark.pos < 0) return "";
  if (static_cast<size_t>(mark.pos) >= text.size()) return ", at the end of the input";
  // The line holding the mark: yaml-cpp's pos counts bytes from the start of the input.
  const size_t position = static_cast<size_t>(mark.pos);
  size_t       begin    = 0;
  if (const size_t newline = position > 0 ? text.rfind('\n', position - 1) : std::string::npos; newline != std::string::npos) begin = newline + 1;
  size_t end = text.find('\n', position);
  if (end == std::string::npos) end = text.size();
  if (end > begin && text[end - 1] == '\r') --end;
  if (position >= end && text.find_first_not_of(" \t\r\n", position) == std::string::npos) return ", at the end of the input";
  std::string line = text.substr(begin, end - begin);
  if (line.find_first_not_of(" \t") == std::string::npos) return "";
  const bool tab_indented = line.find('\t') < line.find_first_not_of(" \t");
  // A long line is shown around the column, at most 80 bytes.
  constexpr size_t kShown = 80;
  if (line.size() > kShown) {
    const size_t column = std::min(position - begin, line.size());
    const size_t from   = column > kShown / 2 ? Utf8Prefix(line, column - kShown / 2) : 0;
    const size_t to     = Utf8Prefix(line, std::min(line.size(), from + kShown));
    line                = (from > 0 ? "..." : "") + line.substr(from, to - from) + (to < line.size() ? "..." : "");
  }
  return ", at '" + OneLine(line) + "'" + (tab_indented ? " (YAML does not allow tabs for indentation)" : "");
}

std::string FormatNumber(double number)
{
  std::ostringstream text;
  text << number;
  return text.str();
}

std::string FormatVec3(const Vec3 &vector) { return "[" + FormatNumber(vector(0)) + ", " + FormatNumber(vector(1)) + ", " + FormatNumber(vector(2)) + "]"; }

namespace {
// The empty values of the mappings read so far, with the marks of their keys: yaml-cpp marks an
// empty value where the next token starts, the next line's key or the end of the file, so an
// error about `end_time:` on the last line was reported one line further down.
thread_local std::vector<std::pair<YAML::Node, YAML::Mark>> empty_value_keys;
} // namespace

YAML::Mark ValueMark(const YAML::Node &value)
{
  if (value.IsDefined() && value.IsNull())
    for (const auto &[node, key_mark] : empty_value_keys)
      if (node.is(value)) return key_mark;
  return value.Mark();
}

std::string DescribeValue(const YAML::Node &value)
{
  if (!value.IsDefined() || value.IsNull()) return "an empty value";
  // A list by its length: "must list two nodes, got a list" did not say what was wrong with it.
  if (value.IsSequence()) return value.size() == 0 ? "an empty list" : "a list of " + std::to_string(value.size());
  if (value.IsMap()) return "a mapping";
  return Quote(value.Scalar());
}

double ReadNumber(const YAML::Node &value, const std::string &key)
{
  // decode() reports failure instead of throwing; it also understands .nan and .inf, which we
  // then reject explicitly so the message can say why.
  double number = 0.0;
  if (!value.IsScalar() || !YAML::convert<double>::decode(value, number)) {
    // A number beyond the range of a double (1e999) fails to convert like a word would.
    if (value.IsScalar() && IsOutOfRangeNumber(value.Scalar()))
      FailAt(ValueMark(value), Quote(key) + " is out of range (at most about 1.8e308 in magnitude), got " + value.Scalar());
    FailAt(ValueMark(value), "expected a number for " + Quote(key) + ", got " + DescribeValue(value));
  }
  if (!std::isfinite(number)) FailAt(ValueMark(value), Quote(key) + " must be finite, got " + value.Scalar());
  return number;
}

double ReadPositiveNumber(const YAML::Node &value, const std::string &key)
{
  const double number = ReadNumber(value, key);
  if (!(number > 0.0)) FailAt(ValueMark(value), Quote(key) + " must be positive, got " + value.Scalar());
  if (std::fpclassify(number) == FP_SUBNORMAL) FailAt(ValueMark(value), Quote(key) + " is too close to zero to compute with, got " + value.Scalar());
  return number;
}

double ReadNonNegativeNumber(const YAML::Node &value, const std::string &key)
{
  const double number = ReadNumber(value, key);
  if (number < 0.0) FailAt(ValueMark(value), Quote(key) + " must not be negative, got " + value.Scalar());
  return number;
}

int ReadInteger(const YAML::Node &value, const std::string &key, int minimum)
{
  // Decimal digits only: yaml-cpp reads 010 as octal 8 and 0x0A as 10 (a user's `elements: 010`
  // ran with 8 elements), where the command line reads 010 as 10.
  if (!value.IsScalar()) FailAt(ValueMark(value), "expected an integer for " + Quote(key) + ", got " + DescribeValue(value));
  const std::string &text    = value.Scalar();
  const size_t       digits  = !text.empty() && (text[0] == '+' || text[0] == '-') ? 1 : 0; // where the digits start
  const bool         decimal = digits < text.size() && text.find_first_not_of("0123456789", digits) == std::string::npos;
  if (!decimal) FailAt(ValueMark(value), "expected an integer for " + Quote(key) + ", got " + DescribeValue(value));
  if (text.size() - digits > 1 && text[digits] == '0')
    FailAt(ValueMark(value), "expected a decimal integer for " + Quote(key) + ", got " + text + " (a leading 0 would read as octal)");
  errno                = 0;
  const long long wide = std::strtoll(text.c_str(), nullptr, 10);
  if (errno == ERANGE || wide > std::numeric_limits<int>::max() || wide < std::numeric_limits<int>::min())
    FailAt(ValueMark(value), Quote(key) + " is out of range (+-2147483647), got " + text);
  const int number = (int)wide;
  if (number < minimum) FailAt(ValueMark(value), Quote(key) + " must be at least " + std::to_string(minimum) + ", got " + value.Scalar());
  return number;
}

bool ReadBool(const YAML::Node &value, const std::string &key)
{
  bool flag = false;
  if (!value.IsScalar() || !YAML::convert<bool>::decode(value, flag))
    FailAt(ValueMark(value), "expected true or false for " + Quote(key) + ", got " + DescribeValue(value));
  return flag;
}

std::string OutputNameProblem(const std::string &name)
{
  if (name.empty()) return "it is empty";
  if (name == ".") return "'.' means the current group in an HDF5 path";
  if (name.find('/') != std::string::npos) return "it contains '/', the HDF5 path separator";
  if (name.find('\0') != std::string::npos) return "it contains a NUL character";
  return "";
}

std::string ReadString(const YAML::Node &value, const std::string &key)
{
  if (!value.IsScalar()) FailAt(ValueMark(value), "expected a string for " + Quote(key) + ", got " + DescribeValue(value));
  if (value.Scalar().empty()) FailAt(ValueMark(value), Quote(key) + " must not be empty");
  // A "\0" escape ends the string for every C interface behind it: `file: "a\0b.h5"` wrote 'a'.
  if (value.Scalar().find('\0') != std::string::npos) FailAt(ValueMark(value), Quote(key) + " must not contain a NUL character (\\0)");
  return value.Scalar();
}

Vec3 ReadVec3(const YAML::Node &value, const std::string &key)
{
  if (!value.IsSequence() || value.size() != 3) {
    const std::string got = value.IsSequence() ? "a list of " + std::to_string(value.size()) : DescribeValue(value);
    FailAt(ValueMark(value), "expected a list of 3 numbers for " + Quote(key) + ", got " + got);
  }
  return Vec3(ReadNumber(value[0], key), ReadNumber(value[1], key), ReadNumber(value[2], key));
}

Vec3 ReadNonNegativeVec3(const YAML::Node &value, const std::string &key)
{
  const Vec3 vector = ReadVec3(value, key);
  for (int component = 0; component < 3; ++component)
    if (vector(component) < 0.0) FailAt(value[component].Mark(), "components of " + Quote(key) + " must not be negative, got " + value[component].Scalar());
  return vector;
}

std::string PositionProblem(const Vec3 &position)
{
  if (position.cwiseAbs().maxCoeff() <= kMaxCoordinate) return "";
  return "coordinates must not exceed " + FormatNumber(kMaxCoordinate) + " m in magnitude";
}

Vec3 ReadPosition(const YAML::Node &value, const std::string &key)
{
  const Vec3 position = ReadVec3(value, key);
  for (int component = 0; component < 3; ++component)
    if (!(std::abs(position(component)) <= kMaxCoordinate))
      FailAt(value[component].Mark(),
             "coordinates of " + Quote(key) + " must not exceed " + FormatNumber(kMaxCoordinate) + " m in magnitude, got " + value[component].Scalar());
  return position;
}

int ReadDofName(const YAML::Node &value, const std::string &key)
{
  const std::string name = ReadString(value, key);
  for (size_t dof = 0; dof < kDofNames.size(); ++dof)
    if (name == kDofNames[dof]) return static_cast<int>(dof);
  FailAt(ValueMark(value), "unknown DOF " + Quote(name) + " in " + Quote(key) + "; expected one of ux, uy, uz, rx, ry, rz");
}

const char *DofName(int dof) { return kDofNames.at(static_cast<size_t>(dof)); }

std::vector<YAML::Node> ReadOptionalList(const YAML::Node *value, const std::string &key)
{
  // A key left empty (e.g. every entry commented out) means "none", like an absent key.
  if (value == nullptr || value->IsNull()) return {};
  if (!value->IsSequence()) FailAt(ValueMark(*value), "expected a list for " + Quote(key) + ", got " + DescribeValue(*value));
  return std::vector<YAML::Node>(value->begin(), value->end());
}

std::vector<YAML::Node> ReadNonEmptyList(const YAML::Node &value, const std::string &key)
{
  std::vector<YAML::Node> items = ReadOptionalList(&value, key);
  if (items.empty()) FailAt(ValueMark(value), Quote(key) + " must be a non-empty list, got " + DescribeValue(value));
  return items;
}

std::vector<NameReference> ReadNameList(const YAML::Node &value, const std::string &key)
{
  if (value.IsScalar()) return {NameReference{ReadString(value, key), value.Mark()}};
  std::vector<NameReference> names;
  for (const YAML::Node &item : ReadNonEmptyList(value, key)) names.push_back(NameReference{ReadString(item, key), item.Mark()});
  return names;
}

MappingReader::MappingReader(const YAML::Node &mapping, const std::string &kind) : description_(kind), mark_(mapping.Mark())
{
  if (!mapping.IsMap()) FailAt(mark_, "expected a mapping (key: value) for " + kind + ", got " + DescribeValue(mapping));
  for (const auto &pair : mapping) {
    if (!pair.first.IsScalar()) FailAt(pair.first.Mark(), "keys in " + kind + " must be plain names, got " + DescribeValue(pair.first));
    entries_.push_back(Entry{pair.first.Scalar(), pair.first, pair.second});
    if (pair.second.IsNull()) empty_value_keys.emplace_back(pair.second, pair.first.Mark());
  }
  if (const YAML::Node *name = Find("name"); name != nullptr && name->IsScalar()) description_ = kind + " " + Quote(name->Scalar());
  // yaml-cpp keeps duplicate keys and would silently read the first one. (A hash of the keys seen,
  // as `nodes` may hold many thousands.)
  std::unordered_map<std::string, const Entry *> first_of_key;
  first_of_key.reserve(entries_.size());
  for (const Entry &entry : entries_)
    if (const auto [first, inserted] = first_of_key.emplace(entry.key, &entry); !inserted)
      FailAt(entry.key_node.Mark(),
             "duplicate key " + Quote(entry.key) + " in " + description_ + " (first at line " + std::to_string(first->second->key_node.Mark().line + 1) + ")");
}

MappingReader::MappingReader(const YAML::Node &mapping, const std::string &kind, std::initializer_list<const char *> allowed_keys)
    : MappingReader(mapping, kind)
{
  RequireOnlyKeys(allowed_keys);
}

void MappingReader::RequireOnlyKeys(std::initializer_list<const char *> allowed_keys) const { RequireOnlyKeys(std::vector<const char *>(allowed_keys)); }

void MappingReader::RequireOnlyKeys(const std::vector<const char *> &allowed_keys) const
{
  for (const Entry &entry : entries_) {
    bool allowed = false;
    for (const char *allowed_key : allowed_keys) allowed = allowed || entry.key == allowed_key;
    if (!allowed) FailAt(entry.key_node.Mark(), "unknown key " + Quote(entry.key) + " in " + description_ + "; allowed keys: " + JoinKeys(allowed_keys));
  }
}

const MappingReader::Entry *MappingReader::FindEntry(const std::string &key) const
{
  for (const Entry &entry : entries_)
    if (entry.key == key) return &entry;
  return nullptr;
}

const YAML::Node *MappingReader::Find(const std::string &key) const
{
  const Entry *entry = FindEntry(key);
  return entry != nullptr ? &entry->value : nullptr;
}

const YAML::Node &MappingReader::Required(const std::string &key) const
{
  const YAML::Node *value = Find(key);
  if (value == nullptr) FailAt(mark_, "missing required key " + Quote(key) + " in " + description_);
  return *value;
}

double MappingReader::Number(const std::string &key) const { return ReadNumber(Required(key), key); }

double MappingReader::Number(const std::string &key, double fallback) const { return Has(key) ? Number(key) : fallback; }

double MappingReader::PositiveNumber(const std::string &key) const { return ReadPositiveNumber(Required(key), key); }

double MappingReader::PositiveNumber(const std::string &key, double fallback) const { return Has(key) ? PositiveNumber(key) : fallback; }

double MappingReader::NonNegativeNumber(const std::string &key, double fallback) const
{
  return Has(key) ? ReadNonNegativeNumber(Required(key), key) : fallback;
}

int MappingReader::Integer(const std::string &key, int minimum) const { return ReadInteger(Required(key), key, minimum); }

int MappingReader::Integer(const std::string &key, int minimum, int fallback) const { return Has(key) ? Integer(key, minimum) : fallback; }

bool MappingReader::Bool(const std::string &key, bool fallback) const { return Has(key) ? ReadBool(Required(key), key) : fallback; }

std::string MappingReader::String(const std::string &key) const { return ReadString(Required(key), key); }

std::string MappingReader::String(const std::string &key, const std::string &fallback) const { return Has(key) ? String(key) : fallback; }

Vec3 MappingReader::Vector(const std::string &key) const { return ReadVec3(Required(key), key); }

Vec3 MappingReader::Vector(const std::string &key, const Vec3 &fallback) const { return Has(key) ? Vector(key) : fallback; }

} // namespace msflex::input_detail
