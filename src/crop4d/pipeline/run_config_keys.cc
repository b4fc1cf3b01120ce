// The table of `crop4d run`'s configuration keys (run_config_keys.h): typed key builders
// (number, integer, flag, path, word, enum) that bind a key to its option by dotted path, and
// the keys of each section with their ranges and comments.

#include "crop4d/pipeline/run_config_keys.h"

#include <fmt/format.h>

#include <cmath>
#include <optional>

#include "crop4d/core/error.h"
#include "crop4d/io/yaml_util.h"
#include "crop4d/pipeline/stage_option_fields.h"

namespace crop4d::pipeline {

namespace {

using Key = ConfigKey;

// The upper bound of a range that has none in practice.
constexpr double kHuge = 1e9;

// The option at `path`; a path that names no field of type T is a programmer error.
template <typename T>
T& FieldOf(RunConfig& c, const char* path) {
  T* field = fields::FindField<T>(c, path);
  CROP4D_CHECK_MSG(field != nullptr, std::string("a configuration key is bound to '") + path +
                                         "', which is no field of that type in RunConfig's "
                                         "field lists (stage_option_fields.h)");
  return *field;
}

std::string FormatDouble(double v) {
  std::string s = fmt::format("{:.10g}", v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

Key Double(const char* section, const char* name, const char* comment, const char* field,
           double min, double max) {
  return {section,
          name,
          comment,
          field,
          [field](RunConfig& c) { return FormatDouble(FieldOf<double>(c, field)); },
          [field, min, max](RunConfig& c, const std::string& text) -> std::string {
            double v = 0;
            if (!io::ParseYamlDouble(text, &v) || !std::isfinite(v)) return "expected a number";
            if (v < min || v > max) return fmt::format("expected a value in [{}, {}]", min, max);
            FieldOf<double>(c, field) = v;
            return "";
          }};
}

Key Int(const char* section, const char* name, const char* comment, const char* field, int min,
        int max) {
  return {section,
          name,
          comment,
          field,
          [field](RunConfig& c) { return std::to_string(FieldOf<int>(c, field)); },
          [field, min, max](RunConfig& c, const std::string& text) -> std::string {
            std::size_t used = 0;
            long v = 0;
            try {
              v = std::stol(text, &used);
            } catch (const std::exception&) {
              used = 0;
            }
            if (used == 0 || used != text.size()) return "expected an integer";
            if (v < min || v > max) return fmt::format("expected an integer in [{}, {}]", min, max);
            FieldOf<int>(c, field) = static_cast<int>(v);
            return "";
          }};
}

Key Bool(const char* section, const char* name, const char* comment, const char* field) {
  return {section,
          name,
          comment,
          field,
          [field](RunConfig& c) { return FieldOf<bool>(c, field) ? "true" : "false"; },
          [field](RunConfig& c, const std::string& text) -> std::string {
            if (text == "true") {
              FieldOf<bool>(c, field) = true;
            } else if (text == "false") {
              FieldOf<bool>(c, field) = false;
            } else {
              return "expected true or false";
            }
            return "";
          }};
}

std::string Quote(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    out += ch;
  }
  return out + "\"";
}

// A free string (a path).
Key String(const char* section, const char* name, const char* comment, const char* field) {
  return {section,
          name,
          comment,
          field,
          [field](RunConfig& c) { return Quote(FieldOf<std::string>(c, field)); },
          [field](RunConfig& c, const std::string& text) -> std::string {
            FieldOf<std::string>(c, field) = text;
            return "";
          }};
}

// One of a few words; `get`/`set` convert between the word and the option.
Key Choice(const char* section, const char* name, const char* comment, const char* field,
           std::vector<std::string> words, std::function<std::string(RunConfig&)> get,
           std::function<void(RunConfig&, const std::string&)> set) {
  return {section,
          name,
          comment,
          field,
          get,
          [words, set](RunConfig& c, const std::string& text) -> std::string {
            for (const std::string& w : words) {
              if (w == text) {
                set(c, text);
                return "";
              }
            }
            std::string list;
            for (const std::string& w : words) list += (list.empty() ? "" : ", ") + w;
            return "expected one of " + list;
          }};
}

// An optional<bool> field as the words auto (unset), true and false.
Key AutoBool(const char* section, const char* name, const char* comment, const char* field) {
  return Choice(
      section, name, comment, field, {"auto", "true", "false"},
      [field](RunConfig& c) -> std::string {
        const std::optional<bool>& v = FieldOf<std::optional<bool>>(c, field);
        return !v ? "auto" : (*v ? "true" : "false");
      },
      [field](RunConfig& c, const std::string& w) {
        FieldOf<std::optional<bool>>(c, field) =
            w == "auto" ? std::nullopt : std::optional<bool>(w == "true");
      });
}

// A string option that takes one of `words` as is.
Key Word(const char* section, const char* name, const char* comment, std::vector<std::string> words,
         const char* field) {
  return Choice(
      section, name, comment, field, std::move(words),
      [field](RunConfig& c) { return FieldOf<std::string>(c, field); },
      [field](RunConfig& c, const std::string& w) { FieldOf<std::string>(c, field) = w; });
}

// An enum option, by the names of its values (FieldEnumNames); with `unset_word`, an optional
// one that this word leaves unset.
template <typename E>
Key Enum(const char* section, const char* name, const char* comment, const char* field,
         const char* unset_word = nullptr) {
  std::vector<std::string> words;
  if (unset_word != nullptr) words.emplace_back(unset_word);
  for (const fields::EnumName<E>& n : FieldEnumNames(E{})) words.emplace_back(n.name);
  auto value = [](const std::string& word) {
    for (const fields::EnumName<E>& n : FieldEnumNames(E{})) {
      if (word == n.name) return n.value;
    }
    return E{};  // not reached: Choice passes only the words
  };
  if (unset_word == nullptr) {
    return Choice(
        section, name, comment, field, std::move(words),
        [field](RunConfig& c) -> std::string {
          return fields::EnumValueName(FieldOf<E>(c, field));
        },
        [field, value](RunConfig& c, const std::string& w) { FieldOf<E>(c, field) = value(w); });
  }
  const std::string unset = unset_word;
  return Choice(
      section, name, comment, field, std::move(words),
      [field, unset](RunConfig& c) -> std::string {
        const std::optional<E>& v = FieldOf<std::optional<E>>(c, field);
        return v ? fields::EnumValueName(*v) : unset;
      },
      [field, value, unset](RunConfig& c, const std::string& w) {
        FieldOf<std::optional<E>>(c, field) =
            w == unset ? std::nullopt : std::optional<E>(value(w));
      });
}

// The top level and `stages`: threads and which optional stages run.
void AddRunKeys(std::vector<Key>& k) {
  k.push_back(Int("", "threads", "worker threads for every stage (0: all cores)", "threads", 0,
                  RunConfig::kMaxThreads));

  k.push_back(Bool("stages", "densify",
                   "dense clouds before the analysis (else the analysis uses the sparse clouds)",
                   "densify"));
  k.push_back(Word("stages", "eval",
                   "evaluation against ground truth: auto (when FIELD/ground_truth/ exists), "
                   "always, never",
                   {"auto", "always", "never"}, "eval"));
  k.push_back(Bool("stages", "report", "write WS/report.html at the end", "report"));
}

// `slam`: row SLAM of each pass (slam_stage.h).
void AddSlamKeys(std::vector<Key>& k) {
  k.push_back(Enum<slam::SensorSet>(
      "slam", "sensors",
      "sensor set: auto (cam+imu+rtk with an RTK receiver, else cam+imu+gps, else cam+imu), "
      "cam+imu+rtk, cam+imu+gps, cam+imu, imu+rtk",
      "slam.sensors", "auto"));
  k.push_back(Int("slam", "neighbors", "each image is matched with this many following images",
                  "slam.front_end.num_neighbors", 1, 50));
  k.push_back(Int("slam", "min_track_length", "a landmark is seen in at least this many images",
                  "slam.front_end.tracks.min_track_length", 2, 1000));
  k.push_back(Double("slam", "max_reprojection_error_px",
                     "observations above this error are removed before the final solve",
                     "slam.optimiser.max_reprojection_error_px", 0.1, 1000));
  k.push_back(Double("slam", "state_rate_hz", "states per second of a camera-less pass",
                     "slam.state_rate_hz", 0.1, 1000));
  k.push_back(Bool("slam", "motion_constraint",
                   "the non-holonomic constraint of a vehicle on row passes",
                   "slam.motion_constraint"));
  k.push_back(Bool("slam", "imu_noise_auto",
                   "inflate the stated IMU noise when the session's IMU + GPS fit misses the "
                   "fixes by more than 1.5 sigmas (false: warn only)",
                   "slam.imu_noise_auto"));
  k.push_back(Enum<PassMode>(
      "slam", "passes",
      "auto (row passes where the drive has rows, declared or clearly found; else one "
      "trajectory), rows (every straight pass along the rows' axis) or whole (one trajectory)",
      "slam.pass_mode"));
  k.push_back(Double(
      "slam", "max_window_s",
      "a session processed as one trajectory is cut into windows of at most this many seconds",
      "slam.max_window_s", 30, 1e6));
  k.push_back(Bool("slam", "estimate_time_offset",
                   "estimate the camera-IMU time offset of each pass (capture instant - image "
                   "stamp; for rigs whose camera and IMU clocks are not synchronised)",
                   "slam.optimiser.estimate_time_offset"));
  k.push_back(Double("slam", "gps_gate_chi2",
                     "drop GPS fixes whose residual against the trajectory, in their own "
                     "sigmas, has a squared norm above this (chi-square, 3 dof; 21.1: 1e-4 "
                     "false rejections; 0: off, the Huber loss only)",
                     "slam.optimiser.gps_gate_chi2", 0, 1e6));
  k.push_back(Bool("slam", "image_weighting",
                   "images less sharp than their neighbours (motion blur, a darker exposure) get "
                   "a larger reprojection sigma, sqrt(their neighbours' median sharpness / "
                   "theirs), up to 3x",
                   "slam.optimiser.image_weighting.enabled"));
  k.push_back(Bool("slam", "standstills",
                   "detect standstills (zero velocity, one pose while the rig stands still)",
                   "slam.standstills"));
  k.push_back(Double(
      "slam", "camera_height_m",
      "camera above the ground, measured on the rig: the scale of passes without RTK (0: the "
      "camera's sensor.yaml height_above_ground_m, if any)",
      "slam.camera_height_m", 0, 100));
  k.push_back(Bool("slam", "use_camera_height",
                   "set the scale of passes without RTK from the camera height, when known",
                   "slam.use_camera_height"));
}

// `associate`: cross-pass matching (associate_stage.h).
void AddAssociateKeys(std::vector<Key>& k) {
  k.push_back(Word("associate", "method",
                   "robust (the paper's), naive (whole-image baseline) or both",
                   {"robust", "naive", "both"}, "associate.method"));
  k.push_back(Int("associate", "session_gap",
                  "a row is matched with the same row in this many later sessions",
                  "associate.session_gap", 1, 1000));
  k.push_back(Double("associate", "min_overlap",
                     "image pairs need this ground-footprint overlap (0..1)",
                     "associate.image_pairs.min_overlap", 0.0, 1.0));
  k.push_back(Int("associate", "pairs_per_image", "image pairs per image of the first pass",
                  "associate.image_pairs.max_pairs_per_image", 1, 1000));
  k.push_back(Double("associate", "sigma_position_m",
                     "position uncertainty of the row-SLAM poses for the bounded search",
                     "associate.robust.sigma_position_m", 0.0, kHuge));
  k.push_back(Double("associate", "max_ratio", "distinctiveness ratio of a match",
                     "associate.robust.max_ratio", 0.01, 1.0));
  k.push_back(Double("associate", "warp_baseline_m", "plane-induced warp beyond this baseline",
                     "associate.robust.warp_min_baseline_m", 0.0, kHuge));
  k.push_back(Word("associate", "prealign",
                   "pre-alignment of passes placed by a metre-level GPS: auto, always, never",
                   {"auto", "always", "never"}, "associate.prealign"));
  k.push_back(Int("associate", "min_track_length",
                  "landmarks projected from row-SLAM tracks of at least this many images",
                  "associate.min_track_length", 2, 1000));
  k.push_back(Double("associate", "max_landmark_distance_m",
                     "landmarks projected up to this distance from the camera",
                     "associate.max_landmark_distance_m", 0.1, kHuge));
  k.push_back(Bool("associate", "surface_points",
                   "also project the features that are no landmark, placed on the local "
                   "surface of the landmarks around them",
                   "associate.surface_points"));
  k.push_back(Bool("associate", "upright",
                   "describe warped keypoints and their candidates upright in the second "
                   "image's pixel grid rather than at SIFT's orientations",
                   "associate.robust.upright_after_warp"));
}

// `fuse`: the joint 4D problem (fuse_stage.h).
void AddFuseKeys(std::vector<Key>& k) {
  k.push_back(Word("fuse", "method", "the associations used: robust or naive", {"robust", "naive"},
                   "fuse.method"));
  k.push_back(Bool("fuse", "full",
                   "re-optimise the whole season after the steps session by session, a window "
                   "at a time: backward and forward sweeps with the sessions on both sides held",
                   "fuse.full"));
  k.push_back(Int("fuse", "full_sweeps", "rounds of a backward and a forward sweep of fuse.full",
                  "fuse.full_sweeps", 1, 100));
  k.push_back(Bool("fuse", "one_problem",
                   "one joint problem over the whole season, rebuilt when a session is added "
                   "(memory grows with the season; default: session by session)",
                   "fuse.one_problem"));
  k.push_back(Int("fuse", "window_sessions",
                  "sessions before the new one that each step of the incremental fuse "
                  "optimises again (the one before them is held)",
                  "fuse.window_sessions", 1, 1000));
  k.push_back(Int("fuse", "max_block_observations",
                  "a joint problem whose free passes hold more observations is solved in blocks "
                  "of neighbouring passes of at most this many, for bounded memory (0: never)",
                  "fuse.blocks.max_observations", 0, 2000000000));
  k.push_back(Int("fuse", "block_sweeps",
                  "sweeps over the blocks of a problem solved in blocks (the last holds the "
                  "calibration that the others refined)",
                  "fuse.blocks.sweeps", 1, 100));
  k.push_back(Int("fuse", "matches_per_image_pair",
                  "cross matches of one image pair used at most (0: all)",
                  "fuse.max_matches_per_image_pair", 0, 1000000));
  k.push_back(Double("fuse", "max_reprojection_error_px",
                     "observations above this error are removed before the final solve",
                     "fuse.optimiser.row.max_reprojection_error_px", 0.1, 1000));
  k.push_back(Double("fuse", "gps_gate_chi2",
                     "the GPS outlier gate of the joint problem (as slam.gps_gate_chi2; 0: off)",
                     "fuse.optimiser.row.gps_gate_chi2", 0, 1e6));
  k.push_back(Int("fuse", "max_iterations", "Levenberg-Marquardt iterations per solve",
                  "fuse.optimiser.row.max_iterations", 1, 100000));
  k.push_back(
      Double("fuse", "function_tolerance",
             "a solve stops when an iteration lowers the cost by less than this fraction of it",
             "fuse.optimiser.row.function_tolerance", 1e-12, 0.1));
  k.push_back(Double(
      "fuse", "max_imu_gap_s",
      "a pass with no IMU sample for longer than this degrades its session (season_quality.h)",
      "fuse.quality.max_imu_gap_s", 0.001, 1e6));
  k.push_back(Double("fuse", "max_gps_rejected_share",
                     "a pass whose row SLAM rejected more than this share of its GPS fixes as "
                     "outliers degrades its session (season_quality.h)",
                     "fuse.quality.max_gps_rejected_share", 0.0, 1.0));
  k.push_back(Choice(
      "fuse", "linear_solver",
      "exact (sparse Cholesky of the Schur complement) or iterative (conjugate gradients)",
      "fuse.optimiser.row.iterative_schur", {"exact", "iterative"},
      [](RunConfig& c) -> std::string {
        return FieldOf<bool>(c, "fuse.optimiser.row.iterative_schur") ? "iterative" : "exact";
      },
      [](RunConfig& c, const std::string& w) {
        FieldOf<bool>(c, "fuse.optimiser.row.iterative_schur") = w == "iterative";
      }));
  k.push_back(Bool("fuse", "image_weighting", "as slam.image_weighting, in the joint problem",
                   "fuse.optimiser.row.image_weighting.enabled"));
  k.push_back(AutoBool(
      "fuse", "estimate_time_offset",
      "refine each pass's camera-IMU time offset in the joint problem: auto (the passes whose "
      "row SLAM estimated one, slam.estimate_time_offset), true (every pass) or false (row "
      "SLAM's held)",
      "fuse.optimiser.estimate_time_offset"));
  k.push_back(Double("fuse", "clock_line_sigma_s",
                     "the time offsets of a session's passes lie on one line over time (one "
                     "camera clock, a steady drift), each within this standard deviation; 0: "
                     "each pass's offset on its own (docs/fusion.md)",
                     "fuse.optimiser.clock_line_sigma_s", 0, 1));
  k.push_back(AutoBool(
      "fuse", "refine_calibration",
      "refine each camera's intrinsics and T_BS rotation in the joint problem: auto (where its "
      "passes' time offsets are estimated and its images hold "
      "calibration_min_cross_observations), true or false (as written)",
      "fuse.optimiser.calibration.refine"));
  k.push_back(Bool("fuse", "refine_lever_arm",
                   "with refine_calibration, also refine the camera's lever arm (trades with the "
                   "time offset along the track; docs/fusion.md)",
                   "fuse.optimiser.calibration.refine_lever_arm"));
  k.push_back(Int("fuse", "calibration_min_cross_observations",
                  "refine_calibration auto: the observations of landmarks shared between passes "
                  "a camera's images need",
                  "fuse.optimiser.calibration.min_cross_observations", 0, 1000000000));
  k.push_back(Bool("fuse", "colmap", "write the COLMAP text model of the fused reconstruction",
                   "fuse.write_colmap"));
  k.push_back(Bool("fuse", "ground_ties",
                   "tie the two dates of a row through their soil where association found "
                   "no cross matches",
                   "fuse.ground_ties"));
  k.push_back(
      Int("fuse", "ground_tie_max_matches",
          "pairs of passes of two sessions with fewer cross matches than this get ground ties",
          "fuse.ground_tie_max_matches", 0, 1000000));
}

// `densify`: the dense clouds (densify_stage.h).
void AddDensifyKeys(std::vector<Key>& k) {
  k.push_back(Double("densify", "cell_m", "cell of the height-field grid",
                     "densify_options.stereo.cell_m", 0.001, 1.0));
  k.push_back(Double("densify", "max_canopy_height_m", "heights swept above the ground",
                     "densify_options.stereo.max_canopy_height_m", 0.01, 100));
  k.push_back(Bool("densify", "adaptive_ceiling",
                   "sweep each session only up to the canopy its sparse cloud shows (at most "
                   "max_canopy_height_m)",
                   "densify_options.adaptive_ceiling"));
  k.push_back(Double("densify", "margin_m", "the crop rows widened by this much",
                     "densify_options.margin_m", 0.0, 1000));
  k.push_back(Int("densify", "max_views", "views compared with the reference view per cell",
                  "densify_options.stereo.max_views", 1, 100));
  k.push_back(Double("densify", "near_time_s",
                     "tiles with plants are matched in images captured within this time of "
                     "their reference (leaves sway in the wind; 0: any time)",
                     "densify_options.stereo.near_time_s", 0.0, 1e6));
  k.push_back(Double("densify", "min_score", "aggregated ZNCC a cell needs",
                     "densify_options.stereo.min_score", -1.0, 1.0));
  k.push_back(
      Double("densify", "top_surface_margin",
             "a green peak above a cell's best height (a top leaf) scoring at most this much "
             "less wins (0: off)",
             "densify_options.stereo.top_surface_margin", 0.0, 2.0));
  k.push_back(Double("densify", "load_block_m",
                     "tiles matched block by block, squares of this side, with only their "
                     "images in memory (larger: fewer images loaded twice)",
                     "densify_options.stereo.load_block_m", 0.1, 1e6));
  k.push_back(Bool("densify", "around_sites", "only discs of radius_m around the sites",
                   "densify_options.around_sites"));
  k.push_back(Double("densify", "radius_m", "radius of the discs of around_sites",
                     "densify_options.radius_m", 0.01, 1000));
}

// `analyze`: terrain, canopy heights and plants (analyze_stage.h).
void AddAnalyzeKeys(std::vector<Key>& k) {
  k.push_back(String("analyze", "sites",
                     "sites file (CSV: site_id,x,y,radius_m or site_id,lat,lon,radius_m); \"\": "
                     "the sites of field.yaml",
                     "analyze.sites_file"));
  k.push_back(Word("analyze", "cloud", "clouds analysed: auto (dense when present), dense, sparse",
                   {"auto", "dense", "sparse"}, "analyze.cloud"));
  k.push_back(Choice(
      "analyze", "greenness", "vegetation index: exg or exgr", "analyze.vegetation.index",
      {"exg", "exgr"},
      [](RunConfig& c) -> std::string {
        return FieldOf<analysis::GreennessIndex>(c, "analyze.vegetation.index") ==
                       analysis::GreennessIndex::kExGR
                   ? "exgr"
                   : "exg";
      },
      [](RunConfig& c, const std::string& w) {
        FieldOf<analysis::GreennessIndex>(c, "analyze.vegetation.index") =
            w == "exgr" ? analysis::GreennessIndex::kExGR : analysis::GreennessIndex::kExG;
      }));
  k.push_back(Enum<analysis::CanopyTop>(
      "analyze", "canopy_top", "canopy height per site: plant-tops, crown-peaks or quantile",
      "analyze.canopy.top"));
  k.push_back(Double("analyze", "plant_top_quantile", "quantile of a plant's canopy cells",
                     "analyze.canopy.plant_top_quantile", 0.0, 1.0));
  k.push_back(Double("analyze", "max_shrink_m",
                     "a plant's top is at most its top in the next session plus this (-1: off)",
                     "analyze.canopy.max_shrink_m", -1.0, 10));
  k.push_back(
      Double("analyze", "plant_min_prominence_m",
             "touching plants are split where the lower top rises this much above the saddle",
             "analyze.plants.min_prominence_m", 0.0, 10));
  k.push_back(Double("analyze", "plant_max_row_offset_m",
                     "plants farther than this from every declared row count at no site (0: off)",
                     "analyze.plants.max_row_offset_m", 0.0, 100));
  k.push_back(Double("analyze", "min_canopy_height_m",
                     "vegetation this far above the terrain is canopy",
                     "analyze.canopy.min_height_m", 0.0, 10));
  k.push_back(Double("analyze", "min_canopy_height_any_colour_m",
                     "any point this far above the terrain is canopy",
                     "analyze.canopy.min_height_any_colour_m", 0.0, 10));
  k.push_back(Double("analyze", "terrain_cell_m", "cell of the terrain model",
                     "analyze.terrain.cell_m", 0.005, 10));
  k.push_back(Double("analyze", "terrain_radius_m", "radius of the terrain's local fits",
                     "analyze.terrain.fit_radius_m", 0.01, 100));
  k.push_back(Double(
      "analyze", "ground_filter_window_m",
      "soil-coloured points above the ground's opening with this window are not ground (0: off)",
      "analyze.terrain.ground_filter.window_m", 0.0, 100));
  k.push_back(Double("analyze", "ground_filter_height_m", "... when more than this above it",
                     "analyze.terrain.ground_filter.max_height_m", 0.001, 10));
  k.push_back(Bool("analyze", "later_session_terrain",
                   "refine the terrain with later sessions' bare ground",
                   "analyze.terrain.use_later_sessions"));
  k.push_back(
      Double("analyze", "lone_point_radius_m",
             "dense clouds: points without another within this radius are left out (0: none)",
             "analyze.lone_point_radius_m", 0.0, 1.0));
  k.push_back(Double("analyze", "tile_m",
                     "sessions read in tiles of this length along the area (0: whole)",
                     "analyze.tile_m", 0.0, 1e6));
  k.push_back(Double("analyze", "raster_cell_m", "cell of the GeoTIFF rasters",
                     "analyze.raster_cell_m", 0.001, 100));
}

// `eval`: the evaluation against ground truth (eval/workspace_eval.h).
void AddEvalKeys(std::vector<Key>& k) {
  k.push_back(Double("eval", "rpe_distance_m", "relative pose error over this path length",
                     "eval_options.metrics.rpe_distance_m", 0.01, kHuge));
  k.push_back(Double("eval", "match_distance_m", "a cross match is correct within this distance",
                     "eval_options.association.max_distance_m", 0.0001, 100));
  k.push_back(Double("eval", "canopy_max_error_m",
                     "a canopy height further from the truth is a failure",
                     "eval_options.canopy_options.max_error_m", 0.0001, 100));
  k.push_back(Bool("eval", "associations",
                   "precision of the cross matches (renders a true depth map per matched image: "
                   "the slow part of the evaluation)",
                   "eval_options.associations"));
  k.push_back(String("eval", "depth_cache",
                     "where rendered true depth maps are kept (\"\": "
                     "WS/eval/depth)",
                     "eval_options.depth_cache_dir"));
}

}  // namespace

const std::vector<ConfigKey>& ConfigKeys() {
  static const std::vector<ConfigKey> keys = [] {
    std::vector<Key> k;
    AddRunKeys(k);
    AddSlamKeys(k);
    AddAssociateKeys(k);
    AddFuseKeys(k);
    AddDensifyKeys(k);
    AddAnalyzeKeys(k);
    AddEvalKeys(k);
    // Every key's field is there, of its type (aborts otherwise: a programmer error).
    RunConfig defaults;
    for (const Key& key : k) key.get(defaults);
    return k;
  }();
  return keys;
}

std::vector<RunConfigKey> RunConfigKeys() {
  std::vector<RunConfigKey> out;
  for (const Key& k : ConfigKeys()) out.push_back({k.section, k.name, k.field});
  return out;
}

}  // namespace crop4d::pipeline
