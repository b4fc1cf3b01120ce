#pragma once

// Test helper: a small workspace with what the viewer reads (two sessions with dense clouds of a
// soil plane and plants that grow between the dates, trajectories, site tables), written with
// the io writers.

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "crop4d/io/ply.h"
#include "crop4d/io/test_helpers.h"
#include "crop4d/io/tum.h"

namespace crop4d::viewer::testing {

// Soil at z = 0.02·x, plants as columns at (1, 2 k) of height `plant_m`.
inline io::PlyPointCloud FieldCloud(int n, double plant_m, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  io::PlyPointCloud cloud;
  for (int i = 0; i < n; ++i) {
    double x = 3.0 * u(rng), y = 10.0 * u(rng);
    double z = 0.02 * x;
    std::array<std::uint8_t, 3> rgb{120, 90, 60};
    if (i % 4 == 0) {  // a plant point
      x = 1.0 + 0.1 * (u(rng) - 0.5);
      y = 2.0 * double(1 + (i / 4) % 4) + 0.1 * (u(rng) - 0.5);
      z += plant_m * u(rng);
      rgb = {40, 170, 50};
    }
    cloud.points.emplace_back(x, y, z);
    cloud.colors.push_back(rgb);
  }
  return cloud;
}

inline void WriteSmallWorkspace(const std::string& ws, int points_per_session = 4000) {
  using io::testing::WriteText;
  const std::vector<std::string> sessions = {"2016-06-10", "2016-06-24"};
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    io::WritePly(ws + "/dense/" + sessions[s] + ".ply",
                 FieldCloud(points_per_session, 0.1 + 0.3 * double(s), 11 + s));
    std::vector<io::StampedPose> poses;
    for (int i = 0; i < 20; ++i)
      poses.push_back(
          {1465570348000000000LL + i * 100000000LL,
           geometry::Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1.0, 0.5 * i, 1.2))});
    io::WriteTum(ws + "/fused/" + sessions[s] + "/poses.tum", poses);
  }
  WriteText(ws + "/analysis/site_plants.csv",
            "site_id,plant,x_m,y_m,session,date,top_m\n"
            "s1,1,0.9,2.0,2016-06-10,2016-06-10,0.1\ns1,2,1.1,2.2,2016-06-10,2016-06-10,0.1\n"
            "s2,1,1.0,6.0,2016-06-10,2016-06-10,0.1\n");
  WriteText(ws + "/analysis/site_heights.csv",
            "site_id,session,date,height_m,cover,volume_m3,n_points\n"
            "s1,2016-06-10,2016-06-10,0.1000,0.300,0.00100,40\n"
            "s1,2016-06-24,2016-06-24,0.4000,0.600,0.00900,90\n"
            "s2,2016-06-10,2016-06-10,0.0900,0.200,0.00080,30\n"
            "s2,2016-06-24,2016-06-24,0.3800,0.500,0.00800,80\n");
  WriteText(ws + "/analysis/growth.csv",
            "site_id,status,asymptote_m,rate_per_day,midpoint_date,max_growth_m_per_day,rmse_m,n\n"
            "s1,fitted,0.5500,0.06000,2016-06-20,0.00825,0.0100,2\n"
            "s2,too_few_points,,,,,,1\n");
  WriteText(ws + "/report.html", "<!doctype html><title>report</title>\n");
}

}  // namespace crop4d::viewer::testing
