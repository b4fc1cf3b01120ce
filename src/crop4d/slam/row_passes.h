#pragma once

// Row passes from the GPS track (DESIGN.md §2.1): a field is driven boustrophedon, straight
// passes over the crop rows joined by headland turns. RowPassSegmenter splits one session's
// antenna track (field ENU frame) into those straight passes, gives each a row index across the
// field and a direction, and drops the turns.
//
// Method.
//  1. Velocity of every fix from a local least-squares line fit over a time window (never
//     point-to-point differences: with a 1.5 m receiver they are pure noise). The window is
//     chosen from the white-noise level, estimated from second differences of the fixes
//     (σ² = var(x_{k+1} − 2 x_k + x_{k−1}) / 6 on straight stretches, robust MAD), so that the
//     course has ~0.08 rad noise at the median speed (course σ ≈ σ √12 / (√(rate W) v W)).
//  2. Row axis: the declared rows' direction; otherwise the dominant course mod 180°, the peak
//     of a speed-weighted histogram of doubled angles refined by their circular mean (axial
//     data, Mardia & Jupp, "Directional Statistics", 2000, §9.3.2). Lateral coordinates are
//     measured along the axis turned 90° clockwise ("right of the axis"); the axis is taken in
//     (−45°, 135°] of the course counter-clockwise from east, so north–south rows have their
//     axis pointing north and row 0 is the westernmost, east–west rows point east and row 0 is
//     the northernmost.
//  3. A fix is straight when its speed is above a minimum and its course within a tolerance of
//     ±axis; maximal runs of straight fixes in one direction, joined across short gaps (GPS
//     outages, stops) when the lateral offsets agree and the motion goes on forward, and kept
//     when at least min_length_m long.
//  4. Boundaries: the windowed course leaves the tolerance only once the window reaches into
//     the turn, so the run ends are refined by a change-point fit (Hinkley, "Inference about the
//     change-point in a sequence of random variables", Biometrika 1970) of the lateral offset:
//     l(t) = polynomial₂(t − t₀) + h (b₁ + b₂ h + b₃ h²), h = max(0, t − t₀) (mirrored at the
//     start), minimising the residual over t₀ on a 0.05 s grid. The h term takes the kink
//     that the antenna's lever arm adds when the vehicle starts to yaw, h² the curvature jump.
//     Done when the noise is below refine_max_noise_m (RTK); else the run ends are moved in
//     by half the window (the windowed course stays straight ~W/2 into a turn).
//  5. Row index. With declared rows: the nearest declared row line (perpendicular distance of
//     the pass's centroid, within max_row_distance_m). Without: relative offsets of consecutive
//     passes, row_{k+1} = row_k + round((l_{k+1} − l_k) / spacing) (consecutive passes are
//     close in time, so a slowly drifting receiver bias cancels), then shifted so that the
//     smallest is 0, or, with lateral_origin_m, so that rows sit nearest to origin + i·spacing.
//     For a noisy receiver the offset between two passes is known to only ~0.4 m (1.5 m noise
//     averaged over a pass, plus the bias drift between passes), too little to count rows, so
//     consecutive passes in opposite directions (a U-turn) are taken to be adjacent rows, on
//     the side the offset says: row_{k+1} = row_k + sign(l_{k+1} − l_k)·max(1, round(|Δl| /
//     spacing − 0.5)) (boustrophedon prior: a skipped row is seen only beyond 1.5 spacings).
//     A noisy receiver (noise above relative_matching_noise_m) is matched to declared rows the
//     same relative way, with one integer shift chosen so that the passes fall on declared
//     rows (fewest outside, then least squares).
//
// Guarantees. RTK (σ ~2 cm): every true pass of at least min_length_m is found once, its
// boundaries within ~0.3 s rms (≤ 0.6 s in the tests) of the start/end of the straight path
// when antenna_in_body_xy is given (~0.7 s late without it, for the simulator's 0.3 m lever
// arm), its row index absolute (from
// declarations, or lateral_origin_m, or else relative to the leftmost pass of the session, so
// consistent between sessions that drive the same leftmost row). Low-accuracy receivers (σ 1.5 m
// plus a drifting bias ~1 m): the same passes and directions; the row indices are correct
// relative to each other for a boustrophedon drive (wrong only where two consecutive passes'
// offsets err by more than a spacing, ~1% of pairs with the antenna offset corrected), but a
// U-turn back onto the same row or over a skipped row is not seen; absolute only when the
// session covers every declared row; the boundaries are within ~1 s of the truth, mostly on
// the inside.
// A track with no straight run of min_length_m along one axis (a person walking in tight turns)
// is one pass "all" (row −1, direction 0) over the whole session, flagged in the summary; so is,
// without declared rows, a track whose straight passes do not look like a field's rows
// (Options::min_row_passes, max_row_step: a car drive on roads). No pass is shorter than
// min_length_m along the axis, also after its boundaries are refined.
// Fewer than 2 fixes: an empty result. Non-finite positions or times not strictly increasing:
// InputError.

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/io/dataset.h"

