#include "io/input_yaml_util.hpp"

#include <array>
#include <cmath>
#include <sstream>

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

} // namespace

void FailAt(const YAML::Mark &mark, const std::string &message)
{
  // yaml-cpp counts from 0 and uses -1 for "no position".
  if (mark.is_null()) throw InputFailure{0, 0, message};
  throw InputFailure{mark.line + 1, mark.column + 1, message};
}

void FailAt(const SourceMark &mark, const std::string &message) { throw InputFailure{mark.line, mark.column, message}; }

std::string Quote(const std::string &text) { return "'" + text + "'"; }

std::string FormatNumber(double number)
{
  std::ostringstream text;
  text << number;
  return text.str();
}

std::string FormatVec3(const Vec3 &vector)
{
  return "[" + FormatNumber(vector(0)) + ", " + FormatNumber(vector(1)) + ", " + FormatNumber(vector(2)) + "]";
}

std::string DescribeValue(const YAML::Node &value)
{
  if (!value.IsDefined() || value.IsNull()) return "an empty value";
  if (value.IsSequence()) return value.size() == 0 ? "an empty list" : "a list";
  if (value.IsMap()) return "a mapping";
  return Quote(value.Scalar());
}

double ReadNumber(const YAML::Node &value, const std::string &key)
{
  // decode() reports failure instead of throwing; it also understands .nan and .inf, which we
  // then reject explicitly so the message can say why.
  double number = 0.0;
  if (!value.IsScalar() || !YAML::convert<double>::decode(value, number))
    FailAt(value.Mark(), "expected a number for " + Quote(key) + ", got " + DescribeValue(value));
  if (!std::isfinite(number)) FailAt(value.Mark(), Quote(key) + " must be finite, got " + value.Scalar());
  return number;
}

double ReadPositiveNumber(const YAML::Node &value, const std::string &key)
{
  const double number = ReadNumber(value, key);
  if (!(number > 0.0)) FailAt(value.Mark(), Quote(key) + " must be positive, got " + value.Scalar());
  return number;
}

double ReadNonNegativeNumber(const YAML::Node &value, const std::string &key)
{
  const double number = ReadNumber(value, key);
  if (number < 0.0) FailAt(value.Mark(), Quote(key) + " must not be negative, got " + value.Scalar());
  return number;
}

int ReadInteger(const YAML::Node &value, const std::string &key, int minimum)
{
  int number = 0;
  if (!value.IsScalar() || !YAML::convert<int>::decode(value, number))
    FailAt(value.Mark(), "expected an integer for " + Quote(key) + ", got " + DescribeValue(value));
  if (number < minimum)
    FailAt(value.Mark(), Quote(key) + " must be at least " + std::to_string(minimum) + ", got " + value.Scalar());
  return number;
}

bool ReadBool(const YAML::Node &value, const std::string &key)
{
  bool flag = false;
  if (!value.IsScalar() || !YAML::convert<bool>::decode(value, flag))
    FailAt(value.Mark(), "expected true or false for " + Quote(key) + ", got " + DescribeValue(value));
  return flag;
}

std::string ReadString(const YAML::Node &value, const std::string &key)
{
  if (!value.IsScalar()) FailAt(value.Mark(), "expected a string for " + Quote(key) + ", got " + DescribeValue(value));
  if (value.Scalar().empty()) FailAt(value.Mark(), Quote(key) + " must not be empty");
  return value.Scalar();
}

Vec3 ReadVec3(const YAML::Node &value, const std::string &key)
{
  if (!value.IsSequence() || value.size() != 3) {
    const std::string got = value.IsSequence() ? "a list of " + std::to_string(value.size()) : DescribeValue(value);
    FailAt(value.Mark(), "expected a list of 3 numbers for " + Quote(key) + ", got " + got);
  }
  return Vec3(ReadNumber(value[0], key), ReadNumber(value[1], key), ReadNumber(value[2], key));
}

Vec3 ReadNonNegativeVec3(const YAML::Node &value, const std::string &key)
{
  const Vec3 vector = ReadVec3(value, key);
  for (int component = 0; component < 3; ++component)
    if (vector(component) < 0.0)
      FailAt(value[component].Mark(), "components of " + Quote(key) + " must not be negative, got " + value[component].Scalar());
  return vector;
}

int ReadDofName(const YAML::Node &value, const std::string &key)
{
  const std::string name = ReadString(value, key);
  for (size_t dof = 0; dof < kDofNames.size(); ++dof)
    if (name == kDofNames[dof]) return static_cast<int>(dof);
  FailAt(value.Mark(), "unknown DOF " + Quote(name) + " in " + Quote(key) + "; expected one of ux, uy, uz, rx, ry, rz");
}

