#pragma once

// How precisely each image of a pass localises its keypoints, from its sharpness
// (features::FeatureSet::sharpness: its gradient energy in its worst direction). By the
// Cramér–Rao bound of image registration a keypoint's position error has a standard deviation
// ∝ 1/√(the gradient energy of its patch), so an image whose sharpness fell below its neighbours' —
// motion blur in a bump or a turn, a darker exposure under a cloud — has its keypoints
// down-weighted by √(reference / sharpness): its reprojection factors get a larger sigma, and
// none of its observations is dropped for it. The reference is the median sharpness of the
// images around it (a window along the pass): the scene itself changes slowly along a pass
// (soil, plants, the headland), blur and exposure from one image to the next.

#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::slam {

struct ImageWeightOptions {
  // Down-weight images that are less sharp than their neighbours (false: every image weighs
  // the same).
  bool enabled = true;
  // Images (the image itself included) whose median sharpness is an image's reference; odd.
  int window = 15;
  // The factor on an image's reprojection sigma is at most this: a far worse image still
  // holds its track's place rather than being lost.
  double max_sigma_scale = 3.0;

  OptionCheck Check() const;
};

// The factor (≥ 1) on the reprojection sigma of each image, in the order of `sharpness` (one
// value per image along the pass). Images sharper than their reference keep 1 (never
// up-weighted: the sigma is that of a good image); an image with sharpness 0 (not measured)
// keeps 1 and is no reference for the others. All 1 when disabled or nothing was measured.
std::vector<double> ImageSigmaScales(const std::vector<double>& sharpness,
                                     const ImageWeightOptions& options);

}  // namespace crop4d::slam