namespace crop4d::slam {

// One GPS antenna fix in the field's ENU world frame.
struct TrackPoint {
  Timestamp t = 0;
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
};

// One straight pass over a row (or the whole session when there is no row structure).
struct RowPass {
  // "row00", "row01", ...; a second pass over the same row in a session "row01_2"; "all" for
  // the whole session.
  std::string id;
  // Row index across the field; −1 for the whole-session pass.
  int row = -1;
  // +1 along the row axis, −1 against it, 0 for the whole-session pass.
  int direction = 0;
  // The pass is [t_begin, t_end].
  Timestamp t_begin = 0, t_end = 0;
  // Where it starts and ends (ENU east, north), m.
  Eigen::Vector2d start_world = Eigen::Vector2d::Zero();
  Eigen::Vector2d end_world = Eigen::Vector2d::Zero();
  // Distance along the row axis from start to end, m (path length for "all").
  double length_m = 0.0;
  // Mean lateral coordinate of the pass (across the rows, summary.lateral_axis_world), m.
  double lateral_m = 0.0;
};

class RowPassSegmenter {
 public:
  struct Options {
    // Distance between rows, m (with declared rows, their median spacing is used instead).
    double row_spacing_m = 0.91;
    // Window of the local line fit that gives each fix's velocity, s; 0 chooses it from the
    // estimated noise, between the two bounds below.
    double velocity_window_s = 0.0;
    double min_velocity_window_s = 1.5;
    double max_velocity_window_s = 8.0;
    // A fix is straight when its course is within this angle of ±row axis, rad.
    double heading_tolerance_rad = 15.0 * M_PI / 180.0;
    // ... and its speed at least this, m/s.
    double min_speed_mps = 0.3;
    // A straight segment shorter than this along the axis is not a pass, m.
    double min_length_m = 5.0;
    // Straight runs in the same direction separated by at most this (GPS outage, stop) are
    // one pass when their lateral offsets agree and the motion goes on forward, s.
    double max_join_gap_s = 20.0;
    // Boundaries are refined by the change-point fit when the estimated noise is below this
    // (RTK), m.
    double refine_max_noise_m = 0.15;
    // Row axis, rad counter-clockwise from east; NaN estimates it (or takes the declared rows').
    double row_axis_rad = std::numeric_limits<double>::quiet_NaN();
    // Lateral coordinate of row 0, m (e.g. summary.row0_lateral_m of an earlier session, with
    // row_axis_rad); NaN makes the session's leftmost pass row 0. Without declared rows only.
    double lateral_origin_m = std::numeric_limits<double>::quiet_NaN();
    // Largest perpendicular distance from a pass to its declared row, m; 0 means half the
    // declared row spacing.
    double max_row_distance_m = 0.0;
    // Above this estimated noise the receiver is treated as low-accuracy (biased): rows come from
    // relative offsets between passes (file comment, step 5), m.
    double relative_matching_noise_m = 0.3;
    // Horizontal position of the GPS antenna in the body frame (x forward, y left), m:
    // p_B_antenna.head<2>(). When non-zero the track is moved to the body origin first,
    // p_body = p_antenna − R(ψ) p_B_antenna with ψ the course of the body track (fixed point,
    // 3 iterations; a ground vehicle points where it goes). This removes the ±y offset that
    // flips with the direction of travel (0.4 m between consecutive passes for y = 0.2 m: it
    // matters for noisy receivers) and the kink that a lever arm x adds to the antenna path when
    // a turn starts (the tail swings out first, which delays the boundary by ~0.5 s).
    // Positions in the passes are then the body origin's.
    Eigen::Vector2d antenna_in_body_xy = Eigen::Vector2d::Zero();

