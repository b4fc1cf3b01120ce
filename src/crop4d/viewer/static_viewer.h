#pragma once

// `crop4d export --viewer DIR`: the viewer as a static folder that any web server can host
// (docs/viewer.md). DIR gets the bundled page (index.html, app/...) and, in the layout that
// `crop4d view` serves, the viewer data (DIR/ws/viewer/, viewer_data.h) and the report
// (DIR/ws/report.html when the workspace has one).

#include <string>

#include "crop4d/viewer/viewer_data.h"

namespace crop4d::viewer {

ViewerDataSummary WriteStaticViewer(const std::string& workspace, const std::string& dir,
                                    const ViewerDataOptions& options = {});

// The lines `crop4d view` and `crop4d export --viewer` print about the data they wrote.
std::string FormatViewerDataSummary(const ViewerDataSummary& summary);

}  // namespace crop4d::viewer
