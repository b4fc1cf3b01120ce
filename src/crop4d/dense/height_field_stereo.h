#pragma once

// Dense reconstruction of a field as a height field (DESIGN.md §2.5): multi-view stereo by a
// vertical plane sweep in object space, the "2.5D" matching of aerial photogrammetry (the
// vertical line locus: candidate heights along each ground cell's vertical; cf. the space sweep
// of Collins, "A space-sweep approach to true multi-image matching", CVPR 1996). The
// scene seen by a vehicle's forward-and-down camera is, to a good approximation, a height field
// over the ground: soil, and the tops of the plants.
//
// For every cell of a regular ENU xy grid (default 0.5 cm: a matching patch then fits on a
// leaflet) candidate heights z are swept between bounds from a coarse ground model
// (ground − below_ground_m .. ground + max_canopy_height_m). The photo-consistency of height z is
// the zero-mean normalised cross-correlation (ZNCC) of a 5 × 5 patch of samples, one cell apart,
// on the horizontal plane at height z around the cell, sampled bilinearly in every view, between
// a reference view and each other view; the ZNCCs of the other views are aggregated robustly by
// the mean of their best half, since leaves hide the cell from some views. Because the patch
// samples of neighbouring cells coincide on the grid, each view is warped once per height onto
// the tile's grid and the ZNCCs of all cells come from box-filtered sums (O(1) per cell). The
// images are resampled once to an undistorted pinhole (a plane then maps to them by a
// homography), and the matched channel is grey plus excess green (leaves, about as grey as the
// soil, stand out), high-pass filtered (so that distant, blurred ground seen through a wrong
// height does not correlate).
//
// Coarse to fine in height: a sweep over the whole range in coarse_step_m steps, then a second
// one ± fine_half_range_m around the (3 × 3 median of the) coarse surface in fine_step_m steps —
// the patch then follows that surface instead of a horizontal plane — with a parabola through
// the winner-take-all peak. The top surface: where the coarse profile also has a peak above the
// best one, almost as good, confirmed by each reference alone and green in both, a second fine
// sweep follows it, and the cell takes it when that sweep confirms it (a top leaf over the
// canopy below it; see Options::top_surface_margin). A cell is kept when its score is high
// enough, its reference patch has texture, its coarse peak is unique, the fine peak lies inside
// the fine range, and enough of its neighbours agree with it. Then visibility: a point that
// hides many other points from the reference they were matched in is a false match floating
// above them; and islands (small connected sets of points — a plant's top leaf, or a false
// match) must be confirmed by both references and must not float high above everything around
// them.
//
// Views: per tile, the images whose camera sees the tile within the image (with a margin) and
// within max_view_distance_m. Two references — the most top-down views (highest resolution),
// from positions at least min_reference_separation_m apart (the second serves where the first is
// occluded); then the other views greedily, each time the one farthest in "height parallax"
// (where the patch moves in the image per metre of height) from those chosen, up to a useful
// parallax, beyond which the more top-down (sharper) view wins. Leaves sway in the wind, so
// where a tile holds plants (green in its first reference), only images captured near that
// reference in time are candidates (Options::near_time_s); bare soil keeps those of every pass.
//
// Memory: the tiles are matched block by block (Options::load_block_m), each block with the
// images its tiles select, so a session's images are never all in memory at once; the cells are
// held a window at a time along the region, and the points given out as they are final
// (cell_window.h), so neither the region's cells nor its cloud are ever all in memory.
//
// Written here because neither OpenCV nor any other packaged library has height-field
// multi-view stereo (OpenCV has two-view rectified block matching only).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/dense/ground_levels.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/io/ply.h"

namespace crop4d::dense {

// Pixels of one image: 8-bit RGB, row-major, 3 bytes per pixel. Empty (width 0) when the image
// could not be read.
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;
};

// A posed image. Its pixels come from the loader given to Run (only images that some tile
// selects are loaded).
struct DenseView {
  geometry::Rigid3 world_from_camera;
  std::string name;   // for messages (e.g. the image file)
  double time_s = 0;  // capture time, s (any clock common to the views)
};

// Where to reconstruct: the cells inside `bounds` that are inside one of `boxes` or within
// `radius_m` of one of `centers` (both empty: every cell of `bounds`).
struct DenseRegion {
  Eigen::AlignedBox2d bounds;
  std::vector<Eigen::AlignedBox2d> boxes;
  std::vector<Eigen::Vector2d> centers;
  double radius_m = 0.0;

  bool Contains(const Eigen::Vector2d& xy) const;
};