const char *DofName(int dof) { return kDofNames.at(static_cast<size_t>(dof)); }

std::vector<YAML::Node> ReadOptionalList(const YAML::Node *value, const std::string &key)
{
  // A key left empty (e.g. every entry commented out) means "none", like an absent key.
  if (value == nullptr || value->IsNull()) return {};
  if (!value->IsSequence()) FailAt(value->Mark(), "expected a list for " + Quote(key) + ", got " + DescribeValue(*value));
  return std::vector<YAML::Node>(value->begin(), value->end());
}

std::vector<YAML::Node> ReadNonEmptyList(const YAML::Node &value, const std::string &key)
{
  std::vector<YAML::Node> items = ReadOptionalList(&value, key);
  if (items.empty()) FailAt(value.Mark(), Quote(key) + " must be a non-empty list, got " + DescribeValue(value));
  return items;
}

std::vector<NameReference> ReadNameList(const YAML::Node &value, const std::string &key)
{
  if (value.IsScalar()) return {NameReference{ReadString(value, key), value.Mark()}};
  std::vector<NameReference> names;
  for (const YAML::Node &item : ReadNonEmptyList(value, key)) names.push_back(NameReference{ReadString(item, key), item.Mark()});
  return names;
}

MappingReader::MappingReader(const YAML::Node &mapping, const std::string &kind)
    : description_(kind), mark_(mapping.Mark())
{
  if (!mapping.IsMap()) FailAt(mark_, "expected a mapping (key: value) for " + kind + ", got " + DescribeValue(mapping));
  for (const auto &pair : mapping) {
    if (!pair.first.IsScalar()) FailAt(pair.first.Mark(), "keys in " + kind + " must be plain names, got " + DescribeValue(pair.first));
    entries_.push_back(Entry{pair.first.Scalar(), pair.first, pair.second});
  }
  if (const YAML::Node *name = Find("name"); name != nullptr && name->IsScalar()) description_ = kind + " " + Quote(name->Scalar());
  // yaml-cpp keeps duplicate keys and would silently read the first one.
  for (const Entry &entry : entries_)
    if (const Entry *first = FindEntry(entry.key); first != &entry)
      FailAt(entry.key_node.Mark(), "duplicate key " + Quote(entry.key) + " in " + description_ + " (first at line " +
                                        std::to_string(first->key_node.Mark().line + 1) + ")");
}

MappingReader::MappingReader(const YAML::Node &mapping, const std::string &kind, std::initializer_list<const char *> allowed_keys)
    : MappingReader(mapping, kind)
{
  RequireOnlyKeys(allowed_keys);
}

void MappingReader::RequireOnlyKeys(std::initializer_list<const char *> allowed_keys) const
{
  RequireOnlyKeys(std::vector<const char *>(allowed_keys));
}

void MappingReader::RequireOnlyKeys(const std::vector<const char *> &allowed_keys) const
{
  for (const Entry &entry : entries_) {
    bool allowed = false;
    for (const char *allowed_key : allowed_keys) allowed = allowed || entry.key == allowed_key;
    if (!allowed)
      FailAt(entry.key_node.Mark(), "unknown key " + Quote(entry.key) + " in " + description_ + "; allowed keys: " + JoinKeys(allowed_keys));
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

double MappingReader::PositiveNumber(const std::string &key, double fallback) const
{
  return Has(key) ? PositiveNumber(key) : fallback;
}

double MappingReader::NonNegativeNumber(const std::string &key, double fallback) const
{
  return Has(key) ? ReadNonNegativeNumber(Required(key), key) : fallback;
}

int MappingReader::Integer(const std::string &key, int minimum) const { return ReadInteger(Required(key), key, minimum); }

int MappingReader::Integer(const std::string &key, int minimum, int fallback) const
{
  return Has(key) ? Integer(key, minimum) : fallback;
}

bool MappingReader::Bool(const std::string &key, bool fallback) const { return Has(key) ? ReadBool(Required(key), key) : fallback; }

std::string MappingReader::String(const std::string &key) const { return ReadString(Required(key), key); }

std::string MappingReader::String(const std::string &key, const std::string &fallback) const
{
  return Has(key) ? String(key) : fallback;
}

Vec3 MappingReader::Vector(const std::string &key) const { return ReadVec3(Required(key), key); }

Vec3 MappingReader::Vector(const std::string &key, const Vec3 &fallback) const { return Has(key) ? Vector(key) : fallback; }

} // namespace msflex::input_detail
