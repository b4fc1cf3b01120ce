#include "crop4d/io/image_sequence.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>

#include "crop4d/core/error.h"
#include "crop4d/io/image_probe.h"

namespace crop4d::io {

ImageSequence::ImageSequence(const Session& session, const std::string& camera, Diagnostics* diag) {
  const CameraSensor* sensor = session.FindCamera(camera);
  if (sensor == nullptr) {
    throw InputError(session.folder(), 0, "session has no camera '" + camera + "'");
  }
  camera_ = *sensor;
  folder_ = (std::filesystem::path(session.folder()) / camera / kImageFolder).string();
  data_csv_ = session.DataCsvPath(camera);
  entries_ = session.ReadImageList(camera, diag);
}

ImageSequence::ImageSequence(CameraSensor camera, const std::string& image_folder,
                             std::vector<ImageEntry> entries)
    : folder_(image_folder), camera_(std::move(camera)), entries_(std::move(entries)) {
  const std::filesystem::path camera_folder = std::filesystem::path(folder_).parent_path();
  data_csv_ = (camera_folder / kDataCsv).string();
}

std::string ImageSequence::Path(std::size_t i) const {
  return (std::filesystem::path(folder_) / entries_.at(i).filename).string();
}

cv::Mat ImageSequence::LoadImage(std::size_t i, int imread_flags, Diagnostics* diag) const {
  const ImageEntry& e = entries_.at(i);
  const std::string path = Path(i);
  // Probed first (a header and the last bytes): a missing, empty or truncated file is not handed
  // to the decoder, which would print its own error (libpng's "Read Error") on stderr.
  const ImageProbe probe = ProbeImage(path, false);
  std::string problem = probe.problem;
  cv::Mat image = probe.ok ? cv::imread(path, imread_flags) : cv::Mat();
  if (!probe.ok) {
    // problem says why: missing, empty, not an image, cut short
  } else if (image.empty()) {
    problem = "cannot be decoded (corrupt?)";
  } else if (image.cols != camera_.camera.width || image.rows != camera_.camera.height) {
    problem = fmt::format("is {}x{}, but {} has resolution {}x{}", image.cols, image.rows,
                          camera_.name, camera_.camera.width, camera_.camera.height);
    image.release();
  }
  if (!problem.empty()) {
    const std::string message = "image '" + e.filename + "' " + problem + "; skipped";
    if (diag != nullptr) {
      diag->Warning(data_csv_, e.line, message);
    } else {
      spdlog::warn("{}", FormatLocation(data_csv_, e.line, message));
    }
  }
  return image;
}

}  // namespace crop4d::io
