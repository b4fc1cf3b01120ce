#include "crop4d/eval/dense_eval.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "crop4d/core/error.h"
#include "crop4d/eval/grid2d.h"
#include "crop4d/eval/natural_order.h"
#include "crop4d/eval/quantile.h"
#include "crop4d/io/ply.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;

// Quantiles, RMSE and shares of plant-top errors; counts are the caller's.
void SummariseTops(std::vector<double> errors, double tolerance, PlantTopStats* s) {
  if (errors.empty()) return;
  const double n = static_cast<double>(errors.size());
  double squares = 0.0;
  int within = 0, low = 0, high = 0;
  for (const double e : errors) {
    squares += e * e;
    if (e < -tolerance) {
      ++low;
    } else if (e > tolerance) {
      ++high;
    } else {
      ++within;
    }
  }
  s->rmse_m = std::sqrt(squares / n);
  s->within_share = within / n;
  s->low_share = low / n;
  s->high_share = high / n;
  s->median_m = Quantile(&errors, 0.5);
  s->p10_m = Quantile(&errors, 0.1);
  s->p90_m = Quantile(&errors, 0.9);
}

}  // namespace

OptionCheck DenseEvalOptions::Check() const {
  OptionChecker c;
  c.Greater("top_radius_m", top_radius_m, 0.0)
      .Finite("top_radius_m", top_radius_m)
      .Greater("tolerance_m", tolerance_m, 0.0)
      .Finite("tolerance_m", tolerance_m)
      .Nested("ground", ground.Check());
  return c.Result();
}

std::vector<std::string> FindDenseClouds(const std::string& workspace,
                                         const std::vector<std::string>& session_order,
                                         const std::vector<std::string>& sessions) {
  std::vector<std::string> names;
  const workspace::Layout ws(workspace);
  for (const std::string& session : ws.DenseCloudSessions()) {
    if (sessions.empty() || std::find(sessions.begin(), sessions.end(), session) != sessions.end())
      names.push_back(session);
  }
  SortByOrder(session_order, &names);
  std::vector<std::string> files;
  for (const std::string& session : names) {
    files.push_back(ws.DenseCloud(session).lexically_relative(ws.root()).generic_string());
  }
  return files;
}

DenseSessionEval EvaluateDenseCloud(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<PlantFootprint>& plants,
                                    const TerrainGrid& terrain, const DenseEvalOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "EvaluateDenseCloud");
  DenseSessionEval s;
  s.points = static_cast<std::int64_t>(points.size());

  // Plant tops: the highest point within the radius of each emerged plant's stem.
  // Only points over the terrain grid (the field) are indexed: a wild point far away, or a
  // non-finite one, can be no plant's top.
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> z;
  for (const Eigen::Vector3d& p : points) {
    double ground;
    if (!p.allFinite() || !terrain.Height(p.x(), p.y(), &ground)) continue;
    xy.push_back(p.head<2>());
    z.push_back(p.z());
  }
  const Grid2d grid(xy, options.top_radius_m);
  const double r2 = options.top_radius_m * options.top_radius_m;
  for (const PlantFootprint& plant : plants) {
    double ground;
    if (!(plant.height_m > 0.0) || !terrain.Height(plant.xy.x(), plant.xy.y(), &ground)) continue;
    ++s.tops.num_plants;
    double top = -std::numeric_limits<double>::infinity();
    grid.ForNear(plant.xy.x(), plant.xy.y(), [&](int i) {
      if ((xy[i] - plant.xy).squaredNorm() <= r2) top = std::max(top, z[i]);
    });
    if (!std::isfinite(top)) {
      ++s.tops.num_missing;
      continue;
    }
    ++s.tops.num_found;
    s.top_errors_m.push_back(top - ground - plant.height_m);
  }
  SummariseTops(s.top_errors_m, options.tolerance_m, &s.tops);

  // Soil.
  const std::vector<Eigen::Vector3d> soil =
      SelectGroundPoints(points, plants, terrain, options.ground);
  std::vector<double> dz, abs_dz;
  dz.reserve(soil.size());
  abs_dz.reserve(soil.size());
  for (const Eigen::Vector3d& p : soil) {
    double z;
    if (!terrain.Height(p.x(), p.y(), &z)) continue;
    dz.push_back(p.z() - z);
    abs_dz.push_back(std::abs(p.z() - z));
  }
  s.soil.num_points = static_cast<std::int64_t>(dz.size());
  s.soil.median_m = Quantile(&dz, 0.5);
  s.soil.abs_median_m = Quantile(&abs_dz, 0.5);
  s.soil.abs_p90_m = Quantile(&abs_dz, 0.9);
  return s;
}

