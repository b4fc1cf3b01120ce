#pragma once

// WS/sessions/<session>/passes.csv: the row passes that row SLAM found in a session, one line per
// pass (id, row, direction, time span, start and end in the field frame, length). Its header line
// is the schema: a file whose header differs (another crop4d version), a malformed or a truncated
// line throws InputError naming the file and line and saying to rerun `crop4d slam`.

#include <string>
#include <vector>

#include "crop4d/slam/row_passes.h"

namespace crop4d::workspace {

// The header line of passes.csv (without its newline).
extern const char* const kPassListHeader;

// Writes the pass list atomically.
void WritePassList(const std::string& path, const std::vector<slam::RowPass>& passes);
// Reads a pass list (empty when the file does not exist).
std::vector<slam::RowPass> ReadPassListFile(const std::string& path);
// The passes of a session from WS/sessions/<session>/passes.csv (empty when there is none).
std::vector<slam::RowPass> ReadPassList(const std::string& workspace, const std::string& session);

}  // namespace crop4d::workspace
