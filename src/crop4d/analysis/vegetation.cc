#include "crop4d/analysis/vegetation.h"

#include <algorithm>
#include <cmath>

#include "crop4d/core/error.h"

namespace crop4d::analysis {

const char* GreennessIndexName(GreennessIndex index) {
  switch (index) {
    case GreennessIndex::kExG:
      return "ExG";
    case GreennessIndex::kExGR:
      return "ExGR";
  }
  return "?";
}

float Greenness(GreennessIndex index, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  const int sum = int{r} + int{g} + int{b};
  if (sum == 0) return 0.0f;
  const float inv = 1.0f / static_cast<float>(sum);
  const float rc = r * inv, gc = g * inv, bc = b * inv;
  const float exg = 2.0f * gc - rc - bc;
  switch (index) {
    case GreennessIndex::kExG:
      return exg;
    case GreennessIndex::kExGR:
      return exg - (1.4f * rc - gc);
  }
  return exg;
}

// Written here rather than cv::threshold(THRESH_OTSU): that one needs an 8-bit image (the
// index would have to be quantised to a fixed range first), does not return the separability,
// and would pull OpenCV's imgproc into this module for some forty lines.
OtsuResult OtsuThreshold(const std::vector<float>& values, int bins) {
  return OtsuThreshold(values, std::vector<double>(values.size(), 1.0), bins);
}

OtsuResult OtsuThreshold(const std::vector<float>& values, const std::vector<double>& weights,
                         int bins) {
  CROP4D_CHECK(bins >= 2);
  CROP4D_CHECK(weights.size() == values.size());
  OtsuResult result;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  double n = 0.0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const float v = values[i];
    if (!std::isfinite(v) || !(weights[i] > 0.0)) continue;
    n += weights[i];
    lo = std::min(lo, static_cast<double>(v));
    hi = std::max(hi, static_cast<double>(v));
  }
  result.num_values = static_cast<std::size_t>(std::llround(n));
  if (!(n > 0.0)) return result;
  if (!(hi > lo)) {  // one distinct value: nothing to separate
    result.threshold = lo;
    return result;
  }

  const double width = (hi - lo) / bins;
  std::vector<double> count(bins, 0.0);
  for (std::size_t i = 0; i < values.size(); ++i) {
    const float v = values[i];
    if (!std::isfinite(v) || !(weights[i] > 0.0)) continue;
    const int k = static_cast<int>((static_cast<double>(v) - lo) / width);
    count[std::clamp(k, 0, bins - 1)] += weights[i];
  }
  // Probabilities and moments over the bin centres c_k = lo + (k + 1/2) width, in bin units
  // (u_k = k + 1/2) to keep the sums well conditioned.
  double mean_total = 0.0;
  for (int k = 0; k < bins; ++k) mean_total += count[k] / n * (k + 0.5);
  double var_total = 0.0;
  for (int k = 0; k < bins; ++k) {
    var_total += count[k] / n * (k + 0.5 - mean_total) * (k + 0.5 - mean_total);
  }

  // Otsu (1979), eq. (18): sigma_B^2(k) = (mu_T omega(k) - mu(k))^2 / (omega(k) (1 - omega(k))),
  // omega(k), mu(k) the zeroth and first cumulative moments up to bin k.
  std::vector<double> between(bins - 1, 0.0);
  double cumulative = 0.0, mu = 0.0, best = -1.0;
  for (int k = 0; k + 1 < bins; ++k) {
    cumulative += count[k];  // exact for integer counts
    mu += count[k] / n * (k + 0.5);
    if (cumulative <= 0.0 || cumulative >= n) continue;  // one class empty
    const double omega = cumulative / n;
    const double d = mean_total * omega - mu;
    between[k] = d * d / (omega * (1.0 - omega));
    best = std::max(best, between[k]);
  }
  // Ties: splits inside a run of empty bins leave the classes unchanged; take the middle of
  // the first run of maxima.
  const double tolerance = 1e-12 * std::max(best, 1.0);
  int first = -1, last = -1;
  for (int k = 0; k + 1 < bins; ++k) {
    if (between[k] >= best - tolerance) {
      if (first < 0) first = k;
      last = k;
    } else if (first >= 0) {
      break;
    }
  }
  CROP4D_CHECK(first >= 0);
  result.threshold = lo + (0.5 * (first + last) + 1.0) * width;
  result.separability = var_total > 0.0 ? std::clamp(best / var_total, 0.0, 1.0) : 0.0;
  return result;
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The weighted mean of the values in (lo, hi]; NaN when there is none.
double MeanIn(const std::vector<float>& values, const std::vector<double>& weights, double lo,
              double hi) {
  double sum = 0.0, n = 0.0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (values[i] > lo && values[i] <= hi) {
      sum += weights[i] * values[i];
      n += weights[i];
    }
  }
  return n > 0.0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

std::uint32_t Packed(const std::array<std::uint8_t, 3>& c) {
  return (std::uint32_t{c[0]} << 16) | (std::uint32_t{c[1]} << 8) | std::uint32_t{c[2]};
}

}  // namespace

