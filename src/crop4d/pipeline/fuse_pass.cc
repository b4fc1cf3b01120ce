#include "crop4d/pipeline/fuse_pass.h"

#include "crop4d/core/error.h"
#include "crop4d/slam/session_solve.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline::fuse {
namespace {

// The pass's row-SLAM problem from its priors (summary.json) and measurements
// (measurements.bin): what row SLAM solved, so that the joint problem starts from it.
// `where` and `summary` name the pass's measurements.bin and summary.json in errors.
void BuildInput(const std::string& where, const std::string& summary, LoadedPass* pass) {
  const workspace::PassPriors& priors = pass->data.problem;
  const workspace::PassMeasurements& measured = pass->data.measurements;
  fusion::JointOptimiser::Pass& input = pass->input;
  input.initial_states = pass->data.states;
  if (pass->data.has_camera()) {
    // LoadPassData checked that the measurements hold the pass's camera.
    input.camera = &measured.camera->sensor.camera;
    input.body_from_camera = measured.camera->sensor.body_from_sensor;
  }
  // Row SLAM without an IMU (cam+rtk, cam+gps): the GP prior carries the motion here too.
  if (priors.use_imu) {
    if (!measured.imu || measured.imu->samples.empty()) {
      throw InputError(where +
                       ": no IMU samples, but row SLAM used the IMU (rerun `crop4d slam "
                       "--force`)");
    }
    input.imu_samples = &measured.imu->samples;
    // The noise row SLAM used: sensor.yaml's times the factor the data asked for.
    input.imu_noise = slam::ImuNoise(measured.imu->sensor, priors.imu_noise_factor);
    input.imu_rate_hz = measured.imu->sensor.rate_hz;
  }
  if (!priors.gps.empty()) {
    if (!measured.gps || measured.gps->sensor.name != priors.gps) {
      throw InputError(where + ": no fixes of GPS '" + priors.gps +
                       "', which row SLAM used (rerun `crop4d slam --force`)");
    }
    // The slam stage applied its GPS outages before it wrote the fixes.
    input.gps_fixes = measured.gps->fixes;
    input.p_body_antenna = measured.gps->sensor.antenna_in_body;
  }
  input.level_up_body = priors.level_up_body;
  input.forward_axis_body = priors.forward_axis_body;
  input.anchor_state = priors.anchor_state;
  input.anchor_sigma_velocity = priors.anchor_sigma_velocity;
  input.still_intervals =
      workspace::StillFlags(priors.still_intervals, input.initial_states.size(), summary);
  if (priors.length_prior) {
    input.length_prior_m = priors.length_prior->first;
    input.length_prior_sigma_m = priors.length_prior->second;
  }
  input.bias_prior_mean = priors.bias_prior_mean;
  input.bias_prior_sigma = priors.bias_prior_sigma;
  // Row SLAM's camera-IMU time offset (unset: not estimated): the joint problem starts from it.
  if (pass->data.time_offset_s) input.time_offset_s = *pass->data.time_offset_s;
  // One camera clock per session: its passes' offsets lie on one line (fusion/clock_line.h).
  input.clock = pass->data.session;
  if (pass->data.has_camera()) {
    input.image_sharpness = features::SharpnessOf(pass->data.features);
  }
}

}  // namespace

void LoadPassProblem(const std::string& workspace, LoadedPass* pass) {
  pass->data = workspace::LoadPassData(
      workspace, pass->data.session, pass->data.pass,
      {.features = true, .tracks = true, .states = true, .measurements = true});
  // The joint problem reads the keypoints, their colours and the images' sharpness; the
  // descriptors (128 bytes a keypoint, most of a feature cache) are not needed after
  // association, and a step holds every pass of its sessions.
  for (features::FeatureSet& f : pass->data.features) {
    f.descriptors.clear();
    f.descriptors.shrink_to_fit();
  }
  const workspace::Layout layout(workspace);
  const std::string& session = pass->data.session;
  const std::string& id = pass->data.pass.id;
  BuildInput(layout.PassMeasurements(session, id).string(),
             layout.PassSummary(session, id).string(), pass);
  for (std::size_t c = 0; c < pass->data.tracks.cloud.size(); ++c) {
    for (const features::Observation& o : pass->data.tracks.cloud[c].observations) {
      pass->cloud_of[ImageFeatureKey(o.image, o.feature)] = static_cast<int>(c);
    }
  }
}

std::map<Timestamp, std::string> ImageNames(const LoadedPass& pass) {
  std::map<Timestamp, std::string> names;
  if (pass.data.measurements.camera) {
    for (const io::ImageEntry& e : pass.data.measurements.camera->images) names[e.t] = e.filename;
  }
  return names;
}

// The cloud tracks of a pass (their keypoints and colours) triangulated from the given cameras
// (one per image).
slam::TrackCloud CloudOfTracks(const LoadedPass& pass, const geometry::PinholeRadTan& camera,
                               const std::vector<geometry::Rigid3>& cameras,
                               const slam::TriangulationOptions& options) {
  const workspace::PassData& data = pass.data;
  std::vector<slam::LandmarkTrack> tracks(data.tracks.cloud.size());
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    for (const features::Observation& o : data.tracks.cloud[i].observations) {
      tracks[i].observations.push_back({o.image, data.features[o.image].Point(o.feature)});
    }
    tracks[i].color = data.tracks.cloud[i].color;
  }
  return slam::TriangulateTrackCloud(camera, cameras, tracks, options);
}

}  // namespace crop4d::pipeline::fuse
