#include "crop4d/io/dataset_writer.h"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/dataset_format.h"

namespace crop4d::io {
namespace {

// Shortest text that reads back to the same double ("0.1", "1e-05", "5").
std::string Num(double x) { return fmt::format("{}", x + 0.0); }  // + 0.0: no "-0"

// A YAML double-quoted scalar (a superset of JSON strings), safe for any text.
std::string Quoted(const std::string& text) {
  std::string out = "\"";
  for (const unsigned char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (c < 0x20 || c == 0x7f) {
          out += fmt::format("\\x{:02x}", c);
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

std::string TbsYaml(const geometry::Rigid3& body_from_sensor) {
  const Eigen::Matrix4d m = body_from_sensor.Matrix();
  std::string out = "# Sensor extrinsics: body_from_sensor, x_in_body = T_BS * x_in_sensor.\n";
  out += "T_BS:\n  cols: 4\n  rows: 4\n  data: [";
  for (int r = 0; r < 4; ++r) {
    if (r > 0) out += ",\n         ";
    for (int c = 0; c < 4; ++c) {
      if (c > 0) out += ", ";
      out += Num(m(r, c));
    }
  }
  return out + "]\n";
}

std::string Header(const char* sensor_type, const std::string& comment) {
  return fmt::format("# crop4d dataset format, docs/format.md\nsensor_type: {}\ncomment: {}\n\n",
                     sensor_type, Quoted(comment));
}

// Writes a CSV file from a header and a per-row formatter, in blocks.
template <typename T, typename Format>
void WriteCsv(const std::string& path, const char* header, const std::vector<T>& rows,
              Format format) {
  AtomicFile file(path);
  fmt::memory_buffer buffer;
  fmt::format_to(std::back_inserter(buffer), "{}\n", header);
  for (const T& row : rows) {
    format(buffer, row);
    if (buffer.size() > (1 << 20)) {
      file.stream().write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
      buffer.clear();
    }
  }
  file.stream().write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  file.Commit();
}

}  // namespace

void WriteFieldYaml(const std::string& path, const FieldInfo& field) {
  std::string out = "# crop4d field description, docs/format.md\n";
  out += "name: " + Quoted(field.name) + "\n";
  out += "# WGS84 origin of the local East-North-Up world frame (degrees, ellipsoidal metres).\n";
  out += fmt::format("origin: {{lat: {}, lon: {}, alt: {}}}\n", Num(field.origin.lat_deg),
                     Num(field.origin.lon_deg), Num(field.origin.alt_m));
  if (!field.rows.empty()) {
    out += "# Crop rows: start and end [east, north] in metres in the ENU frame.\nrows:\n";
    for (const RowDeclaration& row : field.rows) {
      out += fmt::format("  - {{index: {}, start: [{}, {}], end: [{}, {}]}}\n", row.index,
                         Num(row.start_enu.x()), Num(row.start_enu.y()), Num(row.end_enu.x()),
                         Num(row.end_enu.y()));
    }
  }
  if (!field.sites.empty()) {
    out += "# Measurement sites: centre (x east, y north, metres) and radius.\nsites:\n";
    for (const Site& site : field.sites) {
      out += fmt::format("  - {{id: {}, x: {}, y: {}, radius: {}}}\n", Quoted(site.id),
                         Num(site.center_enu.x()), Num(site.center_enu.y()), Num(site.radius_m));
    }
  }
  if (!field.sessions.empty()) {
    out += "# Session folders under sessions/, in time order.\nsessions:\n";
    for (const std::string& session : field.sessions) out += "  - " + Quoted(session) + "\n";
  }
  WriteFileAtomic(path, out);
}

void WriteSessionYaml(const std::string& path, const SessionInfo& session) {
  std::string out = "# crop4d session description, docs/format.md\n";
  out += "date: " + FormatDate(session.date) + "\n";
  out += "notes: " + Quoted(session.notes) + "\n";
  out += std::string("rain_before: ") + (session.rain_before ? "true" : "false") + "\n";
  WriteFileAtomic(path, out);
}

void WriteCameraSensorYaml(const std::string& path, const CameraSensor& sensor) {
  const geometry::PinholeRadTan& c = sensor.camera;
  std::string out = Header("camera", sensor.name + " (pinhole, radial-tangential)");
  out += TbsYaml(sensor.body_from_sensor);
  out +=
      fmt::format("\nrate_hz: {}\nresolution: [{}, {}]\n", Num(sensor.rate_hz), c.width, c.height);
  out += "camera_model: pinhole\n";
  out += fmt::format("intrinsics: [{}, {}, {}, {}]  # fu, fv, cu, cv\n", Num(c.fx), Num(c.fy),
                     Num(c.cx), Num(c.cy));
  out += "distortion_model: radial-tangential\n";
  out += fmt::format("distortion_coefficients: [{}, {}, {}, {}, {}]  # k1, k2, p1, p2, k3\n",
                     Num(c.k1), Num(c.k2), Num(c.p1), Num(c.p2), Num(c.k3));
  if (sensor.height_above_ground_m) {
    out += fmt::format("height_above_ground_m: {}  # optical centre above the ground\n",
                       Num(*sensor.height_above_ground_m));
  }
  WriteFileAtomic(path, out);
}

void WriteImuSensorYaml(const std::string& path, const ImuSensor& sensor) {
  std::string out = Header("imu", sensor.name);
  out += TbsYaml(sensor.body_from_sensor);
  out += fmt::format("\nrate_hz: {}\n\n", Num(sensor.rate_hz));
  out += "# Noise model (continuous time).\n";
  out += fmt::format("gyroscope_noise_density: {}  # [ rad / s / sqrt(Hz) ]\n",
                     Num(sensor.gyroscope_noise_density));
  out += fmt::format("gyroscope_random_walk: {}  # [ rad / s^2 / sqrt(Hz) ]\n",
                     Num(sensor.gyroscope_random_walk));
  out += fmt::format("accelerometer_noise_density: {}  # [ m / s^2 / sqrt(Hz) ]\n",
                     Num(sensor.accelerometer_noise_density));
  out += fmt::format("accelerometer_random_walk: {}  # [ m / s^3 / sqrt(Hz) ]\n",
                     Num(sensor.accelerometer_random_walk));
  WriteFileAtomic(path, out);
}

void WriteMagSensorYaml(const std::string& path, const MagSensor& sensor) {
  std::string out = Header("magnetometer", sensor.name);
  out += TbsYaml(sensor.body_from_sensor);
  out += fmt::format("\nrate_hz: {}\n", Num(sensor.rate_hz));
  WriteFileAtomic(path, out);
}

void WriteGpsSensorYaml(const std::string& path, const GpsSensor& sensor) {
  std::string out = Header("gps", sensor.name);
  out += fmt::format("kind: {}  # rtk | standard\n", GpsKindName(sensor.kind));
  out += fmt::format("rate_hz: {}\n", Num(sensor.rate_hz));
  out += "# Antenna phase centre in the body (IMU) frame, metres.\n";
  out += fmt::format("p_B_antenna: [{}, {}, {}]\n", Num(sensor.antenna_in_body.x()),
                     Num(sensor.antenna_in_body.y()), Num(sensor.antenna_in_body.z()));
  out += "# 1-sigma used when a sample has no sigma of its own (metres).\n";
  out += fmt::format("sigma_h: {}\nsigma_v: {}\n", Num(sensor.default_sigma_h),
                     Num(sensor.default_sigma_v));
  WriteFileAtomic(path, out);
}

void WriteImageCsv(const std::string& path, const std::vector<ImageEntry>& images) {
  WriteCsv(path, kImageCsvHeader, images, [](fmt::memory_buffer& b, const ImageEntry& e) {
    fmt::format_to(std::back_inserter(b), "{},{}\n", e.t, e.filename);
  });
}

void WriteImuCsv(const std::string& path, const std::vector<ImuSample>& samples) {
  WriteCsv(path, kImuCsvHeader, samples, [](fmt::memory_buffer& b, const ImuSample& s) {
    fmt::format_to(std::back_inserter(b), "{},{},{},{},{},{},{}\n", s.t, s.gyro.x(), s.gyro.y(),
                   s.gyro.z(), s.accel.x(), s.accel.y(), s.accel.z());
  });
}

void WriteMagCsv(const std::string& path, const std::vector<MagSample>& samples) {
  WriteCsv(path, kMagCsvHeader, samples, [](fmt::memory_buffer& b, const MagSample& s) {
    fmt::format_to(std::back_inserter(b), "{},{},{},{}\n", s.t, s.field_ut.x(), s.field_ut.y(),
                   s.field_ut.z());
  });
}

void WriteGpsCsv(const std::string& path, const std::vector<GpsSample>& samples) {
  // The velocity columns only when a sample has a velocity.
  const bool velocity = std::any_of(samples.begin(), samples.end(),
                                    [](const GpsSample& s) { return s.velocity_enu.has_value(); });
  WriteCsv(path, velocity ? kGpsCsvHeaderWithVelocity : kGpsCsvHeader, samples,
           [velocity](fmt::memory_buffer& b, const GpsSample& s) {
             fmt::format_to(std::back_inserter(b), "{},{},{},{},{},{},{}", s.t, s.position.lat_deg,
                            s.position.lon_deg, s.position.alt_m, s.sigma_h, s.sigma_v,
                            static_cast<int>(s.fix));
             if (velocity && s.velocity_enu) {
               fmt::format_to(std::back_inserter(b), ",{},{},{},{}", s.velocity_enu->x(),
                              s.velocity_enu->y(), s.velocity_enu->z(), s.sigma_velocity);
             } else if (velocity) {
               fmt::format_to(std::back_inserter(b), ",,,,");
             }
             b.push_back('\n');
           });
}

}  // namespace crop4d::io
