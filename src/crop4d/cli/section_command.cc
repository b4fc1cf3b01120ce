// crop4d section: the paper's cross-section figure, a thin slice across a row with the points of
// several sessions coloured by date (report/cross_section.h, docs/cli.md#section).

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/report/cross_section.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::cli {
namespace {

namespace fs = std::filesystem;

struct SectionArgs {
  std::string workspace;
  std::string field;
  std::optional<int> row;
  std::optional<double> x;
  std::optional<double> y;
  double thickness_m = 0.1;
  double half_length_m = 1.5;
  std::vector<std::string> sessions;
  std::string output;
};

// The sessions of the workspace in their (date) order, restricted to `wanted` when given.
std::vector<std::string> SelectSessions(const std::string& workspace,
                                        const std::vector<std::string>& wanted) {
  const std::vector<std::string> all = report::ListWorkspaceSessions(workspace);
  if (wanted.empty()) return all;
  for (const std::string& s : wanted) {
    if (std::find(all.begin(), all.end(), s) == all.end()) {
      throw InputError(
          "--sessions", 0,
          fmt::format("session '{}' is not in {} (it has {})", s,
                      workspace::Layout(workspace).SessionsDir().string(), fmt::join(all, ", ")));
    }
  }
  std::vector<std::string> selected;
  for (const std::string& s : all) {
    if (std::find(wanted.begin(), wanted.end(), s) != wanted.end()) selected.push_back(s);
  }
  return selected;
}

io::FieldInfo ReadField(const std::string& field) {
  return io::ReadFieldYaml((fs::path(field) / "field.yaml").string());
}

// The y of the slice for --x without --y: the middle of the row of field.yaml nearest to x
// (when a field with rows is given), else the median y of the points within half_length of x.
double DefaultY(const SectionArgs& args, const std::vector<report::SessionCloud>& clouds) {
  if (!args.field.empty()) {
    const io::FieldInfo field = ReadField(args.field);
    const io::RowDeclaration* nearest = nullptr;
    double best = 0;
    for (const io::RowDeclaration& row : field.rows) {
      const Eigen::Vector2d middle = 0.5 * (row.start_enu + row.end_enu);
      if (nearest == nullptr || std::abs(middle.x() - *args.x) < best) {
        nearest = &row;
        best = std::abs(middle.x() - *args.x);
      }
    }
    if (nearest != nullptr) {
      const double y = 0.5 * (nearest->start_enu.y() + nearest->end_enu.y());
      spdlog::info("section: y = {:.2f} m, the middle of row {} (nearest to x = {:.2f} m)", y,
                   nearest->index, *args.x);
      return y;
    }
  }
  std::vector<double> ys;
  for (const report::SessionCloud& c : clouds) {
    for (const Eigen::Vector3d& p : c.cloud.points) {
      if (std::abs(p.x() - *args.x) <= args.half_length_m && std::isfinite(p.y())) {
        ys.push_back(p.y());
      }
    }
  }
  if (ys.empty()) {
    throw InputError("--x", 0,
                     fmt::format("no point of any cloud lies within {} m of x = {} m; give --y "
                                 "(or check --x: the clouds are in the field's ENU frame)",
                                 args.half_length_m, *args.x));
  }
  std::nth_element(ys.begin(), ys.begin() + ys.size() / 2, ys.end());
  const double y = ys[ys.size() / 2];
  spdlog::info("section: y = {:.2f} m, the median y of the points near x = {:.2f} m", y, *args.x);
  return y;
}

// "east", "north", or the bearing (clockwise from north) of the slice's positive direction.
std::string DirectionWords(const Eigen::Vector2d& direction) {
  const double bearing = std::atan2(direction.x(), direction.y()) * 180.0 / M_PI;
  if (std::abs(bearing - 90.0) < 0.5) return "east";
  if (std::abs(bearing) < 0.5) return "north";
  return fmt::format("bearing {:.0f} deg", bearing < 0 ? bearing + 360.0 : bearing);
}

int RunSection(const SectionArgs& args) {
  std::string extension = fs::path(args.output).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (extension != ".png") {
    throw InputError("--output", 0, "the figure is a PNG: give a file name ending in .png");
  }
  if (args.row && args.field.empty()) {
    throw InputError("--row", 0, "--row needs --field FIELD (the rows of FIELD/field.yaml)");
  }

  // The clouds, one per session in date order.
  const std::vector<std::string> sessions = SelectSessions(args.workspace, args.sessions);
  std::vector<std::string> missing;
  std::vector<report::SessionCloud> clouds =
      report::LoadSessionClouds(args.workspace, sessions, &missing);
  for (const std::string& s : missing) {
    spdlog::warn(
        "session {}: no cloud (neither fused/{}/sparse.ply nor sessions/{}/rows/*/"
        "landmarks.ply); left out",
        s, s, s);
  }
  if (clouds.empty()) {
    throw InputError(args.workspace, 0,
                     "no point cloud for any session: neither fused/<session>/sparse.ply nor "
                     "sessions/<session>/rows/*/landmarks.ply (run crop4d slam first)");
  }
  for (const report::SessionCloud& c : clouds) {
    if (c.files.size() == 1 && c.source == c.files[0]) {
      spdlog::info("section: {}: {} points from the fused cloud {}", c.session, c.cloud.size(),
                   c.source);
    } else {
      spdlog::info("section: {}: {} points from {} row SLAM cloud{} {}", c.session, c.cloud.size(),
                   c.files.size(), c.files.size() == 1 ? "" : "s", c.source);
    }
  }

  // The slice.
  report::CrossSectionOptions options;
  std::string where;
  if (args.row) {
    const io::FieldInfo field = ReadField(args.field);
    const auto row =
        std::find_if(field.rows.begin(), field.rows.end(),
                     [&](const io::RowDeclaration& r) { return r.index == *args.row; });
    if (row == field.rows.end()) {
      std::vector<int> indices;
      for (const io::RowDeclaration& r : field.rows) indices.push_back(r.index);
      throw InputError(
          (fs::path(args.field) / "field.yaml").string(), 0,
          field.rows.empty()
              ? std::string("declares no rows: give the slice's position with --x X [--y Y]")
              : fmt::format("has no row {} (rows: {})", *args.row, fmt::join(indices, ", ")));
    }
    options.slice = report::SliceAcrossRow(*row, args.y, args.thickness_m, args.half_length_m);
    where = fmt::format("of row {} ", *args.row);
  } else {
    options.slice.center = Eigen::Vector2d(*args.x, args.y ? *args.y : DefaultY(args, clouds));
    options.slice.direction = Eigen::Vector2d::UnitX();
    options.slice.thickness_m = args.thickness_m;
    options.slice.half_length_m = args.half_length_m;
  }
  const Eigen::Vector2d& centre = options.slice.center;
  options.title = fmt::format("Cross-section {}at x = {:.2f} m, y = {:.2f} m ({:.2f} m thick)",
                              where, centre.x(), centre.y(), options.slice.thickness_m);
  options.along_label =
      fmt::format("position across the row [m] (0: x = {:.2f}, y = {:.2f}; positive: {})",
                  centre.x(), centre.y(), DirectionWords(options.slice.direction));

  std::vector<io::PlyPointCloud> layers;
  std::vector<std::string> labels;
  for (report::SessionCloud& c : clouds) {
    layers.push_back(std::move(c.cloud));
    labels.push_back(c.session);
  }
  const report::CrossSectionFigure figure = report::DrawCrossSection(layers, labels, options);
  report::WriteCrossSectionPng(args.output, figure);

  for (const report::CrossSectionSeries& s : figure.series) {
    if (s.num_points == 0 && figure.num_points > 0) {
      spdlog::warn("session {}: no point in the slice", s.label);
    }
  }
  if (figure.num_points == 0) {
    spdlog::warn(
        "no point of any session lies in the slice (x = {:.2f} m, y = {:.2f} m, {} m thick, "
        "+/-{} m): the figure says so; check --row/--x/--y and --thickness",
        centre.x(), centre.y(), options.slice.thickness_m, options.slice.half_length_m);
  }
  std::fprintf(stderr, "section: %d points of %zu session%s in the slice, figure in %s\n",
               figure.num_points, figure.series.size(), figure.series.size() == 1 ? "" : "s",
               args.output.c_str());
  return 0;
}

}  // namespace

RunFunction SetupSection(CLI::App& app) {
  auto args = std::make_shared<SectionArgs>();
  app.description(
      "Draw the paper's cross-section figure (docs/cli.md#section): a thin vertical slice across "
      "a row with the points of several sessions, one colour per session from the earliest to "
      "the latest, height against position along the slice at equal scale. Per session it reads "
      "WS/fused/<session>/sparse.ply when present, else the union of the row SLAM clouds "
      "WS/sessions/<session>/rows/*/landmarks.ply, and says which.\n\nExample:\n  crop4d "
      "section --workspace ws --field field --row 1 --output row1.png\n  crop4d section "
      "--workspace ws --x 2.7 --y 10 --thickness 0.05 --sessions 2016-06-01,2016-06-20 "
      "--output s.png");
  app.add_option("-w,--workspace", args->workspace, "Workspace (holds sessions/, fused/)")
      ->required()
      ->check(CLI::ExistingDirectory)
      ->type_name("WS");
  app.add_option("--field", args->field, "Field folder: its field.yaml gives the rows")
      ->check(CLI::ExistingDirectory)
      ->type_name("FIELD");
  CLI::Option_group* position = app.add_option_group("position", "Where the slice is (one of)");
  position
      ->add_option("--row", args->row,
                   "Slice across this row of FIELD/field.yaml (index), perpendicular to it")
      ->type_name("N");
  position->add_option("--x", args->x, "Slice east-west through this east coordinate (ENU metres)")
      ->type_name("X");
  position->require_option(1);
  app.add_option("--y", args->y,
                 "North coordinate of the slice's centre (default: the middle of the row; with "
                 "--x, of the row nearest to X, or the median y of the points near X)")
      ->type_name("Y");
  app.add_option("--thickness", args->thickness_m, "Full width of the slice, metres")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--half-length", args->half_length_m,
                 "The slice runs this many metres either side of its centre")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--sessions", args->sessions,
                 "Only these sessions, comma-separated (default: every session of WS/sessions)")
      ->delimiter(',')
      ->type_name("A,B,...");
  app.add_option("-o,--output", args->output, "The figure (PNG)")
      ->required()
      ->type_name("FILE.png");
  return [args] { return RunSection(*args); };
}

}  // namespace crop4d::cli
