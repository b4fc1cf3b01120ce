#include "crop4d/io/sample_field.h"

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "crop4d/core/error.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/dataset.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_writer.h"

namespace crop4d::io {
namespace fs = std::filesystem;

void WriteSampleField(const std::string& folder, const SampleFieldOptions& options) {
  FieldInfo field;
  field.name = "sample field";
  field.origin = {33.7756, -84.3963, 290.0};
  field.rows.push_back({0, Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.0, 30.0)});
  field.rows.push_back({1, Eigen::Vector2d(0.9, 0.0), Eigen::Vector2d(0.9, 30.0)});
  field.sites.push_back({"s01", Eigen::Vector2d(0.0, 5.0), 0.5});
  field.sites.push_back({"s02", Eigen::Vector2d(0.9, 12.5), 0.4});
  field.sessions = options.sessions;
  WriteFieldYaml((fs::path(folder) / kFieldYaml).string(), field);
  const geometry::LocalEnu enu(field.origin);

  for (std::size_t k = 0; k < options.sessions.size(); ++k) {
    const std::string& id = options.sessions[k];
    const fs::path session = fs::path(folder) / kSessionsFolder / id;
    SessionInfo info;
    info.id = id;
    if (!ParseDate(id.substr(0, 10), &info.date)) {
      throw InputError(id, 0, "sample session names must be dates (YYYY-MM-DD)");
    }
    info.notes = "sunny, light wind";
    info.rain_before = k % 2 == 1;
    WriteSessionYaml((session / kSessionYaml).string(), info);
    const Timestamp t0 = info.date + SecondsToTimestamp(options.start_of_day_s);
    const auto count = [&](double rate) {
      return static_cast<int>(std::floor(options.duration_s * rate)) + 1;
    };
    const auto time = [&](int i, double rate) { return t0 + SecondsToTimestamp(i / rate); };

    // Camera: looking forward and down, 0.1 m ahead of the IMU.
    CameraSensor cam;
    cam.name = "cam0";
    cam.rate_hz = options.camera_rate_hz;
    cam.camera.width = options.image_width;
    cam.camera.height = options.image_height;
    cam.camera.fx = cam.camera.fy = 0.8 * options.image_width;
    cam.camera.cx = 0.5 * options.image_width;
    cam.camera.cy = 0.5 * options.image_height;
    cam.camera.k1 = -0.05;
    cam.camera.k2 = 0.01;
    const Eigen::Matrix3d body_from_camera_rotation =
        Eigen::AngleAxisd(-0.5 * M_PI - 0.5, Eigen::Vector3d::UnitX()).toRotationMatrix();
    cam.body_from_sensor = geometry::Rigid3(body_from_camera_rotation, {0.1, 0.0, 0.05});
    const fs::path cam_dir = session / "cam0";
    WriteCameraSensorYaml((cam_dir / kSensorYaml).string(), cam);
    std::vector<ImageEntry> images;
    fs::create_directories(cam_dir / kImageFolder);
    for (int i = 0; i < count(cam.rate_hz); ++i) {
      ImageEntry entry;
      entry.t = time(i, cam.rate_hz);
      entry.filename = std::to_string(entry.t) + ".png";
      cv::Mat image(options.image_height, options.image_width, CV_8UC3);
      for (int r = 0; r < image.rows; ++r) {
        for (int c = 0; c < image.cols; ++c) {
          image.at<cv::Vec3b>(r, c) = cv::Vec3b(static_cast<uchar>((c * 7 + i * 3) % 256),
                                                static_cast<uchar>((r * 9 + 100) % 256),
                                                static_cast<uchar>((r + c + i * 11) % 256));
        }
      }
      const std::string path = (cam_dir / kImageFolder / entry.filename).string();
      if (!cv::imwrite(path, image)) throw InputError(path, 0, "cannot write the image");
      images.push_back(entry);
    }
    WriteImageCsv((cam_dir / kDataCsv).string(), images);

    // IMU: driving north at 1 m/s, slight sway.
    ImuSensor imu;
    imu.name = "imu0";
    imu.rate_hz = options.imu_rate_hz;
    imu.gyroscope_noise_density = 1.7e-4;
    imu.gyroscope_random_walk = 1.9e-5;
    imu.accelerometer_noise_density = 2.0e-3;
    imu.accelerometer_random_walk = 3.0e-3;
    WriteImuSensorYaml((session / "imu0" / kSensorYaml).string(), imu);
    std::vector<ImuSample> imu_samples;
    for (int i = 0; i < count(imu.rate_hz); ++i) {
      const double s = i / imu.rate_hz;
      ImuSample sample;
      sample.t = time(i, imu.rate_hz);
      sample.gyro = Eigen::Vector3d(0.01 * std::sin(2.0 * s), 0.0, 0.002);
      sample.accel = Eigen::Vector3d(0.05 * std::cos(2.0 * s), 0.0, 9.80665);
      imu_samples.push_back(sample);
    }
    WriteImuCsv((session / "imu0" / kDataCsv).string(), imu_samples);

    if (options.with_mag) {
      MagSensor mag;
      mag.name = "mag0";
      mag.rate_hz = options.mag_rate_hz;
      WriteMagSensorYaml((session / "mag0" / kSensorYaml).string(), mag);
      std::vector<MagSample> mag_samples;
      for (int i = 0; i < count(mag.rate_hz); ++i) {
        MagSample sample;
        sample.t = time(i, mag.rate_hz);
        sample.field_ut = Eigen::Vector3d(22.5, 1.0 + 0.1 * (i % 3), -42.0);
        mag_samples.push_back(sample);
      }
      WriteMagCsv((session / "mag0" / kDataCsv).string(), mag_samples);
    }

    GpsSensor gps;
    gps.name = "gps0";
    gps.kind = GpsKind::kRtk;
    gps.rate_hz = options.gps_rate_hz;
    gps.antenna_in_body = Eigen::Vector3d(0.0, 0.0, 0.8);
    WriteGpsSensorYaml((session / "gps0" / kSensorYaml).string(), gps);
    std::vector<GpsSample> gps_samples;
    for (int i = 0; i < count(gps.rate_hz); ++i) {
      GpsSample sample;
      sample.t = time(i, gps.rate_hz);
      sample.position = enu.ToGeodetic(Eigen::Vector3d(0.45, 1.0 * i / gps.rate_hz, 0.8));
      sample.sigma_h = 0.02;
      sample.sigma_v = 0.04;
      sample.fix = (i % 10 == 9) ? GpsFix::kRtkFloat : GpsFix::kRtkFixed;
      gps_samples.push_back(sample);
    }
    WriteGpsCsv((session / "gps0" / kDataCsv).string(), gps_samples);
  }
}

}  // namespace crop4d::io
