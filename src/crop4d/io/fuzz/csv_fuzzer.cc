// libFuzzer target: the CSV reader and the four data.csv readers on arbitrary bytes. They must
// never crash, hang or leak, whatever the input; every problem becomes a diagnostic.

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "crop4d/io/csv.h"
#include "crop4d/io/diagnostics.h"
#include "crop4d/io/sensor_csv.h"

using namespace crop4d::io;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  Diagnostics::Options options;
  options.max_items_per_file = 64;
  {
    std::istringstream in(text);
    CsvReader::Options csv_options;
    csv_options.max_line_length = 256;
    CsvReader reader(in, "raw.csv", csv_options);
    CsvRecord record;
    std::int64_t last_line = 0;
    while (reader.Next(&record)) {
      if (record.line <= last_line) __builtin_trap();  // lines must advance
      last_line = record.line;
      for (std::string_view field : record.fields) {
        double d;
        std::int64_t i;
        ParseDouble(field, &d);
        ParseInt64(field, &i);
      }
    }
  }
  Diagnostics diag(options);
  std::int64_t previous = -1;
  const auto check_order = [&previous](std::int64_t t) {
    if (t <= previous) __builtin_trap();  // the readers promise strictly increasing times
    previous = t;
  };
  {
    std::istringstream in(text);
    ReadImuCsv(
        in, "imu0/data.csv", [&](const ImuSample& s, std::int64_t) { check_order(s.t); }, &diag);
  }
  previous = -1;
  {
    std::istringstream in(text);
    ReadMagCsv(
        in, "mag0/data.csv", [&](const MagSample& s, std::int64_t) { check_order(s.t); }, &diag);
  }
  previous = -1;
  {
    std::istringstream in(text);
    ReadGpsCsv(
        in, "gps0/data.csv", [&](const GpsSample& s, std::int64_t) { check_order(s.t); }, &diag);
  }
  previous = -1;
  {
    std::istringstream in(text);
    ReadImageCsv(
        in, "cam0/data.csv",
        [&](const ImageEntry& e, std::int64_t) {
          check_order(e.t);
          if (e.filename.empty() || e.filename.front() == '/') __builtin_trap();
        },
        &diag);
  }
  return 0;
}
