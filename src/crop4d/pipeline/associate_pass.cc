#include "crop4d/pipeline/associate_pass.h"

#include <map>
#include <optional>

#include "crop4d/association/prealignment.h"
#include "crop4d/core/task_arena.h"

namespace crop4d::pipeline::associate {
namespace {

// The key of an (image, feature) of a pass in PassContext::cloud_of.
std::uint64_t ImageFeatureKey(int image, int feature) {
  return (static_cast<std::uint64_t>(image) << 32) | static_cast<std::uint32_t>(feature);
}

}  // namespace

std::unique_ptr<PassContext> LoadPass(const std::string& field_folder, const std::string& workspace,
                                      const std::string& session, const slam::RowPass& pass,
                                      const AssociateStageOptions& options) {
  auto ctx = std::make_unique<PassContext>();
  ctx->data = workspace::LoadPassData(workspace, session, pass,
                                      {.features = true, .tracks = true, .measurements = true});
  // The camera and image files row SLAM used (LoadPassData checked that they are the pass's).
  const workspace::PassMeasurements& measured = ctx->data.measurements;
  ctx->camera = measured.camera->sensor.camera;
  ctx->precise = ctx->data.sensors.find("rtk") != std::string::npos;
  std::map<Timestamp, std::string> files;
  for (std::size_t i = 0; i < measured.camera->images.size(); ++i) {
    files[measured.camera->images[i].t] = measured.ImagePath(field_folder, i);
  }
  for (Timestamp t : ctx->data.times) {
    const auto it = files.find(t);
    ctx->image_paths.push_back(it != files.end() ? it->second : std::string());
  }
  ctx->landmarks_per_image.resize(ctx->data.times.size());
  std::vector<Eigen::Vector3d> positions;
  std::vector<double> heights;
  const std::vector<workspace::PassTrack>& cloud = ctx->data.tracks.cloud;
  for (std::size_t c = 0; c < cloud.size(); ++c) {
    positions.push_back(cloud[c].position_world);
    heights.push_back(cloud[c].position_world.z());
    for (const features::Observation& o : cloud[c].observations) {
      ctx->cloud_of[ImageFeatureKey(o.image, o.feature)] = static_cast<int>(c);
    }
    if (static_cast<int>(cloud[c].observations.size()) < options.min_track_length) continue;
    for (const features::Observation& o : cloud[c].observations) {
      ctx->landmarks_per_image[o.image].push_back(
          {o.feature, cloud[c].position_world, static_cast<std::int32_t>(c)});
    }
  }
  ctx->ground_z = association::GroundHeight(
      std::move(heights), ctx->data.poses.empty()
                              ? std::nullopt
                              : std::optional<double>(ctx->data.poses.front().translation().z()));
  if (options.method != "naive") {
    ctx->planes = std::make_unique<association::LocalPlanes>(std::move(positions));
  }
  return ctx;
}

fusion::PassAlignment PreAlign(const PassContext& a, const PassContext& b,
                               const AssociateStageOptions& options) {
  association::PreAlignmentOptions prealignment;
  prealignment.stride = options.prealign_stride;
  prealignment.radius_m = options.prealign_radius_m;
  prealignment.max_landmark_distance_m = options.max_landmark_distance_m;
  prealignment.naive = options.naive;
  prealignment.alignment = options.alignment;
  const auto view = [](const PassContext& pass) {
    return association::PreAlignmentPass{
        &pass.camera, &pass.data.poses, &pass.data.features,
        [&pass](int image, int feature) -> std::optional<Eigen::Vector3d> {
          const auto it = pass.cloud_of.find(ImageFeatureKey(image, feature));
          if (it == pass.cloud_of.end()) return std::nullopt;
          return pass.data.tracks.cloud[it->second].position_world;
        }};
  };
  fusion::PassAlignment alignment;
  InArena(options.num_threads,
          [&] { alignment = association::PreAlignPasses(view(a), view(b), prealignment); });
  return alignment;
}

}  // namespace crop4d::pipeline::associate
