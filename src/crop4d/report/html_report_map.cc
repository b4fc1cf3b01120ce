// The season report's field map: rows, sites and each session's trajectory as inline SVG.
// Builder methods (html_report_builder.h).

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "crop4d/io/dataset.h"
#include "crop4d/io/tum.h"
#include "crop4d/report/html_report_builder.h"

namespace crop4d::report::html::detail {

// ---- field map -------------------------------------------------------------------------------

// A trajectory on the map: the fused poses of a session, else its passes', split where the
// poses jump (a gap of more than a second or two metres).
struct MapTrack {
  std::string session, source;
  std::vector<std::vector<Eigen::Vector2d>> lines;
  int poses = 0;
  double length_m = 0;
};

// Where the map is drawn: the drawn area (ENU) and its placement on the page. A field much
// longer north-south than wide is drawn turned a quarter turn clockwise (north to the right, east
// down), so that it fills the page's width; the north arrow shows it.
struct MapFrame {
  Eigen::Vector2d lo, hi, size;
  bool turned = false;
  double scale = 1, ml = 46, mr = 34, mt = 28, mb = 58, pw = 0, ph = 0, width = 0, height = 0;

  MapFrame(Eigen::Vector2d lo_in, Eigen::Vector2d hi_in, const HtmlReportOptions& opt) {
    const Eigen::Vector2d pad = (0.04 * (hi_in - lo_in)).cwiseMax(Eigen::Vector2d(0.5, 0.5));
    lo = lo_in - pad;
    hi = hi_in + pad;
    size = hi - lo;
    turned = size.y() > 1.6 * size.x();
    const double span_w = turned ? size.y() : size.x(), span_h = turned ? size.x() : size.y();
    scale = std::min(opt.map_max_width_px / span_w, opt.map_max_height_px / span_h);
    pw = span_w * scale, ph = span_h * scale;
    width = std::max(pw + ml + mr, 260.0), height = ph + mt + mb;
  }
  // Pixel position of ENU (x, y).
  Eigen::Vector2d P(double x, double y) const {
    return turned ? Eigen::Vector2d(ml + (y - lo.y()) * scale, mt + (x - lo.x()) * scale)
                  : Eigen::Vector2d(ml + (x - lo.x()) * scale, mt + (hi.y() - y) * scale);
  }
};

namespace {

// The grid with coordinates: east on the bottom (upright) or left (turned) edge, north on the
// left (upright) or bottom (turned) edge; one step per axis, about 60 px or more apart.
std::string MapGridSvg(const MapFrame& f) {
  std::string svg;
  auto grid_line = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, double value,
                       double step, bool on_left) {
    const int decimals = step >= 1 ? 0 : (step >= 0.1 ? 1 : 2);
    const Eigen::Vector2d at =
        on_left ? Eigen::Vector2d(f.ml - 4, a.y() + 3) : Eigen::Vector2d(a.x(), f.mt + f.ph + 12);
    svg += fmt::format(
        "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" class=\"grid\"/>"
        "<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"tick\" text-anchor=\"{}\">{:.{}f}</text>\n",
        a.x(), a.y(), b.x(), b.y(), at.x(), at.y(), on_left ? "end" : "middle",
        std::abs(value) < 1e-9 ? 0.0 : value, decimals);
  };
  const double step_x = NiceStep(std::max(f.size.x() / 8.0, 60.0 / f.scale));
  const double step_y = NiceStep(std::max(f.size.y() / 8.0, 60.0 / f.scale));
  for (double x = std::ceil(f.lo.x() / step_x) * step_x; x <= f.hi.x(); x += step_x) {
    grid_line(f.turned ? f.P(x, f.lo.y()) : f.P(x, f.hi.y()),
              f.turned ? f.P(x, f.hi.y()) : f.P(x, f.lo.y()), x, step_x, f.turned);
  }
  for (double y = std::ceil(f.lo.y() / step_y) * step_y; y <= f.hi.y(); y += step_y) {
    grid_line(f.P(f.lo.x(), y), f.P(f.hi.x(), y), y, step_y, !f.turned);
  }
  return svg;
}

// The rows of field.yaml, each with its index beyond its north end.
std::string MapRowsSvg(const MapFrame& f, const std::vector<io::RowDeclaration>& rows) {
  std::string svg;
  for (const io::RowDeclaration& row : rows) {
    const Eigen::Vector2d a = f.P(row.start_enu.x(), row.start_enu.y());
    const Eigen::Vector2d b = f.P(row.end_enu.x(), row.end_enu.y());
    svg += fmt::format(
        "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" class=\"row\"><title>row "
        "{}</title></line>\n",
        a.x(), a.y(), b.x(), b.y(), row.index);
    const Eigen::Vector2d top = row.start_enu.y() > row.end_enu.y() ? row.start_enu : row.end_enu;
    const Eigen::Vector2d t =
        f.P(top.x(), top.y()) + (f.turned ? Eigen::Vector2d(6, 3) : Eigen::Vector2d(0, -5));
    svg += fmt::format(
        "<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"label\" text-anchor=\"{}\">{}<title>row "
        "{}</title></text>\n",
        t.x(), t.y(), f.turned ? "start" : "middle", row.index, row.index);
  }
  return svg;
}

// The sites as circles, each labelled on its right when no other site's circle is in the way
// (else the circle's tooltip names it).
std::string MapSitesSvg(const MapFrame& f, const std::vector<io::Site>& sites) {
  std::string svg;
  for (const io::Site& site : sites) {
    const Eigen::Vector2d c = f.P(site.center_enu.x(), site.center_enu.y());
    const double r = std::max(2.0, site.radius_m * f.scale);
    svg += fmt::format(
        "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" class=\"site\"><title>site {} "
        "({:.2f}, {:.2f}) m, radius {:.2f} m</title></circle>\n",
        c.x(), c.y(), r, E(site.id), site.center_enu.x(), site.center_enu.y(), site.radius_m);
    const double label_w = 5.5 * site.id.size() + 4;
    bool room = true;
    for (const io::Site& other : sites) {
      if (&other == &site) continue;
      const Eigen::Vector2d o = f.P(other.center_enu.x(), other.center_enu.y());
      const double orad = std::max(2.0, other.radius_m * f.scale);
      if (o.x() - orad < c.x() + r + label_w && o.x() + orad > c.x() &&
          std::abs(o.y() - c.y()) < orad + 6) {
        room = false;
      }
    }
    if (room) {
      svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"label site-label\">{}</text>\n",
                         c.x() + r + 2, c.y() + 3, E(site.id));
    }
  }
  return svg;
}