DenseEval EvaluateDenseClouds(const std::string& workspace, const std::string& field,
                              const std::vector<std::string>& files,
                              const DenseEvalOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "EvaluateDenseClouds");
  DenseEval eval;
  eval.options = options;
  const fs::path truth = fs::path(field) / "ground_truth";
  TerrainGrid terrain;
  std::error_code ec;
  try {
    const fs::path terrain_path = truth / "terrain.csv";
    if (!fs::exists(terrain_path, ec)) {
      throw InputError(terrain_path.string(), 0, "file not found (the true terrain)");
    }
    terrain = TerrainGrid::Read(terrain_path.string());
  } catch (const InputError& e) {
    eval.error = e.what();
    return eval;
  }
  // Sessions in parallel (reading a cloud is most of the work), pooled in file order.
  eval.sessions.resize(files.size());
  tbb::parallel_for(std::size_t{0}, files.size(), [&](std::size_t k) {
    const std::string& file = files[k];
    const std::string session = fs::path(file).stem().string();
    DenseSessionEval& s = eval.sessions[k];
    try {
      const fs::path plants_path = truth / session / "plants.csv";
      std::error_code exists_ec;
      if (!fs::exists(plants_path, exists_ec)) {
        throw InputError(plants_path.string(), 0,
                         fmt::format("no true plants for session '{}': file not found", session));
      }
      const std::vector<PlantFootprint> plants = ReadPlantsCsv(plants_path.string());
      const io::PlyPointCloud cloud = io::ReadPly((fs::path(workspace) / file).string());
      s = EvaluateDenseCloud(cloud.points, plants, terrain, options);
    } catch (const InputError& e) {
      s = DenseSessionEval();
      s.error = e.what();
    }
    s.session = session;
    s.file = file;
  });
  std::vector<double> pooled;
  for (const DenseSessionEval& s : eval.sessions) {
    if (!s.ok()) continue;
    eval.tops.num_plants += s.tops.num_plants;
    eval.tops.num_found += s.tops.num_found;
    eval.tops.num_missing += s.tops.num_missing;
    pooled.insert(pooled.end(), s.top_errors_m.begin(), s.top_errors_m.end());
  }
  SummariseTops(std::move(pooled), options.tolerance_m, &eval.tops);
  return eval;
}

std::string FormatDenseTable(const DenseEval& eval) {
  const DenseEvalOptions& o = eval.options;
  std::string out = fmt::format(
      "dense clouds: plant top = highest point within {:g} cm of the true stem, minus the true "
      "height; soil = points clear of the plants, minus the true terrain\n",
      100.0 * o.top_radius_m);
  if (!eval.error.empty()) return out + "not evaluated: " + eval.error + "\n";
  const auto cm = [](double v, bool sign = true) {
    if (!std::isfinite(v)) return std::string("-");
    return sign ? fmt::format("{:+.2f}", 100.0 * v) : fmt::format("{:.2f}", 100.0 * v);
  };
  const auto pct = [](double v) {
    return std::isfinite(v) ? fmt::format("{:.0f}", 100.0 * v) : std::string("-");
  };
  std::size_t w = 7;
  for (const DenseSessionEval& s : eval.sessions) w = std::max(w, s.session.size());
  constexpr const char* kRow =
      "{:<{}}  {:>9}  {:>9}  {:>10}  {:>7}  {:>7}  {:>7}  {:>8}  {:>5}  {:>6}  {:>9}  {:>11}  "
      "{:>13}\n";
  out += fmt::format(fmt::runtime(kRow), "session", w, "points", "plants", "top med cm", "p10 cm",
                     "p90 cm", "rms cm", "within %", "low %", "high %", "soil N", "soil med cm",
                     "|soil| p90 cm");
  const auto line = [&](const std::string& label, const std::string& points, const PlantTopStats& t,
                        const std::string& soil_n, const std::string& soil_med,
                        const std::string& soil_p90) {
    out += fmt::format(fmt::runtime(kRow), label, w, points,
                       fmt::format("{}/{}", t.num_found, t.num_plants), cm(t.median_m), cm(t.p10_m),
                       cm(t.p90_m), cm(t.rmse_m, false), pct(t.within_share), pct(t.low_share),
                       pct(t.high_share), soil_n, soil_med, soil_p90);
  };
  for (const DenseSessionEval& s : eval.sessions) {
    if (!s.ok()) {
      out += fmt::format("{:<{}}  error: {}\n", s.session, w, s.error);
      continue;
    }
    line(s.session, std::to_string(s.points), s.tops, std::to_string(s.soil.num_points),
         cm(s.soil.median_m), cm(s.soil.abs_p90_m, false));
  }
  if (eval.sessions.size() > 1) line("all", "", eval.tops, "", "", "");
  out += fmt::format(
      "plants: found/emerged (missing: no point within the radius); within/low/high: top error "
      "within ±{0:g} cm, below -{0:g} cm (the cloud misses the top leaves), above +{0:g} cm\n",
      100.0 * o.tolerance_m);
  return out;
}

}  // namespace crop4d::eval
