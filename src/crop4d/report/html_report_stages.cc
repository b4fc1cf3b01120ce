// The season report's pipeline stages: row SLAM, associations, 4D fusion, dense clouds and the
// cross-section figure.
// Builder methods (html_report_builder.h).

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <exception>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "crop4d/io/dataset.h"
#include "crop4d/io/ply.h"
#include "crop4d/report/cross_section.h"
#include "crop4d/report/html_report_builder.h"
#include "crop4d/workspace/association_summary.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/stage_summary.h"

namespace crop4d::report::html::detail {

// ---- row SLAM ----------------------------------------------------------------------------------

Section Builder::SlamSection() {
  Section s{{"slam", "Row SLAM", false}, ""};
  std::vector<std::vector<std::string>> per_session, per_pass;
  for (const std::string& session : sessions_) {
    if (!IsDir(layout_.SessionDir(session))) continue;
    int listed = -1;
    std::vector<std::string> listed_passes;
    if (const auto passes = ReadArtefact(layout_.PassList(session), [](const fs::path& p) {
          return workspace::ReadPassListFile(p.string());
        })) {
      listed = static_cast<int>(passes->size());
      for (const slam::RowPass& p : *passes) listed_passes.push_back(p.id);
    }
    int solved = 0, converged = 0;
    double images = 0, landmarks = 0, seconds = 0, rms_sum = 0;
    int rms_n = 0;
    std::set<std::string> have;
    for (const std::string& pass : layout_.PassFolders(session)) {
      const auto summary = ReadArtefact(layout_.PassSummary(session, pass), [](const fs::path& p) {
        return workspace::ReadPassSummary(p.string());
      });
      if (!summary) continue;
      const json* j = &summary->json;
      ++solved;
      have.insert(pass);
      const std::optional<bool> conv = Bool(*j, {"back_end", "converged"});
      if (conv.value_or(false)) ++converged;
      images += Num(*j, {"images"}).value_or(0);
      landmarks += Num(*j, {"back_end", "landmarks"}).value_or(0);
      seconds += Num(*j, {"seconds", "total"}).value_or(0);
      if (auto r = Num(*j, {"back_end", "reprojection_rms_px"})) {
        rms_sum += *r;
        ++rms_n;
      }
      per_pass.push_back({E(session), E(pass), I(Num(*j, {"row"})), E(Str(*j, {"direction"})),
                          E(Str(*j, {"sensors"})), I(Num(*j, {"images"})),
                          I(Num(*j, {"back_end", "landmarks"})), I(Num(*j, {"cloud", "points"})),
                          F(Num(*j, {"back_end", "reprojection_rms_px"}), 2),
                          I(Num(*j, {"back_end", "rejected_observations"})),
                          I(Num(*j, {"back_end", "gps_factors"})),
                          conv ? (*conv ? "yes" : "<span class=\"warnt\">no</span>") : kDash,
                          Duration(Num(*j, {"seconds", "total"}))});
    }
    if (solved > 0) {
      for (const std::string& p : listed_passes) {
        if (!have.count(p)) {
          Skip("slam: session " + session + ", pass " + p + ": no rows/" + p +
               "/summary.json (not solved, or it failed)");
        }
      }
    }
    per_session.push_back({E(session), listed >= 0 ? std::to_string(listed) : std::string(kDash),
                           std::to_string(solved), I(images), I(landmarks),
                           rms_n > 0 ? F(rms_sum / rms_n, 2) : std::string(kDash),
                           fmt::format("{}/{}", converged, solved),
                           solved > 0 ? Duration(seconds) : kDash});
  }
  if (per_session.empty()) {
    s.html = Empty("Row SLAM has not run: no WS/sessions/&lt;session&gt;/ folder.");
    return s;
  }
  s.info.has_data = !per_pass.empty();
  s.html +=
      "<p>One factor graph per row pass (SIFT tracks, IMU preintegration, GP motion prior, "
      "GPS).</p>\n";
  s.html += Table({"session", "passes", "solved", "images", "landmarks", "mean reproj. RMS [px]",
                   "converged", "time"},
                  per_session, "lrrrrrrr");
  if (!per_pass.empty()) {
    s.html += Details(
        fmt::format("Every pass ({})", per_pass.size()),
        Table({"session", "pass", "row", "dir", "sensors", "images", "landmarks", "cloud points",
               "reproj. RMS [px]", "rejected obs.", "GPS factors", "converged", "time"},
              per_pass, "llrrlrrrrrrlr"));
  } else {
    s.html += Empty("No pass has a summary.json yet.");
  }
  return s;
}

// ---- associations -----------------------------------------------------------------------------

Section Builder::AssociationSection() {
  Section s{{"associations", "Associations", false}, ""};
  struct Pair {
    std::string a, b, type;
    std::optional<double> matches, image_pairs, putative, seconds;
    bool prealigned = false;
  };
  std::map<std::string, std::vector<Pair>> by_method;
  for (const fs::path& f : workspace::AssociationSummaries(layout_)) {
    const auto summary = ReadArtefact(
        f, [](const fs::path& p) { return workspace::ReadAssociationSummary(p.string()); });
    if (!summary) continue;
    Pair p;
    p.a = summary->a.session + " " + summary->a.pass;
    p.b = summary->b.session + " " + summary->b.pass;
    p.type = summary->type;
    p.matches = static_cast<double>(summary->matches);
    p.image_pairs = summary->image_pairs;
    p.putative = static_cast<double>(summary->putative);
    p.seconds = summary->seconds;
    p.prealigned = summary->prealigned;
    std::string method = summary->method;
    if (method.empty()) method = f.parent_path().filename().string();
    by_method[method].push_back(p);
  }
  if (by_method.empty()) {
    s.html = Empty(
        "Association has not run: no WS/associations/&lt;method&gt;/&lt;a&gt;__&lt;b&gt;.json.");
    return s;
  }
  s.info.has_data = true;
  s.html +=
      "<p>Cross matches between neighbouring row passes: adjacent rows of one session, and the "
      "same row in adjacent sessions.</p>\n";
  for (const auto& [method, pairs] : by_method) {
    s.html += "<h3>Method: " + E(method) + "</h3>\n";
    double matches = 0, image_pairs = 0, seconds = 0;
    int zero = 0;
    std::map<std::string, std::vector<double>> per_type;
    std::vector<std::vector<std::string>> rows;
    for (const Pair& p : pairs) {
      matches += p.matches.value_or(0);
      image_pairs += p.image_pairs.value_or(0);
      seconds += p.seconds.value_or(0);
      if (p.matches.value_or(0) == 0) ++zero;
      per_type[p.type.empty() ? std::string("(unknown)") : p.type].push_back(p.matches.value_or(0));
      rows.push_back({E(p.a), E(p.b), E(p.type), I(p.image_pairs), I(p.putative), I(p.matches),
                      p.prealigned ? "yes" : "no", Duration(p.seconds)});
    }
    s.html += KeyValues({{"pass pairs", I(double(pairs.size()))},
                         {"pairs without a match", I(double(zero))},
                         {"cross matches", I(matches)},
                         {"image pairs matched", I(image_pairs)},
                         {"time (sum)", Duration(seconds)}});
    std::vector<std::vector<std::string>> type_rows;
    for (auto& [type, m] : per_type) {
      std::vector<double> sorted = m;
      std::sort(sorted.begin(), sorted.end());
      double sum = 0;
      int z = 0;
      for (double v : m) {
        sum += v;
        if (v == 0) ++z;
      }
      type_rows.push_back({E(type), I(double(m.size())), I(sum), I(sorted[sorted.size() / 2]),
                           I(sorted.front()), I(sorted.back()), I(double(z))});
    }
    s.html += Table(
        {"pair type", "pairs", "matches", "median per pair", "min", "max", "pairs without a match"},
        type_rows, "lrrrrrr");
    s.html += Details(fmt::format("Every pair ({})", pairs.size()),
                      Table({"pass a", "pass b", "type", "image pairs", "putative", "matches",
                             "pre-aligned", "time"},
                            rows, "lllrrrlr"));
  }
  return s;
}

// ---- fusion -------------------------------------------------------------------------------------

Section Builder::FusionSection() {
  Section s{{"fusion", "4D fusion", false}, ""};
  const auto Cm = [](std::optional<double> m) {
    return m ? std::optional<double>(100.0 * *m) : std::nullopt;
  };
  const auto summary = ReadArtefact(layout_.FusedSummary(), [](const fs::path& p) {
    return workspace::ReadFusedSummary(p.string());
  });
  if (!summary) {
    s.html = Empty("4D fusion has not run: no WS/fused/summary.json.");
    return s;
  }
  s.info.has_data = true;
  const json& f = summary->json;
  std::string sessions;
  if (const json* ss = At(f, {"sessions"}); ss != nullptr && ss->is_array()) {
    for (const json& x : *ss) {
      if (!sessions.empty()) sessions += ", ";
      sessions += E(x.is_string() ? x.get<std::string>() : x.dump());
    }
  }
  const std::optional<bool> conv = Bool(f, {"joint", "converged"});
  s.html += KeyValues({
      {"sessions", sessions.empty() ? std::string(kDash) : sessions},
      {"row passes", I(Num(f, {"joint", "passes"}))},
      {"states", I(Num(f, {"joint", "states"}))},
      {"landmarks (shared by passes)",
       I(Num(f, {"joint", "landmarks"})) + " (" + I(Num(f, {"joint", "shared_landmarks"})) + ")"},
      {"observations (cross)", I(Num(f, {"joint", "observations"})) + " (" +
                                   I(Num(f, {"joint", "cross_observations"})) + ")"},
      {"rejected observations (cross)", I(Num(f, {"joint", "rejected_observations"})) + " (" +
                                            I(Num(f, {"joint", "rejected_cross_observations"})) +
                                            ")"},
      {"reprojection RMS [px] (cross)", F(Num(f, {"joint", "reprojection_rms_px"}), 3) + " (" +
                                            F(Num(f, {"joint", "cross_reprojection_rms_px"}), 3) +
                                            ")"},
      {"cost, initial &rarr; final", F(Num(f, {"joint", "initial_cost"}), 1) + " &rarr; " +
                                         F(Num(f, {"joint", "final_cost"}), 1)},
      {"iterations (converged)",
       I(Num(f, {"joint", "iterations"})) + " (" +
           (conv ? (*conv ? std::string("yes")
                          : std::string("<span class=\"warnt\">no: iteration limit</span>"))
                 : std::string(kDash)) +
           ")"},
      {"cross matches read (files)", I(Num(f, {"associations", "cross_matches"})) + " (" +
                                         I(Num(f, {"associations", "files"})) + ")"},
      {"ground ties (RMS after fusion across / vertically [cm])",
       I(Num(f, {"joint", "ground_ties"})) + " (" +
           F(Cm(Num(f, {"joint", "ground_tie_rms_across_m"})), 1) + " / " +
           F(Cm(Num(f, {"joint", "ground_tie_rms_vertical_m"})), 1) + ")"},
      {"time: solve / final solve / total", Duration(Num(f, {"seconds", "solve"})) + " / " +
                                                Duration(Num(f, {"seconds", "final_solve"})) +
                                                " / " + Duration(Num(f, {"seconds", "total"}))},
  });
  std::vector<std::vector<std::string>> rows;
  if (const json* ps = At(f, {"passes"}); ps != nullptr && ps->is_array()) {
    for (const json& p : *ps) {
      std::optional<double> shift;
      if (const json* m = At(p, {"mean_shift_m"}); m != nullptr && m->is_array()) {
        double n2 = 0;
        for (const json& v : *m) n2 += v.is_number() ? v.get<double>() * v.get<double>() : 0;
        shift = 1000.0 * std::sqrt(n2);
      }
      rows.push_back({E(Str(p, {"session"})), E(Str(p, {"pass"})), I(Num(p, {"images"})),
                      F(shift, 1), F(Num(p, {"rotation_change_deg"}), 3)});
    }
  }
  if (!rows.empty()) {
    s.html +=
        Details(fmt::format("Change from row SLAM, every pass ({})", rows.size()),
                Table({"session", "pass", "images", "mean shift [mm]", "rotation change [deg]"},
                      rows, "llrrr"));
  }
  return s;
}

// ---- dense --------------------------------------------------------------------------------------

Section Builder::DenseSection() {
  Section s{{"dense", "Dense clouds", false}, ""};
  std::vector<std::vector<std::string>> rows;
  double total = 0;
  for (const std::string& file_session : layout_.DenseSummarySessions()) {
    const auto summary = ReadArtefact(layout_.DenseSummary(file_session), [](const fs::path& p) {
      return workspace::ReadDenseSummary(p.string());
    });
    if (!summary) continue;
    const json* j = &summary->json;
    std::string session = summary->session.empty() ? file_session : summary->session;
    std::optional<double> secs = Num(*j, {"seconds", "total"});
    if (!secs) secs = Num(*j, {"seconds"});
    total += secs.value_or(0);
    std::optional<double> mb;
    std::error_code ec;
    const fs::path ply = layout_.DenseCloud(file_session);
    const auto bytes = fs::file_size(ply, ec);
    if (!ec) mb = bytes / 1e6;
    rows.push_back({"<span class=\"swatch\" style=\"background:" + SessionColor(session) +
                        "\"></span>" + E(session),
                    I(Num(*j, {"points"})), I(Num(*j, {"images", "used"})),
                    F(Num(*j, {"images", "mean_views_per_tile"}), 1), I(Num(*j, {"tiles"})),
                    F(mb, 1), Duration(secs)});
  }
  if (rows.empty()) {
    s.html = Empty("Densification has not run: no WS/dense/&lt;session&gt;.json.");
    return s;
  }
  s.info.has_data = true;
  rows.push_back({"<b>total</b>", "", "", "", "", "", "<b>" + Duration(total) + "</b>"});
  s.html += "<p>Height-field multi-view stereo from the fused cameras.</p>\n";
  s.html +=
      Table({"session", "points", "images used", "views per tile", "tiles", "PLY [MB]", "time"},
            rows, "lrrrrrr");
  return s;
}

// ---- cross-section ------------------------------------------------------------------------------

Section Builder::CrossSectionSection() {
  Section s{{"cross-section", "Cross-section", false}, ""};
  if (!opt_.cross_section) {
    s.html = Empty("Left out (report option).");
    return s;
  }
  if (!field_info_ || field_info_->rows.empty()) {
    s.html = Empty(field_info_ ? "No cross-section: FIELD/field.yaml declares no rows."
                               : "No cross-section: it needs the field's rows (give --field).");
    return s;
  }
  const std::vector<io::RowDeclaration>& rows = field_info_->rows;
  const io::RowDeclaration* row = &rows[(rows.size() - 1) / 2];
  if (opt_.cross_section_row) {
    auto it = std::find_if(rows.begin(), rows.end(), [&](const io::RowDeclaration& r) {
      return r.index == *opt_.cross_section_row;
    });
    if (it == rows.end()) {
      Skip(fmt::format("cross-section: field.yaml has no row {}; drawn across row {}",
                       *opt_.cross_section_row, row->index));
    } else {
      row = &*it;
    }
  }
  const CrossSectionSlice slice = SliceAcrossRow(*row, std::nullopt, opt_.cross_section_thickness_m,
                                                 opt_.cross_section_half_length_m);
  // Per session: the dense cloud (only its points near the slice are kept), else the fused or
  // row SLAM cloud.
  std::vector<SessionCloud> clouds;
  int dense_count = 0;
  const Eigen::Vector2d dir = slice.direction.normalized();
  const Eigen::Vector2d left(-dir.y(), dir.x());
  for (const std::string& session : sessions_) {
    const fs::path dense = layout_.DenseCloud(session);
    if (opt_.cross_section_dense && IsFile(dense)) {
      try {
        // Read a slice at a time: only the points near the slice are held.
        io::PlyPointCloud near = io::ReadPlyWhere(dense.string(), [&](const Eigen::Vector3d& p) {
          const Eigen::Vector2d d = p.head<2>() - slice.center;
          return std::abs(d.dot(left)) <= slice.thickness_m &&
                 std::abs(d.dot(dir)) <= slice.half_length_m + slice.thickness_m;
        });
        SessionCloud c{session, {}, RelToWs(dense), {RelToWs(dense)}};
        c.cloud.points = std::move(near.points);
        c.cloud.colors = std::move(near.colors);
        clouds.push_back(std::move(c));
        ++dense_count;
        continue;
      } catch (const std::exception& e) {
        Skip("cross-section: " + Why(e) + "; the sparse cloud is used instead");
      }
    }
    if (!IsDir(layout_.SessionDir(session)) && !IsDir(layout_.FusedSessionDir(session))) continue;
    try {
      std::vector<std::string> missing;
      std::vector<SessionCloud> one = LoadSessionClouds(ws_, {session}, &missing);
      for (SessionCloud& c : one) clouds.push_back(std::move(c));
      if (!missing.empty()) {
        Skip("cross-section: session " + session + " has no cloud; left out of the figure");
      }
    } catch (const std::exception& e) {
      Skip("cross-section: " + Why(e) + "; session " + session + " left out");
    }
  }
  if (clouds.empty()) {
    s.html = Empty(
        "No cross-section: no cloud (WS/dense/&lt;session&gt;.ply, WS/fused/&lt;session&gt;/"
        "sparse.ply or row SLAM landmarks.ply).");
    return s;
  }
  CrossSectionOptions o;
  o.slice = slice;
  o.plot_width_px = 1000;
  if (dense_count > 0) o.point_radius_px = 1;
  o.max_plot_height_px = 600;
  o.title = fmt::format("Cross-section of row {} at x = {:.2f} m, y = {:.2f} m ({:.2f} m thick)",
                        row->index, o.slice.center.x(), o.slice.center.y(), o.slice.thickness_m);
  o.along_label = "position across the row [m]";
  std::vector<io::PlyPointCloud> layers;
  std::vector<std::string> labels;
  std::string sources;
  for (SessionCloud& c : clouds) {
    sources += "<li>" + E(c.session) + ": " + E(c.source) + "</li>";
    layers.push_back(std::move(c.cloud));
    labels.push_back(c.session);
  }
  const CrossSectionFigure figure = DrawCrossSection(layers, labels, o);
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", figure.image, png)) {
    Skip("cross-section: the figure could not be encoded as PNG");
    s.html = Empty("No cross-section: PNG encoding failed.");
    return s;
  }
  s.info.has_data = true;
  s.html += fmt::format(
      "<p>The paper's figure: a {:.0f} cm slice across row {}, perpendicular to it, the points of "
      "each session coloured by date (earliest dark violet, latest green); {} points of {} in the "
      "slice.</p>\n",
      100 * o.slice.thickness_m, row->index, I(double(figure.num_points)),
      dense_count == static_cast<int>(clouds.size())
          ? "the dense clouds"
          : (dense_count > 0 ? "dense and sparse clouds" : "the sparse clouds"));
  s.html += "<figure><img alt=\"cross-section\" src=\"" +
            PngDataUri(std::string(png.begin(), png.end())) + "\"></figure>\n";
  s.html += Details("Clouds read", "<ul>" + sources + "</ul>");
  return s;
}

}  // namespace crop4d::report::html::detail
