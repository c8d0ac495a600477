// libFuzzer harness: CSV inputs (io/csv.h numeric tables and root controls) and `--path`
// waypoint strings (data/control.h), which turn into a control signal.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "data/control.h"
#include "fuzz_check.h"
#include "io/csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mosyn;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const io::CsvTable table = io::parse_numeric_csv(text, "fuzz.csv");
    FUZZ_CHECK(table.rows.size() == table.row_lines.size());
    for (const auto& row : table.rows) FUZZ_CHECK(row.size() == table.header.size());
  } catch (const Error&) {
  }
  try {
    io::parse_control_csv(text, "fuzz.csv");
  } catch (const Error&) {
  }
  try {
    const std::vector<data::Waypoint> path = data::parse_path(text);
    data::PathOptions o;
    o.seconds = size % 2 ? 0 : 2;  // 0: as long as the path takes
    data::control_from_path(path, o);
  } catch (const Error&) {
  }
  return 0;
}
