#pragma once

// Thinning of the cross matches of two passes before the joint 4D problem (DESIGN.md §2.4): a
// few dozen matches per image pair register the passes as well as hundreds and keep the joint
// problem small. The best matches by descriptor distance are kept, taken in turn from the cells
// of a kThinningGridCells × kThinningGridCells grid over image a, so that they spread over the
// view (matches bunched in one corner constrain the rotation poorly).

#include <vector>

#include "crop4d/association/association_file.h"

namespace crop4d::association {

// Cells per side of the grid over image a: 4 × 4 cells give each of a few dozen matches a part
// of the view to itself.
inline constexpr int kThinningGridCells = 4;

// At most `max_per_pair` matches of every image pair (image_a, image_b) of `all` (0: all), the
// best of each grid cell first, round by round. Image pairs come out in order of (image_a,
// image_b), the matches of a pair that needs no thinning in their given order. Image a is
// `width` × `height` pixels.
std::vector<CrossMatch> ThinCrossMatches(const std::vector<CrossMatch>& all, int width, int height,
                                         int max_per_pair);

}  // namespace crop4d::association
