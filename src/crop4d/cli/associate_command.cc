// crop4d associate: cross matches between neighbouring row passes, in space (other rows of a
// session) and in time (the same row in the next session), DESIGN.md §2.3; outputs in
// WS/associations/<method>/ (pipeline/associate_stage.h, docs/cli.md#associate).

#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/pipeline/associate_stage.h"

namespace crop4d::cli {
namespace {

struct AssociateArgs {
  std::string field;
  std::string workspace;
  std::string pairs = "all";
  double sigma_rotation_deg = 0.3;
  bool schedule_only = false;
  pipeline::AssociateStageOptions options;
};

int RunAssociate(AssociateArgs& args) {
  pipeline::AssociateStageOptions& o = args.options;
  if (o.method != "robust" && o.method != "naive" && o.method != "both") {
    throw InputError("--method", 0, "expected robust, naive or both, got '" + o.method + "'");
  }
  if (args.pairs == "all") {
    o.same_session = o.cross_session = true;
  } else if (args.pairs == "rows") {
    o.same_session = true;
    o.cross_session = false;
  } else if (args.pairs == "sessions") {
    o.same_session = false;
    o.cross_session = true;
  } else {
    throw InputError("--pairs", 0, "expected all, rows or sessions, got '" + args.pairs + "'");
  }
  o.robust.sigma_rotation_rad = args.sigma_rotation_deg * M_PI / 180.0;
  o.naive.verification = o.robust.verification;
  if (o.prealign != "auto" && o.prealign != "always" && o.prealign != "never") {
    throw InputError("--prealign", 0, "expected auto, always or never, got '" + o.prealign + "'");
  }
  if (const std::string why = o.Check(); !why.empty()) throw InputError("crop4d associate", 0, why);
  if (args.schedule_only) {
    for (const pipeline::PassPair& p :
         pipeline::ScheduleAssociations(args.field, args.workspace, o)) {
      std::printf("%s/%s %s/%s %s\n", p.a.session.c_str(), p.a.pass.c_str(), p.b.session.c_str(),
                  p.b.pass.c_str(), pipeline::ToString(p.type));
    }
    return 0;
  }
  const auto lock = LockWorkspace(args.workspace, "crop4d associate", /*create=*/false);
  const std::vector<pipeline::PassPairReport> reports =
      pipeline::RunAssociateStage(args.field, args.workspace, o);
  if (!IsQuiet()) {
    std::printf("%-21s %-21s %-29s %-6s %6s %9s %8s %8s %8s  %s\n", "pass a", "pass b", "type",
                "method", "images", "projected", "putative", "matches", "time [s]", "status");
    for (const pipeline::PassPairReport& r : reports) {
      const std::string a = r.pair.a.session + "/" + r.pair.a.pass;
      const std::string b = r.pair.b.session + "/" + r.pair.b.pass;
      std::printf("%-21s %-21s %-29s %-6s %6d %9lld %8lld %8lld %8.1f  %s\n", a.c_str(), b.c_str(),
                  pipeline::ToString(r.pair.type), r.method.c_str(), r.image_pairs,
                  static_cast<long long>(r.projected), static_cast<long long>(r.putative),
                  static_cast<long long>(r.matches), r.seconds, r.skipped ? "up to date" : "ok");
    }
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

RunFunction SetupAssociate(CLI::App& app) {
  auto args = std::make_shared<AssociateArgs>();
  pipeline::AssociateStageOptions& o = args->options;
  app.description(
      "Cross matches between neighbouring row passes (docs/cli.md#associate, docs/fusion.md): "
      "each pass with its nearest pass in each driving direction in the same session, and with "
      "the same row in the next session. Image pairs by ground-footprint overlap from the "
      "row-SLAM poses; the robust method projects each landmark of one image into the other, "
      "searches a box around it, warps the first image by the local plane's homography beyond "
      "0.5 m of baseline and verifies with 8-point RANSAC; `--method naive` matches whole images "
      "(ratio test + RANSAC). Writes WS/associations/<method>/<a>__<b>.bin and .json; pairs that "
      "are up to date are skipped.\n\nExample:\n  crop4d associate demo/field --workspace "
      "demo/workspace --method both");
  app.add_option("field", args->field, "Field folder (docs/format.md)")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("-w,--workspace", args->workspace, "Workspace with row SLAM results")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--method", o.method, "robust, naive, or both")->capture_default_str();
  app.add_option("--pairs", args->pairs,
                 "Which neighbours: all, rows (same session only) or sessions (same row, other "
                 "sessions only)")
      ->capture_default_str();
  app.add_option("--session", o.session, "Only pairs with a pass of this session");
  app.add_option("--session-gap", o.session_gap,
                 "Match the same row up to this many sessions later")
      ->capture_default_str();
  app.add_option("--min-overlap", o.image_pairs.min_overlap,
                 "Smallest ground-footprint overlap of an image pair (0..1)")
      ->capture_default_str();
  app.add_option("--pairs-per-image", o.image_pairs.max_pairs_per_image,
                 "Images of the other pass matched with each image")
      ->capture_default_str();
  app.add_option("--sigma-position", o.robust.sigma_position_m,
                 "Relative position uncertainty of two cameras, m (sets the search box)")
      ->capture_default_str();
  app.add_option("--sigma-rotation", args->sigma_rotation_deg,
                 "Relative attitude uncertainty of two cameras, degrees (sets the search box)")
      ->capture_default_str();
  app.add_option("--max-scale-ratio", o.robust.max_scale_ratio,
                 "A candidate's keypoint size must be within this factor of the predicted one "
                 "(0: no scale check)")
      ->capture_default_str();
  app.add_option("--max-ratio", o.robust.max_ratio,
                 "Distinctiveness: best descriptor distance below this times the best rival's")
      ->capture_default_str();
  app.add_option("--warp-baseline", o.robust.warp_min_baseline_m,
                 "Warp by the local plane's homography beyond this baseline, m")
      ->capture_default_str();
  app.add_flag("!--no-upright", o.robust.upright_after_warp,
               "Compare warped descriptors at the orientation transferred from image 1 with the "
               "cached descriptors of image 2, instead of both upright in image 2's pixel grid");
  app.add_option("--prealign", o.prealign,
                 "Align the passes with naive matches before the robust search: auto (when a "
                 "pass was not solved with RTK), always or never")
      ->capture_default_str();
  app.add_option("--min-track-length", o.min_track_length,
                 "Landmarks projected: row-SLAM tracks of at least this many images")
      ->capture_default_str();
  app.add_option("--max-landmark-distance", o.max_landmark_distance_m,
                 "Landmarks projected: at most this far from the camera, m")
      ->capture_default_str();
  app.add_flag("!--no-surface-points", o.surface_points,
               "Project only row-SLAM landmarks, not the other features of the image placed on "
               "the local surface of the landmarks around them");
  app.add_option("--surface-max-sigma", o.surface.max_sigma_m,
                 "Surface points: the neighbouring landmarks may lie at most this far off the "
                 "local plane (along the ray), m")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 10.0));
  app.add_flag("--schedule", args->schedule_only, "Print the pass pairs and exit");
  app.add_option("--threads", o.num_threads, "Worker threads (0: all cores)")
      ->capture_default_str();
  app.add_flag("--force", o.force, "Associate again pairs that are up to date");
  return [args] { return RunAssociate(*args); };
}

}  // namespace crop4d::cli