class HeightFieldStereo {
 public:
  struct Options {
    // Grid cell, m; also the spacing of a patch's samples, so the 5 × 5 patch spans 5 cells. The
    // patch must fit on a top leaflet (peanut leaflets are 2–5 cm long): a larger one also holds
    // the canopy a few centimetres below, which matches better and wins, and the plant's top is
    // lost. 0.5 cm cells (2.5 cm patches) gave the lowest canopy-height error on three 640×480
    // fields and on one 1280×960 field, against 0.75, 0.6 and 0.4 cm (and 0.375 cm at 1280×960);
    // on a fourth field, held out from that choice, the gain over 0.75 cm was small (1.93 →
    // 1.87 cm; the cell-size study in bench/RESULTS.md). 1 cm cells flatten the tops of small
    // plants by 1–3 cm. The cost grows with the number of cells: 0.5 cm costs 2.1× as much as
    // 0.75 cm.
    double cell_m = 0.005;
    // Cells per side of a tile, the unit of parallel work and of view selection.
    int tile_cells = 32;
    // Radius of a patch in samples, (2r+1)² samples, in the coarse sweep.
    int patch_radius = 2;
    // Lowest height swept below the ground model, m.
    double below_ground_m = 0.15;
    // Highest height swept above the ground model, m (the tallest plant expected).
    double max_canopy_height_m = 1.0;
    // Height step of the coarse sweep over the whole range, m.
    double coarse_step_m = 0.01;
    // The fine sweep covers ± this around the coarse surface, m...
    double fine_half_range_m = 0.025;
    // ...in steps of this, m (then a parabola through the peak).
    double fine_step_m = 0.0025;
    // Radius of a patch in samples in the fine sweep.
    int fine_patch_radius = 2;
    // Views per tile, the two references included.
    int max_views = 7;
    // Leaves in the wind: where a tile holds plants (at least near_time_min_green of its ground,
    // as its first reference sees it, is green: excess green ≥ top_surface_min_excess_green),
    // its views are the images captured within near_time_s of its first reference (at least
    // min_views + 2 of them, the nearest in time); elsewhere, images of any time (the views of
    // other passes measure still soil better). 0: time plays no part. Measured in
    // bench/RESULTS.md, "Leaves in the wind".
    double near_time_s = 0.8;
    double near_time_min_green = 0.05;
    // A view is used for a tile when its camera is within this distance of the tile's centre, m,
    double max_view_distance_m = 3.2;
    // ...and sees the tile's corners at least this far inside the image, px.
    double image_margin_px = 3.0;
    // The second reference's camera is at least this far from the first's, m.
    double min_reference_separation_m = 0.5;
    // A cell needs the ZNCC of at least this many views besides its reference.
    int min_views = 2;
    // Least aggregated ZNCC (mean of the best half of the other views') of a point.
    double min_score = 0.5;
    // Least standard deviation of the reference patch (high-passed grey levels).
    double min_texture = 2.0;
    // Least margin of the coarse peak over the best score more than 2 cm away from it.
    double min_uniqueness = 0.05;
    // The top surface. A height field holds one height per cell, and the canopy's is its top;
    // but a small top leaf, no larger than the patch, fills only part of it and scores lower
    // than the broader canopy below it, which the oblique views see past the leaf. So where the
    // coarse score profile has a peak more than 2 cm above the best one, scoring at most this
    // much less than the best (0: off), scored at least top_surface_min_reference_score by each
    // reference alone, at least top_surface_min_height_m above the ground model (soil has no
    // layer above it) and green in both references (excess green 2g − r − b at least
    // top_surface_min_excess_green: a leaf), the highest such peak gets a fine sweep of its own,
    // and the cell takes it when that sweep keeps it and its point is still green; otherwise
    // the cell keeps its best peak. Measured on the demo field and a second one:
    // bench/RESULTS.md, crop analysis (the top surface).
    double top_surface_margin = 0.15;
    double top_surface_min_reference_score = 0.45;
    double top_surface_min_height_m = 0.05;
    double top_surface_min_excess_green = 0.1;
    // A point needs at least this many of its 8 neighbours within neighbour_tolerance_m...
    int min_neighbours = 3;
    // ...a height difference, m, that also links neighbours into connected sets (islands).
    double neighbour_tolerance_m = 0.02;
    // Visibility: a point more than visibility_tolerance_m above the reference rays of more than
    // max_blocked_rays other points hides them from the view they were matched in, and goes
    // (0: no check).
    int max_blocked_rays = 3;
    // Tolerance of that test, m.
    double visibility_tolerance_m = 0.03;
    // Where both references score a cell, the heights each finds alone must agree to this, m
    // (0: no check; island_max_disagreement_m applies a looser one to islands).
    double cross_check_m = 0.0;
    // Islands are connected sets of points smaller than this, m² (0: no island checks). A top
    // leaflet is often one; so is a false match (a matching window's size).
    double island_area_m2 = 0.002;
    // Island points whose two references, each alone, find heights further apart than this go, m.
    double island_max_disagreement_m = 0.1;
    // An island rising more than this above every other point within island_radius_m goes, m
    // (a leaf does not float high above everything around it).
    double island_max_rise_m = 0.2;
    // Neighbourhood of that test, m.
    double island_radius_m = 0.2;
    // The matched channel is grey + vegetation_weight · max(0, 2G − R − B) (excess green).
    double vegetation_weight = 3.0;
    // The matched channel is high-pass filtered: minus a Gaussian blur of this sigma, px (0: off).
    double highpass_sigma_px = 2.0;
    // Gain of the high-passed channel stored in 8 bits.
    double highpass_gain = 2.0;
    // The tiles are matched block by block, squares of this side, m, in bands across the
    // region's longer side, one band after the other: the images a block's tiles select are
    // loaded before it and those the next block does not select are freed after it, so that
    // memory holds a block's images, not the session's. The result does not depend on it;
    // larger blocks load fewer images twice (an image that two blocks select is loaded for
    // each).
    double load_block_m = 4.0;
    // Progress bars while loading and matching.
    bool show_progress = true;

