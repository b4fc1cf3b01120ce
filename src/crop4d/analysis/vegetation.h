#pragma once

// Vegetation by colour (DESIGN.md §2.6): a greenness index per coloured point, computed on the
// chromatic coordinates r = R/(R+G+B), g = G/(R+G+B), b = B/(R+G+B) (all 0 for black), and a
// threshold that separates plants from soil, chosen by Otsu's method when the index histogram
// is bimodal.
//
//   ExG  = 2g - r - b                    excess green (Woebbecke et al. 1995, Trans. ASAE 38(1))
//   ExR  = 1.4r - g                      excess red (Meyer, Hindman & Lakshmi 1998)
//   ExGR = ExG - ExR                     excess green minus excess red (Meyer & Neto 2008,
//                                        Comput. Electron. Agric. 63(2)); plants where ExGR > 0
//
// Typical values on our synthetic field: bare soil (149,126,103) or (72,60,50) ExG ≈ 0,
// ExGR ≈ -0.22; leaves (62,85,44)..(90,110,60) ExG ≈ 0.27..0.34, ExGR ≈ 0.2..0.33.

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::analysis {

enum class GreennessIndex {
  kExG,   // excess green, 2g - r - b, in [-1, 2]
  kExGR,  // excess green minus excess red, ExG - (1.4r - g), in [-2.4, 3]
};

// "ExG" or "ExGR".
const char* GreennessIndexName(GreennessIndex index);

// The index of one RGB colour (0 for black). Larger is greener for both indices.
float Greenness(GreennessIndex index, std::uint8_t r, std::uint8_t g, std::uint8_t b);

struct OtsuResult {
  // Values above it are the upper class. NaN when there is no finite value; the value itself
  // when all finite values are equal.
  double threshold = std::numeric_limits<double>::quiet_NaN();
  // Otsu's measure of goodness eta = between-class variance / total variance at the threshold,
  // in [0, 1]: 1 for two separated spikes, ~0.64 for one Gaussian (2/pi), 0.75 for a uniform
  // distribution; 0 when there are fewer than 2 distinct values.
  double separability = 0.0;
  // Finite values used (NaN and infinities are left out).
  std::size_t num_values = 0;
};

// Otsu's threshold (N. Otsu, "A threshold selection method from gray-level histograms", IEEE
// Trans. SMC 9(1), 1979) of the finite `values`, on a histogram of `bins` (>= 2) equal bins
// spanning their range. The threshold maximises the between-class variance; when several
// thresholds tie (empty bins between the classes), the middle of the gap is returned.
OtsuResult OtsuThreshold(const std::vector<float>& values, int bins = 256);
// The same with a weight per value (each value counted `weights[i]` times; num_values is then
// the sum of the weights of the finite values).
OtsuResult OtsuThreshold(const std::vector<float>& values, const std::vector<double>& weights,
                         int bins = 256);

struct VegetationOptions {
  // The greenness index.
  GreennessIndex index = GreennessIndex::kExG;
  // A point is vegetation when its index is above this threshold; NaN: chosen automatically
  // (Otsu's threshold when the histogram is bimodal, else min_threshold; ClassifyVegetation).
  double threshold = std::numeric_limits<double>::quiet_NaN();
  // The automatic threshold is never below this. Soil-only clouds are unimodal around 0 and
  // Otsu would split the soil in two; 0.05 lies above the soil's spread (|ExG| < 0.05 for 99%
  // of the soil points of the synthetic field) and far below leaves (ExG > 0.2).
  double min_threshold = 0.05;
  // Below this separability (Otsu's eta) of the whole histogram it is taken as unimodal (only
  // soil or only plants) and the threshold is min_threshold. One Gaussian gives eta = 0.64 and a
  // uniform distribution 0.75, whatever their width, so 0.8 rejects unimodal histograms with a
  // margin. The demo field's sparse clouds give 0.86-0.90 with 5-6% vegetation (ExG) and
  // 0.77-0.83 with 2-3%, where Otsu's threshold and min_threshold classify alike.
  double min_separability = 0.8;
  // Histogram bins for Otsu's method (over the range of the index values).
  int histogram_bins = 256;

  OptionCheck Check() const;
};

struct VegetationClassification {
  std::vector<std::uint8_t> is_vegetation;  // 1: vegetation, 0: not; one per colour
  std::vector<float> index;                 // the greenness index of each colour
  double threshold = 0.0;                   // the threshold applied (index > threshold)
  // Otsu's separability of the index histogram (computed whatever the threshold's source).
  double separability = 0.0;
  // The threshold came from the data (Otsu, raised to min_threshold at least); false: the
  // manual threshold, or min_threshold because the histogram does not separate soil from
  // plants (see ClassifyVegetation).
  bool automatic = false;
  std::size_t num_vegetation = 0;  // points classified as vegetation

  // num_vegetation / number of points (0 when empty).
  double Fraction() const;
};

// How many points have each colour: the greenness index is a function of the colour, so the
// automatic threshold of a cloud follows from these counts, which can be gathered a part of
// the cloud at a time and hold at most one entry per distinct colour (2^24).
class ColourHistogram {
 public:
  void Add(const std::array<std::uint8_t, 3>& colour, std::uint64_t count = 1);
  void Add(const std::vector<std::array<std::uint8_t, 3>>& colours);
  // Points counted.
  std::uint64_t total() const { return total_; }
  // The distinct colours (packed 0xRRGGBB, increasing) and their counts.
  std::vector<std::pair<std::uint32_t, std::uint64_t>> Entries() const;

 private:
  std::unordered_map<std::uint32_t, std::uint64_t> counts_;
  std::uint64_t total_ = 0;
};

// The threshold that ClassifyVegetation applies, from a cloud's colour counts: options.threshold
// when set, else the automatic one (below). `is_vegetation` and `index` of the result are empty;
// num_vegetation counts the colours above the threshold.
VegetationClassification VegetationThreshold(const ColourHistogram& colours,
                                             const VegetationOptions& options = {});

// Whether `colour` is vegetation under `classification`'s threshold (index > threshold).
bool IsVegetationColour(const VegetationClassification& classification, GreennessIndex index,
                        const std::array<std::uint8_t, 3>& colour);

// Classifies each colour as vegetation (index > threshold) or not. The automatic threshold
// (options.threshold NaN):
//  1. t = Otsu's threshold of all index values. When their separability is below
//     min_separability (unimodal: only soil, or only plants), or when the mean of the values
//     <= t is not below min_threshold (the lower class is not soil: several modes of plants
//     only), the threshold is min_threshold and `automatic` is false.
//  2. Descent: t' = Otsu's threshold of the values <= t; while the values in (t', t] have a
//     mean >= min_threshold (green on average: a mode of plants, e.g. shaded leaves next to
//     sunlit ones), t = t'. Splitting the soil itself ends it.
//  3. t is raised to min_threshold.
// Options must pass Check() (CHECK). An empty input gives an empty classification with
// threshold min_threshold.
VegetationClassification ClassifyVegetation(const std::vector<std::array<std::uint8_t, 3>>& colors,
                                            const VegetationOptions& options = {});

}  // namespace crop4d::analysis
