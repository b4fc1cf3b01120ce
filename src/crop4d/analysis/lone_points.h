#pragma once

// Lone points of a dense cloud: points without another point within a small radius (3D).
//
// A dense cloud samples every surface it holds — soil, leaves, stems — at a spacing of a few
// millimetres, so each of its points has neighbours within a couple of centimetres. A false
// stereo match is a point on no surface: it floats alone, above a plant or below the soil, and a
// canopy height that takes a plant's highest point would take it for the plant's top (on the
// demo field one such point, 14 cm above its plant, made a site 5 cm too high). This is radius
// outlier removal (as PCL's RadiusOutlierRemoval), for dense clouds only: a sparse cloud's points
// are centimetres to decimetres apart and would all be lone.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace crop4d::analysis {

// For each point, 1 when fewer than `min_neighbors` other points lie within `radius_m` of it
// (Euclidean, 3D), else 0. Duplicated points count as neighbours of each other. The points must
// be finite.
std::vector<std::uint8_t> FindLonePoints(const std::vector<Eigen::Vector3d>& points,
                                         double radius_m, int min_neighbors = 1);

}  // namespace crop4d::analysis
