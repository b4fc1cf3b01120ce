// Each option struct of slam/ names the option that is wrong (core/option_check.h).

#include <gtest/gtest.h>

#include <limits>

#include "crop4d/core/option_check_test_util.h"
#include "crop4d/slam/camera_height_scale.h"
#include "crop4d/slam/gp_prior.h"
#include "crop4d/slam/imu_preintegration.h"
#include "crop4d/slam/initialisation.h"
#include "crop4d/slam/row_passes.h"
#include "crop4d/slam/session_solve.h"
#include "crop4d/slam/standstill.h"
#include "crop4d/slam/triangulation.h"
#include "crop4d/slam/visual_initialisation.h"

namespace crop4d::slam {
namespace {

using crop4d::testing::ExpectCheckNamesOption;

TEST(SlamOptions, CheckNamesTheWrongOption) {
  using T = TriangulationOptions;
  ExpectCheckNamesOption<T>(T(), {
                                     {"min_parallax_deg", [](T& o) { o.min_parallax_deg = 180; }},
                                     {"max_depth_m", [](T& o) { o.max_depth_m = o.min_depth_m; }},
                                     {"refine_iterations", [](T& o) { o.refine_iterations = -1; }},
                                 });
  using C = CameraHeightOptions;
  ExpectCheckNamesOption<C>(C(),
                            {
                                {"quantile", [](C& o) { o.quantile = -0.1; }},
                                {"max_excess_green", [](C& o) { o.max_excess_green = 1.0 / 0.0; }},
                                {"triangulation.max_reprojection_error_px",
                                 [](C& o) { o.triangulation.max_reprojection_error_px = 0; }},
                            });
  using G = GpPriorFactor::Options;
  ExpectCheckNamesOption<G>(G(), {{"qc_rotation", [](G& o) { o.qc_rotation = 0; }}});
  using I = ImuPreintegration::Options;
  ExpectCheckNamesOption<I>(
      I(), {{"gyro_random_walk", [](I& o) { o.gyro_random_walk = -1; }},
            {"covariance_regularisation", [](I& o) { o.covariance_regularisation = -1; }}});
  using S = StateInitialiser::Options;
  ExpectCheckNamesOption<S>(
      S(), {{"alignment_window_s", [](S& o) { o.alignment_window_s = o.alignment_step_s; }},
            {"gravity", [](S& o) { o.gravity = 0; }}});
  using R = RowPassSegmenter::Options;
  ExpectCheckNamesOption<R>(
      R(),
      {{"row_spacing_m", [](R& o) { o.row_spacing_m = 0; }},
       {"heading_tolerance_rad", [](R& o) { o.heading_tolerance_rad = 2; }},
       {"row_axis_rad", [](R& o) { o.row_axis_rad = std::numeric_limits<double>::infinity(); }},
       {"max_row_step", [](R& o) { o.max_row_step = 0; }}});
  using W = StandstillOptions;
  ExpectCheckNamesOption<W>(W(), {{"window_s", [](W& o) { o.window_s = 0; }},
                                  {"sigma_rotation", [](W& o) { o.sigma_rotation = 0; }}});
  using V = VisualInitialisationOptions;
  ExpectCheckNamesOption<V>(V(), {{"min_correspondences", [](V& o) { o.min_correspondences = 4; }},
                                  {"ransac_confidence", [](V& o) { o.ransac_confidence = 1; }}});
  using F = ForwardAxisOptions;
  ExpectCheckNamesOption<F>(F(), {{"min_states", [](F& o) { o.min_states = 0; }}});
  using P = SessionSolveOptions;
  ExpectCheckNamesOption<P>(
      P(), {{"initialisation.gravity", [](P& o) { o.initialisation.gravity = -1; }},
            {"forward_axis.min_speed_m_s", [](P& o) { o.forward_axis.min_speed_m_s = 0; }}});
}

}  // namespace
}  // namespace crop4d::slam
