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

Section Builder::MapSection() {
  Section s{{"field-map", "Field map", false}, ""};
  struct Track {
    std::string session, source;
    std::vector<std::vector<Eigen::Vector2d>> lines;
    int poses = 0;
    double length_m = 0;
  };
  std::vector<Track> tracks;
  const auto load_tum = [&](const fs::path& p, Track* t) {
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
    Track t;
    t.session = session;
    const fs::path fused = WsPath("fused") / session / "poses.tum";
    if (IsFile(fused)) {
      t.source = "fused";
      load_tum(fused, &t);
    } else {
      for (const fs::path& pd : ListDir(WsPath("sessions") / session / "rows", true)) {
        if (IsFile(pd / "poses.tum")) {
          t.source = "row SLAM";
          load_tum(pd / "poses.tum", &t);
        }
      }
    }
    if (t.poses > 0) tracks.push_back(std::move(t));
  }

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
  for (const Track& t : tracks) {
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
  const Eigen::Vector2d pad = (0.04 * (hi - lo)).cwiseMax(Eigen::Vector2d(0.5, 0.5));
  lo -= pad;
  hi += pad;
  const Eigen::Vector2d size = hi - lo;
  // A field much longer north-south than wide is drawn turned a quarter turn clockwise (north to
  // the right, east down), so that it fills the page's width; the north arrow shows it.
  const bool turned = size.y() > 1.6 * size.x();
  const double span_w = turned ? size.y() : size.x(), span_h = turned ? size.x() : size.y();
  const double scale = std::min(opt_.map_max_width_px / span_w, opt_.map_max_height_px / span_h);
  const double ml = 46, mr = 34, mt = 28, mb = 58;
  const double pw = span_w * scale, ph = span_h * scale;
  const double width = std::max(pw + ml + mr, 260.0), height = ph + mt + mb;
  // Pixel position of ENU (x, y).
  auto P = [&](double x, double y) {
    return turned ? Eigen::Vector2d(ml + (y - lo.y()) * scale, mt + (x - lo.x()) * scale)
                  : Eigen::Vector2d(ml + (x - lo.x()) * scale, mt + (hi.y() - y) * scale);
  };

  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"map\" width=\"{:.0f}\" "
      "height=\"{:.0f}\" viewBox=\"0 0 {:.0f} {:.0f}\" role=\"img\" aria-label=\"field map\">\n"
      "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#f7f5ef\" "
      "stroke=\"#ccc\"/>\n",
      width, height, width, height, ml, mt, pw, ph);
  // Grid with coordinates: east on the bottom (upright) or left (turned) edge, north on the left
  // (upright) or bottom (turned) edge.
  auto grid_line = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, double value,
                       double step, bool on_left) {
    const int decimals = step >= 1 ? 0 : (step >= 0.1 ? 1 : 2);
    const Eigen::Vector2d at =
        on_left ? Eigen::Vector2d(ml - 4, a.y() + 3) : Eigen::Vector2d(a.x(), mt + ph + 12);
    svg += fmt::format(
        "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" class=\"grid\"/>"
        "<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"tick\" text-anchor=\"{}\">{:.{}f}</text>\n",
        a.x(), a.y(), b.x(), b.y(), at.x(), at.y(), on_left ? "end" : "middle",
        std::abs(value) < 1e-9 ? 0.0 : value, decimals);
  };
  // One step per axis, about 60 px or more apart.
  const double step_x = NiceStep(std::max(size.x() / 8.0, 60.0 / scale));
  const double step_y = NiceStep(std::max(size.y() / 8.0, 60.0 / scale));
  for (double x = std::ceil(lo.x() / step_x) * step_x; x <= hi.x(); x += step_x) {
    grid_line(turned ? P(x, lo.y()) : P(x, hi.y()), turned ? P(x, hi.y()) : P(x, lo.y()), x, step_x,
              turned);
  }
  for (double y = std::ceil(lo.y() / step_y) * step_y; y <= hi.y(); y += step_y) {
    grid_line(P(lo.x(), y), P(hi.x(), y), y, step_y, !turned);
  }
  if (field_info_) {
    for (const io::RowDeclaration& row : field_info_->rows) {
      const Eigen::Vector2d a = P(row.start_enu.x(), row.start_enu.y());
      const Eigen::Vector2d b = P(row.end_enu.x(), row.end_enu.y());
      svg += fmt::format(
          "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" class=\"row\"><title>row "
          "{}</title></line>\n",
          a.x(), a.y(), b.x(), b.y(), row.index);
      // The index beyond the row's north end.
      const Eigen::Vector2d top = row.start_enu.y() > row.end_enu.y() ? row.start_enu : row.end_enu;
      const Eigen::Vector2d t =
          P(top.x(), top.y()) + (turned ? Eigen::Vector2d(6, 3) : Eigen::Vector2d(0, -5));
      svg += fmt::format(
          "<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"label\" text-anchor=\"{}\">{}<title>row "
          "{}</title></text>\n",
          t.x(), t.y(), turned ? "start" : "middle", row.index, row.index);
    }
  }
  for (const Track& t : tracks) {
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
        const Eigen::Vector2d q = P(line[i].x(), line[i].y());
        pts += fmt::format("{:.1f},{:.1f} ", q.x(), q.y());
      }
      svg += "<polyline points=\"" + pts + "\"/>\n";
    }
    svg += "</g>\n";
  }
  if (field_info_) {
    const std::vector<io::Site>& sites = field_info_->sites;
    for (const io::Site& site : sites) {
      const Eigen::Vector2d c = P(site.center_enu.x(), site.center_enu.y());
      const double r = std::max(2.0, site.radius_m * scale);
      svg += fmt::format(
          "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" class=\"site\"><title>site {} "
          "({:.2f}, {:.2f}) m, radius {:.2f} m</title></circle>\n",
          c.x(), c.y(), r, E(site.id), site.center_enu.x(), site.center_enu.y(), site.radius_m);
      // The label right of the circle, when no other site's circle is in its way (else the
      // circle's tooltip names it).
      const double label_w = 5.5 * site.id.size() + 4;
      bool room = true;
      for (const io::Site& other : sites) {
        if (&other == &site) continue;
        const Eigen::Vector2d o = P(other.center_enu.x(), other.center_enu.y());
        const double orad = std::max(2.0, other.radius_m * scale);
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
  }
  // Scale bar (bottom left) and north arrow (top right).
  double bar = NiceStep(std::max(size.x(), size.y()) / 5.0);
  while (bar * scale > pw && bar > 1e-3) bar = NiceStep(bar / 2.5);
  const double bx = ml, by = height - 18;
  svg += fmt::format(
      "<g class=\"scale\"><line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\"/>"
      "<line x1=\"{0:.1f}\" y1=\"{3:.1f}\" x2=\"{0:.1f}\" y2=\"{4:.1f}\"/>"
      "<line x1=\"{2:.1f}\" y1=\"{3:.1f}\" x2=\"{2:.1f}\" y2=\"{4:.1f}\"/>"
      "<text x=\"{5:.1f}\" y=\"{6:.1f}\" text-anchor=\"middle\">{7} m</text></g>\n",
      bx, by, bx + bar * scale, by - 4, by + 4, bx + bar * scale / 2, by - 7, bar);
  svg += fmt::format(
      "<g class=\"north\" transform=\"translate({:.1f},{:.1f}) rotate({})\"><path d=\"M0,-9 "
      "l-5,12 l5,-3 l5,3 z\"/><text x=\"0\" y=\"15\" text-anchor=\"middle\" "
      "transform=\"rotate({})\">N</text></g>\n",
      width - mr + 14, turned ? mt + 14.0 : 16.0, turned ? 90 : 0, turned ? -90 : 0);
  svg += fmt::format(
      "<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"tick\" text-anchor=\"end\">{}</text>\n", ml + pw,
      mt + ph + 26, turned ? "north [m] (turned: north to the right, east down)" : "east [m]");
  svg += "</svg>\n";

  // Legend.
  std::string legend = "<div class=\"legend\"><h3>Sessions</h3>\n";
  if (tracks.empty()) legend += Empty("No trajectory in the workspace yet.");
  for (const Track& t : tracks) {
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
  s.html = "<div class=\"mapbox\">" + svg + legend + "</div>\n";
  return s;
}

}  // namespace crop4d::report::html::detail
