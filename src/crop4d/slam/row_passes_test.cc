#include "crop4d/slam/row_passes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>

#include "crop4d/core/error.h"
#include "crop4d/sim/sensor_models.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/trajectory.h"
#include "crop4d/sim/world.h"

namespace crop4d::slam {
namespace {

constexpr Timestamp kStart = 1'464'000'000LL * kNanosPerSecond;  // 2016-05-23

// The simulator's boustrophedon drive over a field of `num_rows` rows (demo preset otherwise).
struct Drive {
  std::unique_ptr<sim::World> world;
  std::unique_ptr<sim::Trajectory> trajectory;
};

Drive MakeDrive(int num_rows, double row_length_m, std::uint64_t seed) {
  sim::SimConfig config = sim::PresetConfig("demo");
  sim::WorldOptions world_options = config.MakeWorldOptions();
  world_options.num_rows = num_rows;
  world_options.row_length_m = row_length_m;
  Drive drive;
  drive.world = std::make_unique<sim::World>(world_options);
  drive.trajectory = std::make_unique<sim::Trajectory>(*drive.world, config.drive, seed);
  return drive;
}

// 2-D rotation of the field about the ENU origin (a field whose rows are not north–south).
Eigen::Vector2d Rotate(const Eigen::Vector2d& p, double angle) {
  return Eigen::Rotation2Dd(angle) * p;
}

// The antenna track of one receiver (sim::GpsModel: white noise plus the drifting bias) at its
// rate with a random clock phase, the field rotated by `rotation` about the origin.
std::vector<TrackPoint> MakeTrack(const sim::Trajectory& trajectory, const sim::GpsOptions& gps,
                                  std::uint64_t seed, double rotation = 0.0) {
  sim::GpsModel model(gps, seed);
  std::vector<TrackPoint> track;
  const double period = 1.0 / gps.rate_hz;
  for (double t = 0.37 * period; t <= trajectory.Duration(); t += period) {
    const Eigen::Vector3d antenna = trajectory.WorldFromBody(t) * gps.antenna_in_body;
    Eigen::Vector3d measured = model.Measure(period, antenna);
    measured.head<2>() = Rotate(measured.head<2>(), rotation);
    track.push_back({kStart + SecondsToTimestamp(t), measured});
  }
  return track;
}

sim::GpsOptions Rtk() { return sim::PresetConfig("demo").gps0; }
sim::GpsOptions LowAccuracy() { return sim::PresetConfig("demo").gps1; }

// Options for a receiver: its antenna's lever arm.
RowPassSegmenter::Options OptionsFor(const sim::GpsOptions& gps) {
  RowPassSegmenter::Options options;
  options.antenna_in_body_xy = gps.antenna_in_body.head<2>();
  return options;
}

double Seconds(Timestamp t) { return TimestampToSeconds(t - kStart); }

// Declared rows of the simulated field (row r: x = r·spacing, y from 0 to the row length),
// rotated, with the given indices.
std::vector<io::RowDeclaration> DeclaredRows(const sim::World& world, const std::vector<int>& index,
                                             double rotation = 0.0) {
  std::vector<io::RowDeclaration> rows;
  for (int r = 0; r < world.options().num_rows; ++r) {
    io::RowDeclaration row;
    row.index = index[r];
    row.start_enu = Rotate(Eigen::Vector2d(world.RowX(r), 0.0), rotation);
    row.end_enu = Rotate(Eigen::Vector2d(world.RowX(r), world.options().row_length_m), rotation);
    rows.push_back(row);
  }
  return rows;
}

TEST(RowPassSegmenterTest, RtkTrackGivesTheTruePassesRowsAndBoundaries) {
  // Boundaries: 0.3 s rms, none beyond 0.6 s (the antenna's lateral deviation in the first
  // 0.5 s of a turn is ~3 cm, the size of the noise and the pass's lateral wobble).
  double sum_squared_error = 0.0;
  int num_boundaries = 0;
  for (const auto& [num_rows, seed] : {std::pair{4, 1}, std::pair{9, 2}, std::pair{9, 3}}) {
    const Drive drive = MakeDrive(num_rows, 20.0, seed);
    const std::vector<sim::Pass>& truth = drive.trajectory->passes();
    const std::vector<TrackPoint> track = MakeTrack(*drive.trajectory, Rtk(), seed);
    RowPassSegmenter::Summary summary;
    const std::vector<RowPass> passes =
        RowPassSegmenter(OptionsFor(Rtk())).Segment(track, {}, &summary);
    EXPECT_FALSE(summary.whole_session);
    EXPECT_FALSE(summary.relative_rows);
    EXPECT_LT(summary.noise_sigma_m, 0.05);
    EXPECT_NEAR(summary.row_axis_world.y(), 1.0, 1e-3);  // north–south rows, axis north
    ASSERT_EQ(passes.size(), truth.size()) << "seed " << seed;
    for (size_t k = 0; k < passes.size(); ++k) {
      SCOPED_TRACE(testing::Message() << "seed " << seed << " pass " << k);
      EXPECT_EQ(passes[k].row, truth[k].lane);
      EXPECT_EQ(passes[k].id,
                (truth[k].lane < 10 ? "row0" : "row") + std::to_string(truth[k].lane));
      EXPECT_EQ(passes[k].direction, truth[k].northward ? 1 : -1);
      const double begin_error = Seconds(passes[k].t_begin) - truth[k].t_begin;
      const double end_error = Seconds(passes[k].t_end) - truth[k].t_end;
      EXPECT_LE(std::abs(begin_error), 0.6);
      EXPECT_LE(std::abs(end_error), 0.6);
      sum_squared_error += begin_error * begin_error + end_error * end_error;
      num_boundaries += 2;
      EXPECT_NEAR(passes[k].length_m, 22.0, 1.0);  // row + lead-in and lead-out
      EXPECT_NEAR(passes[k].start_world.x(), drive.trajectory->LaneX(truth[k].lane), 0.3);
      EXPECT_NEAR(passes[k].lateral_m, drive.trajectory->LaneX(truth[k].lane), 0.3);
    }
    EXPECT_NEAR(summary.row0_lateral_m, 0.0, 0.3);
  }
  EXPECT_LT(std::sqrt(sum_squared_error / num_boundaries), 0.3);  // rms, s
}

TEST(RowPassSegmenterTest, LowAccuracyTrackGivesThePassesDirectionsAndRelativeRows) {
  for (const auto& [num_rows, seed] : {std::pair{4, 1}, std::pair{9, 2}, std::pair{9, 3}}) {
    const Drive drive = MakeDrive(num_rows, 20.0, seed);
    const std::vector<sim::Pass>& truth = drive.trajectory->passes();
    const std::vector<TrackPoint> track = MakeTrack(*drive.trajectory, LowAccuracy(), seed);
    RowPassSegmenter::Summary summary;
    const std::vector<RowPass> passes =
        RowPassSegmenter(OptionsFor(LowAccuracy())).Segment(track, {}, &summary);
    EXPECT_TRUE(summary.relative_rows);
    EXPECT_NEAR(summary.noise_sigma_m, 1.5, 0.3);
    ASSERT_EQ(passes.size(), truth.size()) << "seed " << seed;
    for (size_t k = 0; k < passes.size(); ++k) {
      SCOPED_TRACE(testing::Message() << "seed " << seed << " pass " << k);
      EXPECT_EQ(passes[k].direction, truth[k].northward ? 1 : -1);
      EXPECT_EQ(passes[k].row - passes[0].row, truth[k].lane - truth[0].lane);
      // Inside the true pass, covering most of it.
      EXPECT_GT(Seconds(passes[k].t_begin), truth[k].t_begin - 1.0);
      EXPECT_LT(Seconds(passes[k].t_end), truth[k].t_end + 1.0);
      EXPECT_GT(Seconds(passes[k].t_end) - Seconds(passes[k].t_begin),
                0.7 * (truth[k].t_end - truth[k].t_begin));
    }
  }
}

TEST(RowPassSegmenterTest, DeclaredRowsGiveTheIndicesInAnyOrderAndRotation) {
  const Drive drive = MakeDrive(6, 20.0, 4);
  const std::vector<sim::Pass>& truth = drive.trajectory->passes();
  const std::vector<int> index = {12, 11, 10, 9, 8, 7};  // east to west
  for (const double rotation : {0.0, 30.0 * M_PI / 180.0}) {
    SCOPED_TRACE(testing::Message() << "rotation " << rotation);
    std::vector<io::RowDeclaration> declared = DeclaredRows(*drive.world, index, rotation);
    std::swap(declared[0], declared[4]);  // listed out of order
    std::swap(declared[1], declared[3]);
    const std::vector<TrackPoint> track = MakeTrack(*drive.trajectory, Rtk(), 4, rotation);
    RowPassSegmenter::Summary summary;
    const std::vector<RowPass> passes =
        RowPassSegmenter(OptionsFor(Rtk())).Segment(track, declared, &summary);
    EXPECT_TRUE(summary.used_declared_rows);
    EXPECT_EQ(summary.num_dropped_unmatched, 0);
    EXPECT_NEAR(std::atan2(summary.row_axis_world.y(), summary.row_axis_world.x()),
                M_PI / 2 + rotation, 1e-9);
    ASSERT_EQ(passes.size(), truth.size());
    for (size_t k = 0; k < passes.size(); ++k) {
      EXPECT_EQ(passes[k].row, index[truth[k].lane]);
      EXPECT_EQ(passes[k].direction, truth[k].northward ? 1 : -1);
      EXPECT_NEAR(Seconds(passes[k].t_begin), truth[k].t_begin, 0.6);
      EXPECT_NEAR(Seconds(passes[k].t_end), truth[k].t_end, 0.6);
    }
    // Without the declarations the rotated field gives the same passes, row 0 leftmost
    // looking along the axis (the westernmost row before rotation).
    const std::vector<RowPass> undeclared = RowPassSegmenter({}).Segment(track, {});
    ASSERT_EQ(undeclared.size(), truth.size());
    for (size_t k = 0; k < undeclared.size(); ++k) EXPECT_EQ(undeclared[k].row, truth[k].lane);
  }
}

TEST(RowPassSegmenterTest, DeclaredRowsFixTheAbsoluteRowsOfALowAccuracyTrack) {
  const Drive drive = MakeDrive(6, 20.0, 5);
  const std::vector<sim::Pass>& truth = drive.trajectory->passes();
  const std::vector<int> index = {0, 1, 2, 3, 4, 5};
  const std::vector<TrackPoint> track = MakeTrack(*drive.trajectory, LowAccuracy(), 5);
  RowPassSegmenter::Summary summary;
  const std::vector<RowPass> passes =
      RowPassSegmenter(OptionsFor(LowAccuracy()))
          .Segment(track, DeclaredRows(*drive.world, index), &summary);
  EXPECT_TRUE(summary.relative_rows);
  ASSERT_EQ(passes.size(), truth.size());
  for (size_t k = 0; k < passes.size(); ++k) EXPECT_EQ(passes[k].row, truth[k].lane);
}

TEST(RowPassSegmenterTest, LateralOriginIndexesASecondSessionLikeTheFirst) {
  // The second session drives only the rows from 2 on; with the first session's axis and
  // origin its passes keep the field's row numbers.
  const Drive drive = MakeDrive(5, 20.0, 6);
  RowPassSegmenter::Summary first;
  RowPassSegmenter({}).Segment(MakeTrack(*drive.trajectory, Rtk(), 6), {}, &first);
  std::vector<TrackPoint> track = MakeTrack(*drive.trajectory, Rtk(), 7);
  const double t_cut = drive.trajectory->passes()[2].t_begin - 3.0;
  track.erase(track.begin(), std::find_if(track.begin(), track.end(), [&](const TrackPoint& p) {
                return Seconds(p.t) > t_cut;
              }));
  RowPassSegmenter::Options options;
  options.row_axis_rad = std::atan2(first.row_axis_world.y(), first.row_axis_world.x());
  options.lateral_origin_m = first.row0_lateral_m;
  const std::vector<RowPass> passes = RowPassSegmenter(options).Segment(track, {});
  ASSERT_EQ(passes.size(), 3u);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(passes[k].row, k + 2);
  // Without them the session's leftmost pass is row 0.
  EXPECT_EQ(RowPassSegmenter({}).Segment(track, {}).front().row, 0);
}

TEST(RowPassSegmenterTest, RepeatedRowGetsASuffix) {
  // Drive row 0 north, turn, drive it back south on the same line: row00 and row00_2.
  std::vector<TrackPoint> track;
  double t = 0.0;
  auto add = [&](const Eigen::Vector2d& p) {
    track.push_back({kStart + SecondsToTimestamp(t), Eigen::Vector3d(p.x(), p.y(), 0.0)});
    t += 0.2;
  };
  for (double y = 0.0; y <= 20.0; y += 0.3) add({0.0, y});
  for (double a = 0.0; a <= 2.0 * M_PI; a += 0.15)
    add({-2.0 + 2.0 * std::cos(a), 20.0 + 2.0 * std::sin(a)});
  for (double y = 20.0; y >= 0.0; y -= 0.3) add({0.0, y});
  const std::vector<RowPass> passes = RowPassSegmenter({}).Segment(track, {});
  ASSERT_EQ(passes.size(), 2u);
  EXPECT_EQ(passes[0].id, "row00");
  EXPECT_EQ(passes[1].id, "row00_2");
  EXPECT_EQ(passes[0].direction, 1);
  EXPECT_EQ(passes[1].direction, -1);
}

TEST(RowPassSegmenterTest, WalkInTightCirclesIsOneWholeSessionPass) {
  std::mt19937_64 random(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<TrackPoint> track;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double angle = 0.0;
  for (int k = 0; k < 3000; ++k) {  // 10 min at 5 Hz: circles of ~1.5 m, the centre wanders
    angle += 0.2 * 1.2 / 1.5 + 0.05 * normal(random);
    centre += 0.05 * Eigen::Vector2d(normal(random), normal(random));
    const Eigen::Vector2d p = centre + 1.5 * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    track.push_back(
        {kStart + k * 200 * kNanosPerMillisecond,
         Eigen::Vector3d(p.x() + 0.02 * normal(random), p.y() + 0.02 * normal(random), 0)});
  }
  RowPassSegmenter::Summary summary;
  const std::vector<RowPass> passes = RowPassSegmenter({}).Segment(track, {}, &summary);
  ASSERT_EQ(passes.size(), 1u);
  EXPECT_TRUE(summary.whole_session);
  EXPECT_EQ(passes[0].id, "all");
  EXPECT_EQ(passes[0].row, -1);
  EXPECT_EQ(passes[0].direction, 0);
  EXPECT_EQ(passes[0].t_begin, track.front().t);
  EXPECT_EQ(passes[0].t_end, track.back().t);
}

TEST(RowPassSegmenterTest, EmptyShortAndBadTracks) {
  const RowPassSegmenter segmenter({});
  RowPassSegmenter::Summary summary;
  EXPECT_TRUE(segmenter.Segment({}, {}, &summary).empty());
  EXPECT_FALSE(summary.whole_session);
  const TrackPoint a{kStart, Eigen::Vector3d(0, 0, 0)};
  const TrackPoint b{kStart + kNanosPerSecond, Eigen::Vector3d(0, 1, 0)};
  EXPECT_TRUE(segmenter.Segment({a}, {}).empty());
  // Two fixes: no straight pass of 5 m, so the whole session.
  const std::vector<RowPass> two = segmenter.Segment({a, b}, {}, &summary);
  ASSERT_EQ(two.size(), 1u);
  EXPECT_EQ(two[0].id, "all");
  EXPECT_TRUE(summary.whole_session);
  EXPECT_THROW(segmenter.Segment({b, a}, {}), InputError);
  EXPECT_THROW(segmenter.Segment({a, a}, {}), InputError);
  TrackPoint bad = b;
  bad.position_world.x() = std::nan("");
  EXPECT_THROW(segmenter.Segment({a, bad}, {}), InputError);
  io::RowDeclaration degenerate;  // start == end
  EXPECT_THROW(segmenter.Segment({a, b}, {degenerate}), InputError);
  RowPassSegmenter::Options options;
  options.min_length_m = 0.0;
  EXPECT_NE(options.Check(), "");
  EXPECT_THROW(RowPassSegmenter{options}, std::invalid_argument);
}

TEST(RowPassSegmenterTest, GpsOutageInsideAPassDoesNotSplitIt) {
  const Drive drive = MakeDrive(4, 20.0, 8);
  const std::vector<sim::Pass>& truth = drive.trajectory->passes();
  for (const auto& [gps, name] : {std::pair{Rtk(), "rtk"}, std::pair{LowAccuracy(), "standard"}}) {
    SCOPED_TRACE(name);
    std::vector<TrackPoint> track = MakeTrack(*drive.trajectory, gps, 8);
    // 4 s without fixes in the middle of the second pass.
    const double middle = 0.5 * (truth[1].t_begin + truth[1].t_end);
    std::erase_if(track,
                  [&](const TrackPoint& p) { return std::abs(Seconds(p.t) - middle) < 2.0; });
    RowPassSegmenter::Summary summary;
    const std::vector<RowPass> passes =
        RowPassSegmenter(OptionsFor(gps)).Segment(track, {}, &summary);
    ASSERT_EQ(passes.size(), truth.size());
    EXPECT_GE(summary.num_joined_gaps, 1);
    EXPECT_EQ(passes[1].row - passes[0].row, 1);
    EXPECT_LT(Seconds(passes[1].t_begin), middle - 2.0);
    EXPECT_GT(Seconds(passes[1].t_end), middle + 2.0);
  }
}

// A car drive on roads (no rows): straight roads on a north-south / east-west grid, 20 to 400
// m long, joined by turns of 8 to 30 m radius and by gentle curves, at 4 to 20 m/s with stops
// at some junctions; RTK antenna fixes at 5 Hz (1 cm noise). Like the real drive of issue 25:
// long straight stretches along one axis, hundreds of metres apart across it.
std::vector<TrackPoint> MakeRoadDrive(std::uint64_t seed, double duration_s = 900.0) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<TrackPoint> track;
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
  double heading = 0.5 * M_PI * std::floor(4.0 * uniform(random));
  double t = 0.0, next_fix = 0.0;
  constexpr double kDt = 0.01, kFixPeriod = 0.2;
  // Advances the car over `duration` s at speed v (m/s) and yaw rate w (rad/s).
  auto drive = [&](double duration, double v, double w) {
    for (double s = 0.0; s < duration && t < duration_s; s += kDt, t += kDt) {
      heading += w * kDt;
      p += v * kDt * Eigen::Vector2d(std::cos(heading), std::sin(heading));
      if (t >= next_fix) {
        track.push_back(
            {kStart + SecondsToTimestamp(t),
             Eigen::Vector3d(p.x() + 0.01 * normal(random), p.y() + 0.01 * normal(random), 0.0)});
        next_fix += kFixPeriod;
      }
    }
  };
  drive(5.0, 0.0, 0.0);  // standing at the start
  while (t < duration_s) {
    const double v = 4.0 + 16.0 * uniform(random);
    const double length = 20.0 + 380.0 * uniform(random);
    if (uniform(random) < 0.3) {  // a gentle curve: 10 to 30 degrees over the road
      const double bend =
          (uniform(random) < 0.5 ? -1 : 1) * (10.0 + 20.0 * uniform(random)) * M_PI / 180.0;
      drive(length / v, v, bend / (length / v));
      drive(length / v, v, -bend / (length / v));
    } else {
      drive(length / v, v, 0.0);
    }
    if (uniform(random) < 0.3) drive(2.0 + 20.0 * uniform(random), 0.0, 0.0);  // a junction
    const double radius = 8.0 + 22.0 * uniform(random);
    const double turn_v = std::min(v, 6.0);
    const double turn = (uniform(random) < 0.5 ? -0.5 : 0.5) * M_PI;
    drive(std::abs(turn) * radius / turn_v, turn_v, turn_v / radius * (turn > 0 ? 1 : -1));
    heading = 0.5 * M_PI * std::round(heading / (0.5 * M_PI));  // back on the grid
  }
  return track;
}

TEST(RowPassSegmenterTest, RoadDriveIsOneTrajectoryAndNoPassIsShorterThanTheMinimum) {
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    SCOPED_TRACE(seed);
    const std::vector<TrackPoint> track = MakeRoadDrive(seed);
    RowPassSegmenter::Summary summary;
    const std::vector<RowPass> passes = RowPassSegmenter({}).Segment(track, {}, &summary);
    ASSERT_EQ(passes.size(), 1u);
    EXPECT_TRUE(summary.whole_session);
    EXPECT_EQ(passes[0].t_begin, track.front().t);
    EXPECT_EQ(passes[0].t_end, track.back().t);
    // Taking the straight stretches anyway (--passes rows): none is shorter than the minimum,
    // also after the boundaries are refined (the tiny passes of issue 25).
    RowPassSegmenter::Options rows;
    rows.require_row_structure = false;
    const std::vector<RowPass> straight = RowPassSegmenter(rows).Segment(track, {}, &summary);
    EXPECT_GT(straight.size(), 5u);
    for (const RowPass& p : straight) {
      SCOPED_TRACE(p.id);
      EXPECT_GE(p.length_m, rows.min_length_m - 0.5);
      EXPECT_GT(Seconds(p.t_end) - Seconds(p.t_begin), 0.2);
    }
  }
}

TEST(RowPassSegmenterTest, FieldRowsWithoutDeclarationsAreStillRows) {
  // The boustrophedon drives of the other tests look like rows; a single straight pass does not.
  const Drive drive = MakeDrive(6, 20.0, 3);
  for (const auto& [gps, name] : {std::pair{Rtk(), "rtk"}, std::pair{LowAccuracy(), "standard"}}) {
    SCOPED_TRACE(name);
    RowPassSegmenter::Summary summary;
    const std::vector<RowPass> passes =
        RowPassSegmenter(OptionsFor(gps))
            .Segment(MakeTrack(*drive.trajectory, gps, 3), {}, &summary);
    EXPECT_EQ(passes.size(), drive.trajectory->passes().size());
    EXPECT_FALSE(summary.whole_session);
  }
  std::vector<TrackPoint> line;
  for (int k = 0; k < 200; ++k) {
    line.push_back({kStart + k * 200 * kNanosPerMillisecond, Eigen::Vector3d(0, 0.2 * k, 0)});
  }
  RowPassSegmenter::Summary summary;
  EXPECT_EQ(RowPassSegmenter({}).Segment(line, {}, &summary).front().id, "all");
  EXPECT_TRUE(summary.whole_session);
}

TEST(WholeDriveWindowsTest, EqualOverlappingWindowsCoverTheDrive) {
  const std::vector<TrackPoint> track = MakeRoadDrive(2, 700.0);
  const Timestamp begin = track.front().t, end = track.back().t;
  const std::vector<RowPass> one = WholeDriveWindows(begin, end, track, 1000.0, 15.0);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].id, "all");
  EXPECT_EQ(one[0].t_begin, begin);
  EXPECT_EQ(one[0].t_end, end);
  double path = 0.0;
  for (size_t k = 1; k < track.size(); ++k) {
    path += (track[k].position_world - track[k - 1].position_world).head<2>().norm();
  }
  EXPECT_NEAR(one[0].length_m, path, 1e-6 * path);

  const std::vector<RowPass> windows = WholeDriveWindows(begin, end, track, 300.0, 15.0);
  ASSERT_EQ(windows.size(), 3u);  // ~700 s: 3 windows of (700 + 2 · 15) / 3 s
  const double expected = (TimestampToSeconds(end - begin) + 2 * 15.0) / 3;
  EXPECT_EQ(windows[0].id, "all00");
  EXPECT_EQ(windows[2].id, "all02");
  EXPECT_EQ(windows.front().t_begin, begin);
  EXPECT_EQ(windows.back().t_end, end);
  double covered = 0.0;
  for (size_t k = 0; k < windows.size(); ++k) {
    const double length = TimestampToSeconds(windows[k].t_end - windows[k].t_begin);
    EXPECT_LE(length, 300.0);
    EXPECT_NEAR(length, expected, 1e-6);
    EXPECT_EQ(windows[k].row, -1);
    if (k > 0) {
      EXPECT_NEAR(TimestampToSeconds(windows[k - 1].t_end - windows[k].t_begin), 15.0, 1e-6);
    }
    covered += windows[k].length_m;
    // Its ends lie on the track: within one fix interval (0.2 s at ≤ 20 m/s) of the fix nearest
    // in time.
    for (const auto& [t, p] : {std::pair{windows[k].t_begin, windows[k].start_world},
                               std::pair{windows[k].t_end, windows[k].end_world}}) {
      const auto near = std::min_element(track.begin(), track.end(),
                                         [t = t](const TrackPoint& a, const TrackPoint& b) {
                                           return std::abs(a.t - t) < std::abs(b.t - t);
                                         });
      EXPECT_LT((p - near->position_world.head<2>()).norm(), 4.0 + 0.05);
    }
  }
  EXPECT_GT(covered, path);  // the overlaps count twice
  EXPECT_EQ(windows.front().start_world, track.front().position_world.head<2>());
  EXPECT_EQ(windows.back().end_world, track.back().position_world.head<2>());
  EXPECT_THROW(WholeDriveWindows(begin, end, track, 10.0, 10.0), std::invalid_argument);
}

TEST(RowPassSegmenterTest, FindPassReturnsTheContainingPass) {
  std::vector<RowPass> passes(2);
  passes[0].t_begin = 10;
  passes[0].t_end = 20;
  passes[1].t_begin = 30;
  passes[1].t_end = 40;
  EXPECT_EQ(FindPass(passes, 5), -1);
  EXPECT_EQ(FindPass(passes, 10), 0);
  EXPECT_EQ(FindPass(passes, 20), 0);
  EXPECT_EQ(FindPass(passes, 25), -1);
  EXPECT_EQ(FindPass(passes, 35), 1);
  EXPECT_EQ(FindPass(passes, 41), -1);
  EXPECT_EQ(FindPass({}, 0), -1);
}

}  // namespace
}  // namespace crop4d::slam
