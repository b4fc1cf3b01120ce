#pragma once

// The images of one camera of a session, decoded one at a time on demand: the list
// (cam0/data.csv) is in memory, the pixels never all at once.
//
//   ImageSequence images(session, "cam0");
//   for (std::size_t i = 0; i < images.size(); ++i) {
//     cv::Mat bgr = images.LoadImage(i);
//     if (bgr.empty()) continue;   // unreadable: already reported
//     ...
//   }

#include <opencv2/core/mat.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "crop4d/io/dataset_reader.h"

namespace crop4d::io {

class ImageSequence {
 public:
  // Reads the image list of `camera` (throws InputError when the session has no such camera
  // or its data.csv cannot be opened; bad lines are skipped and reported, see sensor_csv.h).
  ImageSequence(const Session& session, const std::string& camera = "cam0",
                Diagnostics* diag = nullptr);
  // A list read before (a row pass's copy of data.csv's lines in the workspace): `image_folder`
  // is the camera's <session>/<camera>/data folder; messages name its data.csv and the entries'
  // lines.
  ImageSequence(CameraSensor camera, const std::string& image_folder,
                std::vector<ImageEntry> entries);

  std::size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }
  const CameraSensor& camera() const { return camera_; }
  const std::vector<ImageEntry>& entries() const { return entries_; }
  const ImageEntry& entry(std::size_t i) const { return entries_.at(i); }
  Timestamp time(std::size_t i) const { return entries_.at(i).t; }
  std::string Path(std::size_t i) const;
  const std::string& folder() const { return folder_; }

  // Decodes image i (`imread_flags` as cv::imread; colour BGR by default). Returns an empty
  // Mat when the file is missing, unreadable or not of the camera's resolution; the problem
  // is reported to `diag` (nullptr: logged as a warning) with data.csv's line. Thread-safe.
  cv::Mat LoadImage(std::size_t i, int imread_flags = cv::IMREAD_COLOR,
                    Diagnostics* diag = nullptr) const;

 private:
  std::string folder_;    // <session>/<camera>/data
  std::string data_csv_;  // for messages
  CameraSensor camera_;
  std::vector<ImageEntry> entries_;
};

}  // namespace crop4d::io
