#include "crop4d/pipeline/pass_standstills.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "crop4d/slam/initialisation.h"

namespace crop4d::pipeline {

std::vector<std::optional<double>> ConsecutiveImageMotion(const features::FrontEnd::Result& front,
                                                          std::size_t num_images) {
  std::vector<std::optional<double>> motion(num_images > 0 ? num_images - 1 : 0);
  for (const features::PairMatches& pair : front.pairs) {
    if (pair.image2 != pair.image1 + 1 || pair.image1 < 0 ||
        static_cast<std::size_t>(pair.image2) >= num_images || pair.matches.size() < 8) {
      continue;
    }
    const features::FeatureSet& a = front.features[pair.image1];
    const features::FeatureSet& b = front.features[pair.image2];
    std::vector<double> d;
    d.reserve(pair.matches.size());
    for (const features::FeatureMatch& m : pair.matches) {
      const features::Keypoint& p = a.keypoints[m.feature1];
      const features::Keypoint& q = b.keypoints[m.feature2];
      d.push_back(std::hypot(q.x - p.x, q.y - p.y));
    }
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    motion[pair.image1] = d[d.size() / 2];
  }
  return motion;
}

std::vector<bool> DetectPassStandstills(const std::vector<Timestamp>& times,
                                        const slam::ImuStream& imu,
                                        const features::FrontEnd::Result* front,
                                        const std::vector<slam::GpsFixWorld>* gps,
                                        const slam::StandstillOptions& options) {
  if (times.size() < 2) return {};
  const std::vector<slam::TimeInterval> quiet =
      slam::QuietImuIntervals(imu.samples, imu.sensor.rate_hz, options);
  std::vector<slam::IntervalMotion> motion(times.size() - 1);
  if (front != nullptr) {
    const std::vector<std::optional<double>> image = ConsecutiveImageMotion(*front, times.size());
    for (std::size_t k = 0; k < motion.size(); ++k) {
      // A pair without enough matches (blur, a blank view) cannot show that the camera is still.
      motion[k].image_motion_px = image[k] ? *image[k] : std::numeric_limits<double>::infinity();
    }
  }
  if (gps != nullptr && !gps->empty()) {
    for (std::size_t k = 0; k < motion.size(); ++k) {
      const Timestamp mid = times[k] + (times[k + 1] - times[k]) / 2;
      if (const auto fit = slam::FitGpsTrack(*gps, mid, 1.0)) {
        motion[k].gps_speed = fit->velocity_world.head<2>().norm();
      }
    }
  }
  return slam::StillIntervals(times, quiet, motion, options);
}

}  // namespace crop4d::pipeline
