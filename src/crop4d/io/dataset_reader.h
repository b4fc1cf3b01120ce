#pragma once

// Reading a field folder in the crop4d dataset format (DESIGN.md §4, docs/format.md).
//
//   Field field("my_field");                          // field.yaml + the session list
//   for (const std::string& id : field.session_ids()) {
//     Session session = field.OpenSession(id);        // session.yaml + every sensor.yaml
//     session.ForEachImuSample("imu0", [](const ImuSample& s) { ... });   // streamed
//     std::vector<GpsSample> gps = session.ReadGps("gps0");
//     std::vector<ImageEntry> images = session.ReadImageList("cam0");   // names, not pixels
//   }
//
// Images are decoded one at a time by ImageSequence (image_sequence.h).
//
// Error policy (see diagnostics.h): every function takes an optional Diagnostics*. Without one,
// a problem in metadata (field.yaml, session.yaml, sensor.yaml) throws InputError naming the
// file, the line and the key, and a bad data line or image is skipped with a logged warning.
// With one, every problem is reported into it and reading carries on with what could be read
// (a sensor whose sensor.yaml is broken is left out of the session).

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/geometry/enu.h"
#include "crop4d/io/dataset.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/diagnostics.h"
#include "crop4d/io/sensor_csv.h"

namespace crop4d::io {

// ---- metadata files --------------------------------------------------------------------------

// field.yaml. Sites given as lat/lon are converted to the field's ENU frame.
FieldInfo ReadFieldYaml(const std::string& path, Diagnostics* diag = nullptr);

// session.yaml (at `path`) of session `id`. The date comes from the `date` key or, when there
// is none, from an id that starts with YYYY-MM-DD; session.yaml is optional for such an id.
SessionInfo ReadSessionYaml(const std::string& path, const std::string& id,
                            Diagnostics* diag = nullptr);

// sensor.yaml files (EuRoC/Kalibr keys). The sensor's name is its folder's name.
CameraSensor ReadCameraSensorYaml(const std::string& path, Diagnostics* diag = nullptr);
ImuSensor ReadImuSensorYaml(const std::string& path, Diagnostics* diag = nullptr);
MagSensor ReadMagSensorYaml(const std::string& path, Diagnostics* diag = nullptr);
GpsSensor ReadGpsSensorYaml(const std::string& path, Diagnostics* diag = nullptr);

// A sensor folder of a session: "cam0", "imu0", "mag0", "gps0", "gps1", ...
struct SensorFolder {
  std::string name;
  SensorKind kind = SensorKind::kCamera;
};

// The sensor folders in `session_folder`, sorted by name. Other folders are reported as
// warnings (and ignored).
std::vector<SensorFolder> ListSensorFolders(const std::string& session_folder,
                                            Diagnostics* diag = nullptr);

// The date at the start of a session id ("2016-05-25", "2016-05-25_pm"), if any.
std::optional<Timestamp> DateFromSessionId(const std::string& id);

// ---- Session ---------------------------------------------------------------------------------

class Session {
 public:
  // Reads session.yaml and the sensor.yaml of every sensor folder of `folder`; the id is the
  // folder's name. Data files are only read by the ForEach/Read functions.
  explicit Session(std::string folder, Diagnostics* diag = nullptr);

  const std::string& folder() const { return folder_; }
  const std::string& id() const { return info_.id; }
  const SessionInfo& info() const { return info_; }

  const std::vector<CameraSensor>& cameras() const { return cameras_; }
  const std::vector<ImuSensor>& imus() const { return imus_; }
  const std::vector<MagSensor>& mags() const { return mags_; }
  const std::vector<GpsSensor>& gps_receivers() const { return gps_; }

  // A sensor by name, or nullptr when the session has none of that name.
  const CameraSensor* FindCamera(const std::string& name) const;
  const ImuSensor* FindImu(const std::string& name) const;
  const MagSensor* FindMag(const std::string& name) const;
  const GpsSensor* FindGps(const std::string& name) const;

  // <folder>/<sensor>/data.csv and <folder>/<camera>/data/<filename>.
  std::string DataCsvPath(const std::string& sensor) const;
  std::string ImagePath(const std::string& camera, const std::string& filename) const;

  // Stream a sensor's samples in time order (strictly increasing timestamps; bad lines
  // skipped, see sensor_csv.h). Throws InputError when the session has no such sensor or its
  // data.csv cannot be opened.
  DataFileStats ForEachImageEntry(const std::string& camera,
                                  const std::function<void(const ImageEntry&)>& callback,
                                  Diagnostics* diag = nullptr) const;
  DataFileStats ForEachImuSample(const std::string& imu,
                                 const std::function<void(const ImuSample&)>& callback,
                                 Diagnostics* diag = nullptr) const;
  DataFileStats ForEachMagSample(const std::string& mag,
                                 const std::function<void(const MagSample&)>& callback,
                                 Diagnostics* diag = nullptr) const;
  // GPS samples with sigma 0 (missing) get the receiver's default sigmas.
  DataFileStats ForEachGpsSample(const std::string& gps,
                                 const std::function<void(const GpsSample&)>& callback,
                                 Diagnostics* diag = nullptr) const;

  // The same, collected into a vector.
  std::vector<ImageEntry> ReadImageList(const std::string& camera = "cam0",
                                        Diagnostics* diag = nullptr) const;
  std::vector<ImuSample> ReadImu(const std::string& imu = "imu0",
                                 Diagnostics* diag = nullptr) const;
  std::vector<MagSample> ReadMag(const std::string& mag = "mag0",
                                 Diagnostics* diag = nullptr) const;
  std::vector<GpsSample> ReadGps(const std::string& gps = "gps0",
                                 Diagnostics* diag = nullptr) const;

 private:
  std::string folder_;
  SessionInfo info_;
  std::vector<CameraSensor> cameras_;
  std::vector<ImuSensor> imus_;
  std::vector<MagSensor> mags_;
  std::vector<GpsSensor> gps_;
};

// ---- Field -----------------------------------------------------------------------------------

class Field {
 public:
  // Reads <folder>/field.yaml and lists the sessions under <folder>/sessions/.
  explicit Field(std::string folder, Diagnostics* diag = nullptr);

  const std::string& folder() const { return folder_; }
  const FieldInfo& info() const { return info_; }
  // Session ids in time order: field.yaml's `sessions` when given (folders not listed there
  // are ignored with a warning), otherwise the folders of sessions/ sorted by name.
  const std::vector<std::string>& session_ids() const { return session_ids_; }
  std::string SessionFolder(const std::string& id) const;
  Session OpenSession(const std::string& id, Diagnostics* diag = nullptr) const;
  // The field's local ENU frame (the world frame W).
  geometry::LocalEnu Enu() const { return geometry::LocalEnu(info_.origin); }

 private:
  std::string folder_;
  FieldInfo info_;
  std::vector<std::string> session_ids_;
};

}  // namespace crop4d::io