    OptionCheck Check() const;
  };

  struct Summary {
    std::int64_t num_cells = 0;             // cells of the region
    std::int64_t num_cells_with_views = 0;  // with a reference and min_views other views
    std::int64_t num_points = 0;            // kept
    std::int64_t num_top_surface = 0;       // kept points on a top surface (top_surface_margin)
    // Rejected cells by the first test they failed.
    std::int64_t num_low_texture = 0;
    std::int64_t num_low_score = 0;
    std::int64_t num_not_unique = 0;
    std::int64_t num_at_range_edge = 0;
    std::int64_t num_isolated = 0;
    std::int64_t num_occluding = 0;  // hide more than max_blocked_rays points from their reference
    int num_tiles = 0;
    int num_tiles_near_in_time = 0;   // tiles with plants, matched in views near in time
    int num_views = 0;                // given
    int num_images_used = 0;          // loaded (selected by some tile)
    int num_images_failed = 0;        // selected but unreadable
    int num_blocks = 0;               // blocks of tiles matched one after the other
    int num_image_loads = 0;          // images loaded, counting one loaded for two blocks twice
    int max_images_loaded = 0;        // the most images in memory at once
    std::int64_t max_cells_held = 0;  // the most cells of the region in memory at once
    // The farthest a cell lies, horizontally, from a reference camera of its tile, m: the reach
    // of the visibility test, which sets how many cells are held.
    double reference_reach_m = 0;
    double mean_views_per_tile = 0;
    double load_seconds = 0;
    double match_seconds = 0;
    double total_seconds = 0;
  };

  struct Result {
    // Points (x, y, z in the world frame, one per kept cell at its centre), RGB from their
    // reference view, and the scalar fields "score" (aggregated ZNCC, float), "num_views"
    // (reference + other views scored, uchar) and "uniqueness" (see min_uniqueness, float).
    io::PlyPointCloud cloud;
    Summary summary;
  };

  using ImageLoader = std::function<RgbImage(int view)>;
  // Receives the points of the cloud, a part at a time, in the cloud's order.
  using PointSink = std::function<void(const io::PlyPointCloud& part)>;

  explicit HeightFieldStereo(const Options& options);

  // The layout of Result::cloud and of the parts a PointSink receives: colours and the scalar
  // fields score, num_views and uniqueness.
  static io::PlyLayout CloudLayout();

  // Reconstructs `region`: `views` are the posed images of one camera, `load(i)` gives the
  // pixels of views[i] (called in parallel, for the selected views of each block of tiles:
  // Options::load_block_m), `ground` bounds the heights. Parallel over tiles (oneTBB, the
  // caller's arena). The points go to `sink` as they are final, a band of the region at a time
  // (Result::cloud then stays empty), or into Result::cloud when there is no sink.
  Result Run(const geometry::PinholeRadTan& camera, const std::vector<DenseView>& views,
             const ImageLoader& load, const DenseRegion& region, const GroundLevels& ground,
             const PointSink& sink = nullptr) const;

 private:
  Options options_;
};

}  // namespace crop4d::dense
