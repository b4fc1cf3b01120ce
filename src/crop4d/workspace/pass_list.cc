#include "crop4d/workspace/pass_list.h"

#include <cstdint>
#include <filesystem>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::workspace {

namespace fs = std::filesystem;

const char* const kPassListHeader =
    "pass,row,direction,t_begin [ns],t_end [ns],start_x [m],start_y [m],end_x [m],end_y [m],"
    "length [m]";

void WritePassList(const std::string& path, const std::vector<slam::RowPass>& passes) {
  std::ostringstream out;
  out << kPassListHeader << '\n';
  for (const slam::RowPass& p : passes) {
    out << p.id << ',' << p.row << ',' << p.direction << ',' << p.t_begin << ',' << p.t_end << ','
        << p.start_world.x() << ',' << p.start_world.y() << ',' << p.end_world.x() << ','
        << p.end_world.y() << ',' << p.length_m << '\n';
  }
  io::WriteFileAtomic(path, out.str());
}

std::vector<slam::RowPass> ReadPassListFile(const std::string& path) {
  std::vector<slam::RowPass> passes;
  if (!fs::exists(path)) return passes;
  io::CsvReader reader(path);
  io::CsvRecord record;
  bool header = false;
  while (reader.Next(&record)) {
    if (record.unterminated) {
      throw InputError(path, record.line, "truncated (rerun `crop4d slam`)");
    }
    if (!header) {
      std::string line;
      for (std::size_t k = 0; k < record.fields.size(); ++k) {
        line += (k > 0 ? "," : "") + std::string(record.fields[k]);
      }
      if (line != kPassListHeader) {
        throw InputError(
            path, record.line,
            "not a pass list of this crop4d version (header '" + line + "'); rerun `crop4d slam`");
      }
      header = true;
      continue;
    }
    if (record.fields.size() != 10) {
      throw InputError(path, record.line, "expected 10 columns (rerun `crop4d slam`)");
    }
    slam::RowPass p;
    p.id = std::string(record.fields[0]);
    std::int64_t row = 0, direction = 0;
    double v[5];
    bool ok =
        io::ParseInt64(record.fields[1], &row) && io::ParseInt64(record.fields[2], &direction) &&
        io::ParseInt64(record.fields[3], &p.t_begin) && io::ParseInt64(record.fields[4], &p.t_end);
    for (int k = 0; k < 5; ++k) ok = ok && io::ParseDouble(record.fields[5 + k], &v[k]);
    if (!ok || p.id.empty()) {
      throw InputError(path, record.line, "malformed pass line (rerun `crop4d slam`)");
    }
    p.row = static_cast<int>(row);
    p.direction = static_cast<int>(direction);
    p.start_world = Eigen::Vector2d(v[0], v[1]);
    p.end_world = Eigen::Vector2d(v[2], v[3]);
    p.length_m = v[4];
    passes.push_back(p);
  }
  if (!header) throw InputError(path, 0, "empty: no header line (rerun `crop4d slam`)");
  return passes;
}

std::vector<slam::RowPass> ReadPassList(const std::string& workspace, const std::string& session) {
  return ReadPassListFile(Layout(workspace).PassList(session).string());
}

}  // namespace crop4d::workspace