// The scale bar (bottom left), the north arrow (top right) and the axis' name.
std::string MapScaleSvg(const MapFrame& f) {
  double bar = NiceStep(std::max(f.size.x(), f.size.y()) / 5.0);
  while (bar * f.scale > f.pw && bar > 1e-3) bar = NiceStep(bar / 2.5);
  const double bx = f.ml, by = f.height - 18;
  std::string svg = fmt::format(
      "<g class=\"scale\"><line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\"/>"
      "<line x1=\"{0:.1f}\" y1=\"{3:.1f}\" x2=\"{0:.1f}\" y2=\"{4:.1f}\"/>"
      "<line x1=\"{2:.1f}\" y1=\"{3:.1f}\" x2=\"{2:.1f}\" y2=\"{4:.1f}\"/>"
      "<text x=\"{5:.1f}\" y=\"{6:.1f}\" text-anchor=\"middle\">{7} m</text></g>\n",
      bx, by, bx + bar * f.scale, by - 4, by + 4, bx + bar * f.scale / 2, by - 7, bar);
  svg += fmt::format(
      "<g class=\"north\" transform=\"translate({:.1f},{:.1f}) rotate({})\"><path d=\"M0,-9 "
      "l-5,12 l5,-3 l5,3 z\"/><text x=\"0\" y=\"15\" text-anchor=\"middle\" "
      "transform=\"rotate({})\">N</text></g>\n",
      f.width - f.mr + 14, f.turned ? f.mt + 14.0 : 16.0, f.turned ? 90 : 0, f.turned ? -90 : 0);
  svg +=
      fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"tick\" text-anchor=\"end\">{}</text>\n",
                  f.ml + f.pw, f.mt + f.ph + 26,
                  f.turned ? "north [m] (turned: north to the right, east down)" : "east [m]");
  return svg;
}

}  // namespace

