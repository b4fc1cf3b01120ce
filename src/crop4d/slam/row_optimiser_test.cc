// RowOptimiser alone on synthetic data: the sensors of a simulated session (no rendering) and
// landmarks projected into the true camera poses, so every error has a known cause.

#include "crop4d/slam/row_optimiser.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/simulated_session_test_util.h"

namespace crop4d::slam {
namespace {

using testing::MakeInput;
using testing::MakeScenario;
using testing::Scenario;
using testing::TrueBody;

// Initial states: the truth perturbed by 5 cm and 2°, velocity and rate from the truth, zero
// biases.
std::vector<RowState> PerturbedTruth(const Scenario& s) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<RowState> states;
  for (Timestamp t : s.times) {
    const sim::BodyState truth = s.record.trajectory->StateAt(s.record.Seconds(t));
    RowState st;
    st.t = t;
    const Eigen::Vector3d dp(noise(rng), noise(rng), noise(rng));
    const Eigen::Vector3d dphi(noise(rng), noise(rng), noise(rng));
    st.nav.world_from_body = geometry::Rigid3(
        truth.world_from_body.rotation() * geometry::ExpQuat(dphi * (2.0 * M_PI / 180)),
        truth.world_from_body.translation() + 0.05 * dp);
    st.nav.vel_world = truth.velocity_world;
    st.nav.rate_body = truth.angular_velocity_body;
    states.push_back(st);
  }
  return states;
}

struct Errors {
  double position_rms = 0, rotation_rms_deg = 0;
};

Errors CameraErrors(const Scenario& s, const std::vector<RowState>& states) {
  Errors e;
  for (const RowState& st : states) {
    const geometry::Rigid3 est = st.nav.world_from_body * s.body_from_camera;
    const geometry::Rigid3 truth = TrueBody(s, st.t) * s.body_from_camera;
    e.position_rms += (est.translation() - truth.translation()).squaredNorm();
    const double a = geometry::AngleBetween(est.rotation(), truth.rotation()) * 180 / M_PI;
    e.rotation_rms_deg += a * a;
  }
  e.position_rms = std::sqrt(e.position_rms / states.size());
  e.rotation_rms_deg = std::sqrt(e.rotation_rms_deg / states.size());
  return e;
}

// `n` points on the ground (0–10 cm high) along the pass, up to 1 m across and 3 m along it
// from the line between the first and the last camera.
std::vector<Eigen::Vector3d> GroundPointsAlongThePass(const Scenario& s, int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const geometry::Rigid3 first = TrueBody(s, s.times.front()) * s.body_from_camera;
  const geometry::Rigid3 last = TrueBody(s, s.times.back()) * s.body_from_camera;
  std::vector<Eigen::Vector3d> points;
  for (int k = 0; k < n; ++k) {
    const double a = uniform(*rng);
    const Eigen::Vector3d along = (1 - a) * first.translation() + a * last.translation();
    points.emplace_back(along.x() + 2.0 * (uniform(*rng) - 0.5),
                        along.y() + 6.0 * (uniform(*rng) - 0.5), 0.1 * uniform(*rng));
  }
  return points;
}

// The exact pixels of `p` in the true camera of every state that sees it.
std::vector<LandmarkObservation> TrueObservations(const Scenario& s, const Eigen::Vector3d& p) {
  std::vector<LandmarkObservation> observations;
  for (std::size_t i = 0; i < s.times.size(); ++i) {
    const geometry::Rigid3 camera_from_world =
        (TrueBody(s, s.times[i]) * s.body_from_camera).Inverse();
    Eigen::Vector2d pixel;
    if (!s.camera.Project(camera_from_world * p, &pixel) || !s.camera.IsInImage(pixel)) continue;
    observations.push_back({static_cast<int>(i), pixel});
  }
  return observations;
}

TEST(RowOptimiser, ImuAndRtkAloneRecoverThePass) {
  const Scenario s = MakeScenario();
  RowOptimiser::Input input = MakeInput(s, PerturbedTruth(s));
  input.forward_axis_body = Eigen::Vector3d::UnitX();
  const RowOptimiser::Result result = RowOptimiser(RowOptimiser::Options()).Solve(input);
  EXPECT_GT(result.summary.num_gps_factors, 25);
  EXPECT_EQ(result.summary.num_imu_factors, static_cast<int>(s.times.size()) - 1);
  EXPECT_LT(result.summary.final_cost, result.summary.initial_cost);
  const Errors e = CameraErrors(s, result.states);
  EXPECT_LT(e.position_rms, 0.02);
  EXPECT_LT(e.rotation_rms_deg, 1.0);
}

// An RTK track with a stretch in RTK-float (sigmas 0.3 / 0.5 m as the receiver reports them, and
// errors that large) and four multipath fixes 5 m off: the gate drops the four and only them,
// and the pass stays within the RTK error; the Huber loss alone lets them pull it off.
TEST(RowOptimiser, GpsGateDropsMultipathOutliersAndKeepsFloatFixes) {
  const Scenario s = MakeScenario();
  RowOptimiser::Input input = MakeInput(s, PerturbedTruth(s));
  input.forward_axis_body = Eigen::Vector3d::UnitX();
  // The fixes inside the pass.
  std::vector<GpsFixWorld*> fixes;
  for (GpsFixWorld& fix : input.gps_fixes) {
    if (fix.t >= s.times.front() && fix.t <= s.times.back()) fixes.push_back(&fix);
  }
  ASSERT_GT(fixes.size(), 30u);
  std::mt19937 rng(17);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (std::size_t k = 10; k < 20; ++k) {
    fixes[k]->sigma_h = 0.3;
    fixes[k]->sigma_v = 0.5;
    fixes[k]->position_world +=
        Eigen::Vector3d(0.3 * noise(rng), 0.3 * noise(rng), 0.5 * noise(rng));
  }
  const std::vector<std::pair<std::size_t, Eigen::Vector3d>> outliers{
      {3, {3.0, 4.0, 0.0}}, {23, {-4.0, 3.0, 0.0}}, {27, {0.0, -4.0, 3.0}}, {31, {5.0, 0.0, 0.0}}};
  for (const auto& [k, offset] : outliers) fixes[k]->position_world += offset;  // 5 m
  RowOptimiser::Options options;
  const RowOptimiser::Result huber = RowOptimiser(options).Solve(input);
  options.gps_gate_chi2 = 21.1;
  const RowOptimiser::Result gated = RowOptimiser(options).Solve(input);
  EXPECT_EQ(huber.summary.num_gps_rejected, 0);
  EXPECT_EQ(gated.summary.num_gps_rejected, 4);
  const Errors e_huber = CameraErrors(s, huber.states);
  const Errors e_gated = CameraErrors(s, gated.states);
  std::printf("GPS outliers: position RMS %.1f mm gated, %.1f mm Huber only\n",
              1e3 * e_gated.position_rms, 1e3 * e_huber.position_rms);
  EXPECT_LT(e_gated.position_rms, 0.02);
  EXPECT_LT(e_gated.position_rms, e_huber.position_rms);
}

TEST(RowOptimiser, LandmarksFixTheAttitudeAndOutliersAreRejected) {
  const Scenario s = MakeScenario();
  // Landmarks on the ground ahead of the cameras, seen with 0.5 px noise; every 50th
  // observation is an outlier 20–40 px away.
  std::mt19937 rng(11);
  std::normal_distribution<double> pixel_noise(0.0, 0.5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const std::vector<Eigen::Vector3d> points = GroundPointsAlongThePass(s, 1500, &rng);
  RowOptimiser::Input input = MakeInput(s, PerturbedTruth(s));
  input.camera = &s.camera;
  input.body_from_camera = s.body_from_camera;
  int outliers = 0, count = 0;
  std::vector<int> track_point;
  for (std::size_t point = 0; point < points.size(); ++point) {
    LandmarkTrack track;
    for (LandmarkObservation o : TrueObservations(s, points[point])) {
      o.pixel += Eigen::Vector2d(pixel_noise(rng), pixel_noise(rng));
      if (++count % 50 == 0) {
        o.pixel += Eigen::Vector2d(20 + 20 * uniform(rng), -20 - 20 * uniform(rng));
        ++outliers;
      }
      track.observations.push_back(o);
    }
    if (track.observations.size() >= 7) {
      input.tracks.push_back(track);
      track_point.push_back(static_cast<int>(point));
    }
  }
  ASSERT_GT(input.tracks.size(), 300u);
  const RowOptimiser::Result result = RowOptimiser(RowOptimiser::Options()).Solve(input);
  EXPECT_GT(result.summary.num_landmarks_final, 300);
  // Most outliers are removed; no more than twice their number of observations is lost.
  EXPECT_GE(result.summary.num_rejected_observations, outliers * 8 / 10);
  EXPECT_LE(result.summary.num_rejected_observations, 2 * outliers + 50);
  EXPECT_LT(result.summary.reprojection_rms_px, 1.0);
  const Errors e = CameraErrors(s, result.states);
  EXPECT_LT(e.position_rms, 0.015);
  EXPECT_LT(e.rotation_rms_deg, 0.15);
  // Landmarks land on their true positions.
  double landmark_ss = 0;
  for (std::size_t l = 0; l < result.landmarks_world.size(); ++l) {
    const Eigen::Vector3d& truth = points[track_point[result.landmark_tracks[l]]];
    landmark_ss += (result.landmarks_world[l] - truth).squaredNorm();
  }
  EXPECT_LT(std::sqrt(landmark_ss / result.landmarks_world.size()), 0.03);
}

// Every third image blurred: its keypoints are six times less precise (3 px against 0.5 px)
// and its sharpness a 36th of the others' (Cramér–Rao: sigma ∝ 1/√energy). Weighted by their
// sharpness, the blurred images no longer pull the landmarks (and the poses) off; their
// observations are kept.
TEST(RowOptimiser, BlurredImagesAreDownWeighted) {
  const Scenario s = MakeScenario();
  std::mt19937 rng(13);
  std::normal_distribution<double> unit(0.0, 1.0);
  RowOptimiser::Input input = MakeInput(s, PerturbedTruth(s));
  input.camera = &s.camera;
  input.body_from_camera = s.body_from_camera;
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& p : GroundPointsAlongThePass(s, 1500, &rng)) {
    LandmarkTrack track;
    for (LandmarkObservation o : TrueObservations(s, p)) {
      const double sigma = o.state % 3 == 1 ? 3.0 : 0.5;
      o.pixel += sigma * Eigen::Vector2d(unit(rng), unit(rng));
      track.observations.push_back(o);
    }
    if (track.observations.size() >= 7) {
      input.tracks.push_back(track);
      points.push_back(p);
    }
  }
  ASSERT_GT(input.tracks.size(), 300u);
  const auto landmark_rms = [&](const RowOptimiser::Result& r) {
    double ss = 0;
    for (std::size_t l = 0; l < r.landmarks_world.size(); ++l) {
      ss += (r.landmarks_world[l] - points[r.landmark_tracks[l]]).squaredNorm();
    }
    return std::sqrt(ss / r.landmarks_world.size());
  };
  input.image_sharpness.resize(s.times.size());
  for (std::size_t i = 0; i < s.times.size(); ++i) {
    input.image_sharpness[i] = i % 3 == 1 ? 100.0 / 36.0 : 100.0;
  }
  RowOptimiser::Options options;
  options.image_weighting.max_sigma_scale = 6.0;
  const RowOptimiser::Result weighted = RowOptimiser(options).Solve(input);
  options.image_weighting.enabled = false;
  const RowOptimiser::Result flat = RowOptimiser(options).Solve(input);

  EXPECT_EQ(weighted.summary.num_downweighted_images, static_cast<int>(s.times.size() / 3));
  EXPECT_NEAR(weighted.summary.max_image_sigma_scale, 6.0, 1e-9);
  EXPECT_EQ(flat.summary.num_downweighted_images, 0);
  const Errors e_weighted = CameraErrors(s, weighted.states);
  const Errors e_flat = CameraErrors(s, flat.states);
  // Measured: landmarks 12.6 mm against 18.8 mm (11.4 mm without the blurred images' extra
  // noise); the cameras, which the RTK fixes and the IMU hold too, 6.9 against 7.1 mm and
  // 0.101° against 0.103°.
  EXPECT_LT(landmark_rms(weighted), 0.75 * landmark_rms(flat));
  EXPECT_LE(e_weighted.position_rms, 1.01 * e_flat.position_rms);
  // Down-weighted, not dropped: the blurred images keep their observations.
  EXPECT_LT(weighted.summary.num_rejected_observations, 0.01 * weighted.summary.num_observations);
}

// Ground landmarks along the pass seen with 0.5 px noise, each image captured at its stamp + td
// (the camera's clock off the IMU's): the tracks of observations in at least 7 images and their
// true points.
struct CapturedTracks {
  std::vector<LandmarkTrack> tracks;
  std::vector<Eigen::Vector3d> points;
};

CapturedTracks TracksCapturedAt(const Scenario& s, double td) {
  std::mt19937 rng(23);
  std::normal_distribution<double> pixel_noise(0.0, 0.5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<geometry::Rigid3> world_from_camera, camera_from_world;
  for (Timestamp t : s.times) {
    world_from_camera.push_back(s.record.trajectory->WorldFromBody(s.record.Seconds(t) + td) *
                                s.body_from_camera);
    camera_from_world.push_back(world_from_camera.back().Inverse());
  }
  // Points on the ground (0–10 cm high) where the ray of a random pixel of a random image meets
  // it: the ground each image sees, on a straight row as in a turn.
  CapturedTracks out;
  for (int k = 0; k < 1000; ++k) {
    const geometry::Rigid3& camera =
        world_from_camera[std::min<std::size_t>(uniform(rng) * s.times.size(), s.times.size() - 1)];
    const Eigen::Vector3d ray =
        camera.rotation() * Eigen::Vector3d((uniform(rng) - 0.5) * s.camera.width / s.camera.fx,
                                            (uniform(rng) - 0.5) * s.camera.height / s.camera.fy,
                                            1.0);
    const double height = 0.1 * uniform(rng);
    if (!(ray.z() < -1e-3)) continue;
    const Eigen::Vector3d p =
        camera.translation() + ray * ((height - camera.translation().z()) / ray.z());
    if ((p - camera.translation()).norm() > 6.0) continue;  // the near ground, as the front end

    LandmarkTrack track;
    for (std::size_t i = 0; i < s.times.size(); ++i) {
      Eigen::Vector2d pixel;
      if (!s.camera.Project(camera_from_world[i] * p, &pixel) || !s.camera.IsInImage(pixel)) {
        continue;
      }
      pixel += Eigen::Vector2d(pixel_noise(rng), pixel_noise(rng));
      track.observations.push_back({static_cast<int>(i), pixel});
    }
    if (track.observations.size() >= 7) {
      out.tracks.push_back(track);
      out.points.push_back(p);
    }
  }
  return out;
}

struct TimeOffsetSolve {
  RowOptimiser::Result result;
  Errors camera;
  double landmark_rms = 0;  // m
};

// The figures docs/slam.md quotes.
void Print(const char* name, double td_true, const TimeOffsetSolve& with,
           const TimeOffsetSolve& without) {
  std::printf(
      "%s: td true %.1f ms, estimated %.2f ms; with / without the estimate: camera %.1f / %.1f "
      "mm, %.3f / %.3f deg; landmarks %.1f / %.1f cm\n",
      name, 1e3 * td_true, 1e3 * with.result.summary.time_offset_s, 1e3 * with.camera.position_rms,
      1e3 * without.camera.position_rms, with.camera.rotation_rms_deg,
      without.camera.rotation_rms_deg, 1e2 * with.landmark_rms, 1e2 * without.landmark_rms);
}

TimeOffsetSolve SolveWithTimeOffset(const Scenario& s, double td_true, bool estimate) {
  RowOptimiser::Input input = MakeInput(s, PerturbedTruth(s));
  input.camera = &s.camera;
  input.body_from_camera = s.body_from_camera;
  const CapturedTracks captured = TracksCapturedAt(s, td_true);
  input.tracks = captured.tracks;
  EXPECT_GT(input.tracks.size(), 200u);
  RowOptimiser::Options options;
  options.estimate_time_offset = estimate;
  TimeOffsetSolve out;
  out.result = RowOptimiser(options).Solve(input);
  out.camera = CameraErrors(s, out.result.states);
  const std::vector<Eigen::Vector3d>& landmarks = out.result.landmarks_world;
  for (std::size_t l = 0; l < landmarks.size(); ++l) {
    out.landmark_rms +=
        (landmarks[l] - captured.points[out.result.landmark_tracks[l]]).squaredNorm();
  }
  out.landmark_rms = std::sqrt(out.landmark_rms / std::max<std::size_t>(landmarks.size(), 1));
  return out;
}

// The first row at about 1.3 m/s: the images were captured 25 ms after their stamps. On a
// straight row at nearly constant speed td is weakly observed (moving every capture position
// and every landmark by v td along the row changes no image; only the changes of speed and the
// small turns tell td apart): its error is about 1 ms here, so the bound is the 2 ms.
TEST(RowOptimiser, EstimatesTheCameraImuTimeOffset) {
  const Scenario s = MakeScenario();
  const double td_true = 0.025;
  const TimeOffsetSolve with = SolveWithTimeOffset(s, td_true, true);
  const TimeOffsetSolve without = SolveWithTimeOffset(s, td_true, false);
  Print("row", td_true, with, without);
  ASSERT_TRUE(with.result.summary.time_offset_estimated);
  EXPECT_NEAR(with.result.summary.time_offset_s, td_true, 2e-3);
  EXPECT_FALSE(without.result.summary.time_offset_estimated);
  EXPECT_EQ(without.result.summary.time_offset_s, 0.0);
  // The states (at the stamps) and the landmarks are closer to the truth when the offset is
  // estimated: without it the landmarks absorb the distance driven in td (3 cm here).
  EXPECT_LT(with.camera.position_rms, without.camera.position_rms);
  EXPECT_LT(with.camera.rotation_rms_deg, without.camera.rotation_rms_deg);
  EXPECT_LT(with.camera.position_rms, 0.015);
  EXPECT_LT(with.landmark_rms, 0.5 * without.landmark_rms);
}

// The headland turn after the first row (from 2 s before the row's end to 8 s after): the
// rotation over td matters as much as the translation, and td is well observed.
Scenario TurnScenario() {
  Scenario s = MakeScenario();
  const double end = s.record.trajectory->passes().at(0).t_end;
  s.times.clear();
  for (Timestamp t : s.record.image_times) {
    const double ts = s.record.Seconds(t);
    if (ts >= end - 2.0 && ts <= end + 8.0) s.times.push_back(t);
  }
  return s;
}

TEST(RowOptimiser, EstimatesTheTimeOffsetInATurn) {
  const Scenario s = TurnScenario();
  double max_rate = 0;
  for (Timestamp t : s.times) {
    max_rate = std::max(
        max_rate, s.record.trajectory->StateAt(s.record.Seconds(t)).angular_velocity_body.norm());
  }
  ASSERT_GT(max_rate, 0.2);  // rad/s
  const double td_true = -0.03;
  const TimeOffsetSolve with = SolveWithTimeOffset(s, td_true, true);
  const TimeOffsetSolve without = SolveWithTimeOffset(s, td_true, false);
  Print("turn", td_true, with, without);
  ASSERT_TRUE(with.result.summary.time_offset_estimated);
  EXPECT_NEAR(with.result.summary.time_offset_s, td_true, 1e-3);
  // Without it the attitude is off by the turn over td (0.6° here).
  EXPECT_LT(with.camera.rotation_rms_deg, 0.1);
  EXPECT_LT(with.camera.rotation_rms_deg, 0.2 * without.camera.rotation_rms_deg);
  EXPECT_LT(with.camera.position_rms, 0.5 * without.camera.position_rms);
  EXPECT_LT(with.landmark_rms, 0.5 * without.landmark_rms);
}

TEST(RowOptimiser, TimeOffsetOfSynchronisedClocksIsZero) {
  const TimeOffsetSolve solve = SolveWithTimeOffset(TurnScenario(), 0.0, true);
  ASSERT_TRUE(solve.result.summary.time_offset_estimated);
  EXPECT_NEAR(solve.result.summary.time_offset_s, 0.0, 1e-3);
  std::printf("turn: td true 0 ms, estimated %.3f ms\n", 1e3 * solve.result.summary.time_offset_s);
}

TEST(RowOptimiser, TimeOffsetOptionsAreChecked) {
  RowOptimiser::Options options;
  EXPECT_EQ(options.Check(), "");
  EXPECT_FALSE(options.estimate_time_offset);
  options.time_offset_prior_sigma_s = 0;
  EXPECT_NE(options.Check(), "");
  EXPECT_NE(options.Error().find("time_offset_prior_sigma_s"), std::string::npos);
  options = RowOptimiser::Options();
  options.max_abs_time_offset_s = -0.1;
  EXPECT_NE(options.Error().find("max_abs_time_offset_s"), std::string::npos);
  options.max_abs_time_offset_s = 2.0;
  EXPECT_NE(options.Error().find("max_abs_time_offset_s"), std::string::npos);
  try {
    RowOptimiser{options};
    ADD_FAILURE() << "invalid options accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_abs_time_offset_s"), std::string::npos);
  }
}

