#include "crop4d/slam/image_quality.h"

#include <algorithm>
#include <cmath>

namespace crop4d::slam {

OptionCheck ImageWeightOptions::Check() const {
  OptionChecker c;
  c.AtLeast("window", window, 1)
      .Require(window % 2 == 1, "window", "must be odd", window)
      .AtLeast("max_sigma_scale", max_sigma_scale, 1.0);
  return c.Result();
}

std::vector<double> ImageSigmaScales(const std::vector<double>& sharpness,
                                     const ImageWeightOptions& options) {
  const int n = static_cast<int>(sharpness.size());
  std::vector<double> scales(n, 1.0);
  if (!options.enabled) return scales;
  const int half = options.window / 2;
  std::vector<double> neighbours;
  for (int i = 0; i < n; ++i) {
    if (!(sharpness[i] > 0.0)) continue;
    // The window is shifted inwards at the pass's ends so that it always spans `window` images.
    const int first = std::clamp(i - half, 0, std::max(0, n - options.window));
    const int last = std::min(n, first + options.window);
    neighbours.clear();
    for (int k = first; k < last; ++k) {
      if (sharpness[k] > 0.0) neighbours.push_back(sharpness[k]);
    }
    const auto middle = neighbours.begin() + neighbours.size() / 2;
    std::nth_element(neighbours.begin(), middle, neighbours.end());
    const double reference = *middle;
    scales[i] = std::clamp(std::sqrt(reference / sharpness[i]), 1.0, options.max_sigma_scale);
  }
  return scales;
}

}  // namespace crop4d::slam
