// Reading `expected`: the results an example must reproduce (docs/input.md, "expected"). The
// solver ignores them; the test suite compares them with the result file
// (tests/regression/msflex_testing.py, check_expected), so each number lives in the example alone.
#include "io/input_reader_internal.hpp"

#include <string>

namespace msflex::input_detail {

namespace {

const char *const kStatistics[] = {"final", "max", "min", "max_abs", "range"};

ExpectedResult ReadExpectedResult(const YAML::Node &item, const ReaderContext &context)
{
  const MappingReader entry(item, "expected result", {"series", "time", "statistic", "value", "tolerance", "relative_tolerance", "below", "above"});
  ExpectedResult      expected;
  expected.mark   = context.MarkOf(entry.Mark());
  expected.series = entry.String("series");
  if (entry.Has("time") == entry.Has("statistic"))
    FailAt(entry.Mark(), "an expected result needs exactly one of 'time' (the row at that time) and 'statistic' (final, max, min, max_abs or range)");
  if (entry.Has("time")) {
    expected.time = ReadNonNegativeNumber(entry.Required("time"), "time");
  } else {
    expected.statistic = entry.String("statistic");
    bool known         = false;
    for (const char *statistic : kStatistics) known = known || expected.statistic == statistic;
    if (!known)
      FailAt(entry.Required("statistic").Mark(),
             "unknown statistic " + Quote(expected.statistic) + " of an expected result; expected final, max, min, max_abs or range");
  }
  expected.has_value = entry.Has("value");
  expected.has_below = entry.Has("below");
  expected.has_above = entry.Has("above");
  if (!expected.has_value && !expected.has_below && !expected.has_above) FailAt(entry.Mark(), "an expected result needs 'value', 'below' or 'above'");
  if (expected.has_value) {
    expected.value = entry.Number("value");
    if (entry.Has("tolerance") == entry.Has("relative_tolerance"))
      FailAt(entry.Required("value").Mark(), "'value' of an expected result needs exactly one of 'tolerance' (absolute) and 'relative_tolerance'");
    expected.tolerance          = entry.NonNegativeNumber("tolerance", 0.0);
    expected.relative_tolerance = entry.NonNegativeNumber("relative_tolerance", 0.0);
  } else {
    for (const char *key : {"tolerance", "relative_tolerance"})
      if (const YAML::Node *value = entry.Find(key)) FailAt(value->Mark(), Quote(key) + " of an expected result goes with 'value', which is missing");
  }
  expected.below = entry.Number("below", 0.0);
  expected.above = entry.Number("above", 0.0);
  return expected;
}

} // namespace

void ReadExpected(const YAML::Node *list, ReaderContext &context)
{
  for (const YAML::Node &item : ReadOptionalList(list, "expected")) context.model.expected.push_back(ReadExpectedResult(item, context));
}

} // namespace msflex::input_detail
