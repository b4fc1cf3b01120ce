#pragma once

// A cheap check that a file is an image OpenCV can read, without decoding it: a regular,
// non-empty file with a known image signature; PNG and JPEG headers also give the size, and a
// PNG or JPEG must end with its end marker (a file cut short does not).

#include <string>

namespace crop4d::io {

struct ImageProbe {
  bool ok = false;
  std::string problem;  // why the file is not a readable image (empty when ok)
  std::string format;   // "png", "jpeg", "tiff", "bmp", "pnm", "webp"
  int width = 0;        // from the header; 0 when unknown (formats other than PNG and JPEG)
  int height = 0;
};

// Probes `path`. With `decode`, the whole image is also decoded (cv::imread), which finds
// truncated and corrupt files, at the cost of the full decoding time.
ImageProbe ProbeImage(const std::string& path, bool decode = false);

}  // namespace crop4d::io
