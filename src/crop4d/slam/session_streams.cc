#include "crop4d/slam/session_streams.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <limits>

namespace crop4d::slam {

const GpsStream* SessionStreams::FindGps(io::GpsKind kind) const {
  for (const GpsStream& stream : gps) {
    if (stream.sensor.kind == kind && !stream.fixes.empty()) return &stream;
  }
  return nullptr;
}

const GpsStream* SessionStreams::BestGps() const {
  const GpsStream* best = nullptr;
  double best_sigma = std::numeric_limits<double>::infinity();
  for (const GpsStream& stream : gps) {
    if (stream.fixes.empty()) continue;
    std::vector<double> sigmas;
    sigmas.reserve(stream.fixes.size());
    for (const GpsFixWorld& fix : stream.fixes) sigmas.push_back(fix.sigma_h);
    std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
    const double median = sigmas[sigmas.size() / 2];
    if (median < best_sigma) {
      best_sigma = median;
      best = &stream;
    }
  }
  return best;
}

SessionStreams LoadSessionStreams(const io::Field& field, const io::Session& session,
                                  const std::string& camera_name, const std::string& imu_name) {
  SessionStreams streams;
  streams.session_id = session.id();

  const io::CameraSensor* camera = nullptr;
  if (camera_name.empty()) {
    if (!session.cameras().empty()) camera = &session.cameras().front();
  } else {
    camera = session.FindCamera(camera_name);
    if (camera == nullptr) {
      spdlog::warn("session {}: no camera named {}", session.id(), camera_name);
    }
  }
  if (camera != nullptr) {
    CameraStream stream;
    stream.sensor = *camera;
    stream.images = session.ReadImageList(camera->name);
    streams.camera = std::move(stream);
  }

  const io::ImuSensor* imu = nullptr;
  if (imu_name.empty()) {
    if (!session.imus().empty()) imu = &session.imus().front();
  } else {
    imu = session.FindImu(imu_name);
    if (imu == nullptr) spdlog::warn("session {}: no IMU named {}", session.id(), imu_name);
  }
  if (imu != nullptr) {
    ImuStream stream;
    stream.sensor = *imu;
    const Eigen::Matrix3d body_from_imu = imu->body_from_sensor.RotationMatrix();
    session.ForEachImuSample(imu->name, [&](const io::ImuSample& s) {
      ImuSample sample;
      sample.timestamp = s.t;
      sample.gyro_body = body_from_imu * s.gyro;
      sample.accel_body = body_from_imu * s.accel;
      stream.samples.push_back(sample);
    });
    streams.imu = std::move(stream);
  }

  const geometry::LocalEnu enu = field.Enu();
  for (const io::GpsSensor& sensor : session.gps_receivers()) {
    GpsStream stream;
    stream.sensor = sensor;
    session.ForEachGpsSample(sensor.name, [&](const io::GpsSample& s) {
      if (s.fix == io::GpsFix::kNone) return;
      GpsFixWorld fix;
      fix.t = s.t;
      fix.position_world = enu.ToEnu(s.position);
      fix.sigma_h = s.sigma_h;
      fix.sigma_v = s.sigma_v;
      fix.fix = s.fix;
      stream.fixes.push_back(fix);
    });
    streams.gps.push_back(std::move(stream));
  }
  return streams;
}

}  // namespace crop4d::slam