OptionCheck VegetationOptions::Check() const {
  OptionChecker c;
  c.Require(index == GreennessIndex::kExG || index == GreennessIndex::kExGR, "index",
            "must be exg or exgr")
      .Require(std::isnan(threshold) || std::isfinite(threshold), "threshold",
               "must be finite or NaN (automatic)", threshold)
      .Finite("min_threshold", min_threshold)
      .Finite("min_separability", min_separability)
      .InRange("min_separability", min_separability, 0.0, 1.0)
      .InRange("histogram_bins", histogram_bins, 2, 1 << 20);
  return c.Result();
}

double VegetationClassification::Fraction() const {
  return is_vegetation.empty()
             ? 0.0
             : static_cast<double>(num_vegetation) / static_cast<double>(is_vegetation.size());
}

void ColourHistogram::Add(const std::array<std::uint8_t, 3>& colour, std::uint64_t count) {
  counts_[Packed(colour)] += count;
  total_ += count;
}

void ColourHistogram::Add(const std::vector<std::array<std::uint8_t, 3>>& colours) {
  for (const auto& c : colours) Add(c);
}

std::vector<std::pair<std::uint32_t, std::uint64_t>> ColourHistogram::Entries() const {
  std::vector<std::pair<std::uint32_t, std::uint64_t>> out(counts_.begin(), counts_.end());
  std::sort(out.begin(), out.end());
  return out;
}

VegetationClassification VegetationThreshold(const ColourHistogram& colours,
                                             const VegetationOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "VegetationThreshold");
  // One value per distinct colour, weighted by its count (in colour order: reproducible).
  std::vector<float> index;
  std::vector<double> weight;
  for (const auto& [packed, count] : colours.Entries()) {
    index.push_back(Greenness(options.index, static_cast<std::uint8_t>(packed >> 16),
                              static_cast<std::uint8_t>(packed >> 8),
                              static_cast<std::uint8_t>(packed)));
    weight.push_back(static_cast<double>(count));
  }
  VegetationClassification out;
  const OtsuResult otsu = OtsuThreshold(index, weight, options.histogram_bins);
  out.separability = otsu.separability;
  if (!std::isnan(options.threshold)) {
    out.threshold = options.threshold;
  } else if (otsu.separability >= options.min_separability && std::isfinite(otsu.threshold) &&
             MeanIn(index, weight, -kInf, otsu.threshold) < options.min_threshold) {
    // Otsu's lower class is soil (its mean below min_threshold). Plants may form more than one
    // mode (sunlit tops and shaded lower leaves: ExG ~0.65 and ~0.25 on the synthetic field),
    // and next to a dominant soil mode Otsu may split the plants rather than soil from plants.
    // So descend: split the values <= t again, and take the split when what it moves to the
    // vegetation (the values in (t', t]) is green on average (mean >= min_threshold). Splitting
    // the soil itself moves soil, whose mean is below min_threshold, and ends the descent.
    double threshold = otsu.threshold;
    std::vector<double> lower(weight.size());
    for (int step = 0; step < 16; ++step) {
      for (std::size_t i = 0; i < index.size(); ++i) {
        lower[i] = index[i] <= threshold ? weight[i] : 0.0;
      }
      const OtsuResult below = OtsuThreshold(index, lower, options.histogram_bins);
      if (!(below.threshold < threshold) ||
          !(MeanIn(index, lower, below.threshold, threshold) >= options.min_threshold)) {
        break;
      }
      threshold = below.threshold;
    }
    out.threshold = std::max(threshold, options.min_threshold);
    out.automatic = true;
  } else {
    out.threshold = options.min_threshold;
  }
  for (std::size_t i = 0; i < index.size(); ++i) {
    if (index[i] > out.threshold) out.num_vegetation += static_cast<std::size_t>(weight[i]);
  }
  return out;
}

bool IsVegetationColour(const VegetationClassification& classification, GreennessIndex index,
                        const std::array<std::uint8_t, 3>& colour) {
  return Greenness(index, colour[0], colour[1], colour[2]) > classification.threshold;
}

VegetationClassification ClassifyVegetation(const std::vector<std::array<std::uint8_t, 3>>& colors,
                                            const VegetationOptions& options) {
  ColourHistogram histogram;
  histogram.Add(colors);
  VegetationClassification out = VegetationThreshold(histogram, options);
  out.num_vegetation = 0;  // counted again below, point by point
  out.index.resize(colors.size());
  out.is_vegetation.resize(colors.size());
  for (std::size_t i = 0; i < colors.size(); ++i) {
    out.index[i] = Greenness(options.index, colors[i][0], colors[i][1], colors[i][2]);
    out.is_vegetation[i] = out.index[i] > out.threshold ? 1 : 0;
    out.num_vegetation += out.is_vegetation[i];
  }
  return out;
}

}  // namespace crop4d::analysis
