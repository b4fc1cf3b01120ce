#pragma once

// Individual plants, "separated by colour" as in the paper (Dong et al. 2017, §V): early in the
// season the plants are small islands of vegetation on bare soil. Each island of canopy cells
// (vegetation at least CanopyOptions::min_height_m above the ground, binned into `cell_m` cells,
// 8-connected after closing gaps of one cell) is a plant, and its stem lies under its top: the
// centroid of the plant's cells within `top_fraction` of its highest. Two plants whose leaves
// touch make one island; it is split at the saddle between their tops when the lower top rises
// above it by the prominence (`min_prominence_m`, `min_prominence_fraction`). Later, when the
// canopy closes and islands merge, the stems found early keep identifying the plants: a site's
// canopy height is then the mean over the plants whose stems lie in the site of each plant's top
// (the highest canopy within `top_radius_m` of its stem) — what a person with a ruler measures,
// plant by plant (analysis/canopy.h, CanopyTop::kPlantTops).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "crop4d/analysis/canopy.h"
#include "crop4d/core/option_check.h"
#include "crop4d/io/dataset.h"

namespace crop4d::analysis {

struct PlantDetectionOptions {
  // Cell size of the vegetation mask, metres.
  double cell_m = 0.01;
  // Smallest island, and smallest plant split from one, in cells (noise and lone green points
  // are not plants).
  int min_cells = 3;
  // Islands larger than this (m²) are a closed canopy, not one plant: not used for stems.
  double max_area_m2 = 0.09;
  // The stem is the centroid of the plant's cells at least this fraction of its top height.
  double top_fraction = 0.8;
  // Two touching plants make one island; it is split at a saddle when the lower top rises at
  // least this much above it, m...
  double min_prominence_m = 0.01;
  // ...and at least this fraction of its own height.
  double min_prominence_fraction = 0.15;
  // Stems closer than this are one plant (an island split in two by a gap in the cloud),
  // metres.
  double min_spacing_m = 0.08;
  // Where the field declares its rows (field.yaml), a plant whose stem lies farther than this
  // from every row's centre line is no plant of the crop — a weed, or noise on the soil between
  // the rows — and no site counts it (PlantsOnRows), metres; 0: every plant counts. Seeders
  // place the crop within a few centimetres of the line; the bound leaves room for a row
  // declared a few centimetres off. Measured in bench/RESULTS.md, "Leaves in the wind".
  double max_row_offset_m = 0.15;

  OptionCheck Check() const;
};

struct DetectedPlant {
  Eigen::Vector2d stem = Eigen::Vector2d::Zero();  // ENU xy
  double height_m = 0.0;                           // its top above the ground
  double area_m2 = 0.0;                            // area of its canopy cells
};

// The plants of one session's cloud within `area`, heights above `ground`; plants closer than
// `min_spacing_m` are merged (the larger island is kept).
std::vector<DetectedPlant> DetectPlants(const SessionCloud& cloud, const GroundFunction& ground,
                                        const Eigen::AlignedBox2d& area,
                                        const CanopyOptions& canopy,
                                        const PlantDetectionOptions& options);

// The canopy raster that DetectPlants reads (per cell of `cell_m` over the area, the highest
// canopy above the ground), filled a part of a cloud at a time: each cell keeps a maximum, so
// adding the parts of a cloud (each point once) gives the raster of the whole cloud, and the
// same plants. Its memory follows the area (4 bytes a cell), not the points.
class PlantRaster {
 public:
  PlantRaster(const Eigen::AlignedBox2d& area, const CanopyOptions& canopy,
              const PlantDetectionOptions& options);
  void Add(const SessionCloud& cloud, const GroundFunction& ground);
  // The plants of the points added (DetectPlants).
  std::vector<DetectedPlant> Detect() const;

 private:
  Eigen::AlignedBox2d area_;
  CanopyOptions canopy_;
  PlantDetectionOptions options_;
  int rows_ = 0, cols_ = 0;
  std::vector<float> height_;  // row-major, 0: no canopy
};

// The plants whose stems lie within max_row_offset_m of the centre line (the segment from start
// to end) of one of `rows`; all of them when `rows` is empty or max_row_offset_m is 0.
std::vector<DetectedPlant> PlantsOnRows(std::vector<DetectedPlant> plants,
                                        const std::vector<io::RowDeclaration>& rows,
                                        const PlantDetectionOptions& options);

}  // namespace crop4d::analysis