TEST(RowOptimiser, OptionErrorsNameTheOptionAndWhy) {
  RowOptimiser::Options options;
  EXPECT_EQ(options.Error(), "");
  options.max_iterations = 0;
  EXPECT_EQ(options.Error(), "max_iterations: must be > 0 (got 0)");
  options = RowOptimiser::Options();
  options.gps_loss_scale = -1;
  EXPECT_EQ(options.Error(), "gps_loss_scale: must be > 0 (got -1)");
  options = RowOptimiser::Options();
  options.function_tolerance = 1;
  EXPECT_EQ(options.Error(), "function_tolerance: must be in (0, 1) (got 1)");
  options = RowOptimiser::Options();
  options.min_observations = 1;
  EXPECT_EQ(options.Error(), "min_observations: must be >= 2 (got 1)");
  options = RowOptimiser::Options();
  options.triangulation.min_parallax_deg = 180;
  EXPECT_EQ(options.Check().rfind("triangulation.min_parallax_deg: ", 0), 0u) << options.Check();
  options = RowOptimiser::Options();
  options.gps_gate_chi2 = -1;
  EXPECT_EQ(options.Error(), "gps_gate_chi2: must be >= 0 (0: off) (got -1)");
}

}  // namespace
}  // namespace crop4d::slam