    // Without declared rows, passes covering less than this fraction of the session's time make
    // it a session without row structure (one pass "all"): a boustrophedon drive spends more
    // than half its time in rows, a walk with a few straight stretches much less.
    double min_row_time_fraction = 0.3;
    // Without declared rows, the passes are a field's rows only when there are at least this
    // many and most consecutive ones are neighbours: at most max_row_step rows apart and
    // overlapping along the rows by half the shorter one (a road drive has straight stretches
    // along one axis too, but far apart or end to end). Otherwise the session is one pass.
    int min_row_passes = 2;
    int max_row_step = 3;
    // False: take the straight passes found even when they do not look like rows (the three
    // tests above off; `crop4d slam --passes rows`).
    bool require_row_structure = true;

    OptionCheck Check() const;
  };

  struct Summary {
    int num_points = 0;
    // Estimated white noise of the fixes per horizontal axis, m.
    double noise_sigma_m = 0.0;
    // The velocity window used, s.
    double velocity_window_s = 0.0;
    // Unit vectors along the rows (direction +1) and across them (row index grows), ENU.
    Eigen::Vector2d row_axis_world = Eigen::Vector2d::UnitY();
    Eigen::Vector2d lateral_axis_world = Eigen::Vector2d::UnitX();
    // Row spacing used, m, and the lateral coordinate of row 0 (origin + row·spacing is the
    // nominal lateral of a row; without declarations, store it to index later sessions the same).
    double row_spacing_m = 0.0;
    double row0_lateral_m = 0.0;
    bool used_declared_rows = false;
    // Rows from relative offsets between passes (noisy receiver, file comment step 5).
    bool relative_rows = false;
    // No row structure: the result is one pass "all" over the whole session; warn the user.
    bool whole_session = false;
    // Straight runs found, runs joined across gaps, segments dropped (too short, or no declared
    // row within max_row_distance_m).
    int num_straight_runs = 0;
    int num_joined_gaps = 0;
    int num_dropped_short = 0;
    int num_dropped_unmatched = 0;
  };

  explicit RowPassSegmenter(Options options);

  // The passes in time order. `track` sorted by strictly increasing time; `declared_rows` may
  // be empty. Throws InputError for non-finite positions or unsorted times.
  std::vector<RowPass> Segment(const std::vector<TrackPoint>& track,
                               const std::vector<io::RowDeclaration>& declared_rows,
                               Summary* summary = nullptr) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

// A session processed as one trajectory, [t_begin, t_end], cut into windows of at most
// max_window_s seconds that overlap by overlap_s (so the passes join), all of the same length:
// one pass "all" when it fits, else "all00", "all01", ... (row −1, direction 0). Positions and
// path lengths from `track` (antenna or body fixes) when it is not empty. Bounding a pass bounds
// the back end's memory and solve time on long drives; nothing of the drive is dropped.
std::vector<RowPass> WholeDriveWindows(Timestamp t_begin, Timestamp t_end,
                                       const std::vector<TrackPoint>& track, double max_window_s,
                                       double overlap_s);

// Index of the pass that contains t (t_begin ≤ t ≤ t_end), or −1. Passes in time order.
int FindPass(const std::vector<RowPass>& passes, Timestamp t);

}  // namespace crop4d::slam
