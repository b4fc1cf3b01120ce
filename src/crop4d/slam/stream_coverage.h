#pragma once

// How well a sensor stream covers a stretch of time: the gaps between its samples (an IMU or GPS
// outage inside a row pass), and the horizontal precision of a GPS track (whether a
// receiver is precise enough for the session solve, the standstill test and the scale).

#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/slam/session_streams.h"

namespace crop4d::slam {

struct TimeGaps {
  // The longest time without a sample, s.
  double longest_s = 0;
  // How many gaps are longer than the threshold.
  int count_over = 0;
};

// The gaps in [begin, end] between the elements of `sorted` (ascending) that lie in it, the span's
// ends included as the first and last bounds: the longest, and how many exceed threshold_s.
TimeGaps FindTimeGaps(const std::vector<Timestamp>& sorted, Timestamp begin, Timestamp end,
                      double threshold_s);

// The median horizontal sigma of the fixes, m (the upper median of an even count); infinity
// without fixes.
double MedianSigmaH(const std::vector<GpsFixWorld>& fixes);

// The horizontal sigma that a share `q` (0–1) of the fixes is within, m: the sorted sigmas'
// element at index ⌊q·n⌋ (q = 0.5: MedianSigmaH); infinity without fixes.
double SigmaHQuantile(const std::vector<GpsFixWorld>& fixes, double q);

}  // namespace crop4d::slam