// The trajectory of every session that has one.
std::vector<MapTrack> Builder::MapTracks() {
  std::vector<MapTrack> tracks;
  const auto load_tum = [&](const fs::path& p, MapTrack* t) {
    std::vector<io::StampedPose> poses;
    try {
      poses = io::ReadTum(p.string());
    } catch (const std::exception& e) {
      Skip(Why(e) + "; left off the map");
      return;
    }
    std::vector<Eigen::Vector2d> line;
    Timestamp last = 0;
    for (const io::StampedPose& sp : poses) {
      const Eigen::Vector3d x = sp.pose.translation();
      if (!x.allFinite()) continue;
      const Eigen::Vector2d xy = x.head<2>();
      if (!line.empty() && (sp.t - last > 1'000'000'000LL || (xy - line.back()).norm() > 2.0)) {
        t->lines.push_back(std::move(line));
        line.clear();
      }
      if (!line.empty()) t->length_m += (xy - line.back()).norm();
      line.push_back(xy);
      last = sp.t;
      ++t->poses;
    }
    if (!line.empty()) t->lines.push_back(std::move(line));
  };
  for (const std::string& session : sessions_) {
    MapTrack t;
    t.session = session;
    const fs::path fused = layout_.FusedPoses(session);
    if (IsFile(fused)) {
      t.source = "fused";
      load_tum(fused, &t);
    } else {
      for (const std::string& pass : layout_.PassFolders(session)) {
        const fs::path poses = layout_.PassPoses(session, pass);
        if (IsFile(poses)) {
          t.source = "row SLAM";
          load_tum(poses, &t);
        }
      }
    }
    if (t.poses > 0) tracks.push_back(std::move(t));
  }
  return tracks;
}

// The trajectories, each in its session's colour, thinned to map_max_points_per_session.
std::string Builder::MapTracksSvg(const MapFrame& f, const std::vector<MapTrack>& tracks) const {
  std::string svg;
  for (const MapTrack& t : tracks) {
    const std::string color = SessionColor(t.session);
    int total = 0;
    for (const auto& line : t.lines) total += static_cast<int>(line.size());
    const int stride = std::max(1, (total + opt_.map_max_points_per_session - 1) /
                                       std::max(2, opt_.map_max_points_per_session));
    svg += "<g class=\"track\" stroke=\"" + color + "\"><title>" + E(t.session) + " (" +
           E(t.source) + ")</title>\n";
    for (const auto& line : t.lines) {
      if (line.size() < 2) continue;
      std::string pts;
      for (std::size_t i = 0; i < line.size(); ++i) {
        if (i % stride != 0 && i + 1 != line.size()) continue;
        const Eigen::Vector2d q = f.P(line[i].x(), line[i].y());
        pts += fmt::format("{:.1f},{:.1f} ", q.x(), q.y());
      }
      svg += "<polyline points=\"" + pts + "\"/>\n";
    }
    svg += "</g>\n";
  }
  return svg;
}

// The sessions' colours and what the field's marks are.
std::string Builder::MapLegend(const std::vector<MapTrack>& tracks) const {
  std::string legend = "<div class=\"legend\"><h3>Sessions</h3>\n";
  if (tracks.empty()) legend += Empty("No trajectory in the workspace yet.");
  for (const MapTrack& t : tracks) {
    legend += fmt::format(
        "<div><span class=\"swatch\" style=\"background:{}\"></span>{} <span "
        "class=\"muted\">{}, {} poses, {:.0f} m</span></div>\n",
        SessionColor(t.session), E(t.session), E(t.source), t.poses, t.length_m);
  }
  legend +=
      "<h3>Field</h3>\n<div><span class=\"swatch rowsw\"></span>crop row "
      "(field.yaml; its index at its north end)</div>\n<div><span class=\"swatch "
      "sitesw\"></span>measurement site</div>\n";
  if (!field_info_) legend += Empty("No field.yaml: rows and sites are not drawn.");
  legend +=
      "<p class=\"muted\">Hover a site, row or trajectory for its name. ENU frame of the field "
      "(x east, y north), metres" +
      std::string(field_info_ ? fmt::format("; origin {:.6f}, {:.6f}", field_info_->origin.lat_deg,
                                            field_info_->origin.lon_deg)
                              : std::string("")) +
      "</p></div>\n";
  return legend;
}

Section Builder::MapSection() {
  Section s{{"field-map", "Field map", false}, ""};
  const std::vector<MapTrack> tracks = MapTracks();
  // Bounds of everything drawn.
  Eigen::Vector2d lo(INFINITY, INFINITY), hi(-INFINITY, -INFINITY);
  auto grow = [&](const Eigen::Vector2d& p, double r = 0) {
    lo = lo.cwiseMin(p - Eigen::Vector2d(r, r));
    hi = hi.cwiseMax(p + Eigen::Vector2d(r, r));
  };
  if (field_info_) {
    for (const io::RowDeclaration& row : field_info_->rows) {
      grow(row.start_enu);
      grow(row.end_enu);
    }
    for (const io::Site& site : field_info_->sites) grow(site.center_enu, site.radius_m);
  }
  for (const MapTrack& t : tracks) {
    for (const auto& line : t.lines) {
      for (const Eigen::Vector2d& p : line) grow(p);
    }
  }
  if (!(lo.allFinite() && hi.allFinite())) {
    s.html = Empty(
        "Nothing to draw: no rows or sites (FIELD/field.yaml) and no trajectory (WS/fused/"
        "&lt;session&gt;/poses.tum or WS/sessions/&lt;session&gt;/rows/*/poses.tum).");
    return s;
  }
  s.info.has_data = true;
  const MapFrame f(lo, hi, opt_);
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"map\" width=\"{:.0f}\" "
      "height=\"{:.0f}\" viewBox=\"0 0 {:.0f} {:.0f}\" role=\"img\" aria-label=\"field map\">\n"
      "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#f7f5ef\" "
      "stroke=\"#ccc\"/>\n",
      f.width, f.height, f.width, f.height, f.ml, f.mt, f.pw, f.ph);
  svg += MapGridSvg(f);
  if (field_info_) svg += MapRowsSvg(f, field_info_->rows);
  svg += MapTracksSvg(f, tracks);
  if (field_info_) svg += MapSitesSvg(f, field_info_->sites);
  svg += MapScaleSvg(f);
  svg += "</svg>\n";
  s.html = "<div class=\"mapbox\">" + svg + MapLegend(tracks) + "</div>\n";
  return s;
}

}  // namespace crop4d::report::html::detail
