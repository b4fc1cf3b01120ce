#include "crop4d/io/image_probe.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <system_error>

namespace crop4d::io {
namespace {

std::uint32_t BigEndian32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

// Walks the JPEG markers up to the first start-of-frame segment, which holds the size.
bool JpegSize(std::ifstream& in, int* width, int* height) {
  in.clear();
  in.seekg(2);
  for (int segments = 0; segments < 1000; ++segments) {
    unsigned char marker[4];
    if (!in.read(reinterpret_cast<char*>(marker), 2)) return false;
    if (marker[0] != 0xFF) return false;
    while (marker[1] == 0xFF) {  // fill bytes
      if (!in.read(reinterpret_cast<char*>(&marker[1]), 1)) return false;
    }
    const unsigned char type = marker[1];
    if (type == 0xD8 || type == 0x01 || (type >= 0xD0 && type <= 0xD7)) continue;  // no length
    if (!in.read(reinterpret_cast<char*>(marker + 2), 2)) return false;
    const int length = (marker[2] << 8) | marker[3];
    if (length < 2) return false;
    const bool start_of_frame =
        type >= 0xC0 && type <= 0xCF && type != 0xC4 && type != 0xC8 && type != 0xCC;
    if (start_of_frame) {
      unsigned char sof[5];
      if (!in.read(reinterpret_cast<char*>(sof), 5)) return false;
      *height = (sof[1] << 8) | sof[2];
      *width = (sof[3] << 8) | sof[4];
      return *width > 0 && *height > 0;
    }
    in.seekg(length - 2, std::ios::cur);
    if (!in) return false;
  }
  return false;
}

// Whether the last bytes of the file hold `marker`: a PNG ends with its IEND chunk and a JPEG
// with its end-of-image marker, so a file cut short (a copy or a recording that stopped) lacks
// it. A few bytes of padding after the marker are allowed.
bool EndsWithMarker(std::ifstream& in, std::uintmax_t size, const char* marker,
                    std::size_t length) {
  constexpr std::uintmax_t kTail = 64;
  const std::uintmax_t tail = std::min(size, kTail);
  std::array<char, kTail> bytes{};
  in.clear();
  in.seekg(static_cast<std::streamoff>(size - tail));
  if (!in.read(bytes.data(), static_cast<std::streamsize>(tail))) return false;
  const char* begin = bytes.data();
  const char* end = begin + tail;
  return std::search(begin, end, marker, marker + length) != end;
}

}  // namespace

ImageProbe ProbeImage(const std::string& path, bool decode) {
  ImageProbe probe;
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    probe.problem = "missing";
    return probe;
  }
  if (!fs::is_regular_file(status)) {
    probe.problem =
        fs::is_directory(status) ? "is a folder, not an image file" : "not a regular file";
    return probe;
  }
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec || size == 0) {
    probe.problem = "empty file (0 bytes)";
    return probe;
  }
  std::ifstream in(path, std::ios::binary);
  std::array<unsigned char, 32> head{};
  if (!in) {
    probe.problem = "cannot be opened";
    return probe;
  }
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  const std::size_t n = static_cast<std::size_t>(in.gcount());
  const auto starts = [&](const char* magic, std::size_t length, std::size_t offset = 0) {
    return n >= offset + length && std::memcmp(head.data() + offset, magic, length) == 0;
  };
  if (starts("\x89PNG\r\n\x1a\n", 8)) {
    probe.format = "png";
    if (n < 24 || !starts("IHDR", 4, 12)) {
      probe.problem = "truncated PNG header";
      return probe;
    }
    probe.width = static_cast<int>(BigEndian32(head.data() + 16));
    probe.height = static_cast<int>(BigEndian32(head.data() + 20));
    if (probe.width <= 0 || probe.height <= 0) {
      probe.problem = "PNG header with an invalid size";
      return probe;
    }
    if (!EndsWithMarker(in, size, "IEND", 4)) {
      probe.problem = "truncated PNG (no IEND chunk at the end)";
      return probe;
    }
  } else if (starts("\xFF\xD8\xFF", 3)) {
    probe.format = "jpeg";
    if (!JpegSize(in, &probe.width, &probe.height)) {
      probe.problem = "JPEG without a readable frame header (truncated?)";
      return probe;
    }
    if (!EndsWithMarker(in, size, "\xFF\xD9", 2)) {
      probe.problem = "truncated JPEG (no end-of-image marker at the end)";
      return probe;
    }
  } else if (starts("II*\0", 4) || starts("MM\0*", 4)) {
    probe.format = "tiff";
  } else if (starts("BM", 2)) {
    probe.format = "bmp";
  } else if (n >= 2 && head[0] == 'P' && head[1] >= '1' && head[1] <= '6') {
    probe.format = "pnm";
  } else if (starts("RIFF", 4) && starts("WEBP", 4, 8)) {
    probe.format = "webp";
  } else {
    probe.problem = "not an image (unknown file signature)";
    return probe;
  }
  in.close();
  if (!cv::haveImageReader(path)) {
    probe.problem = "OpenCV has no decoder for this " + probe.format + " file";
    return probe;
  }
  if (decode) {
    const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (image.empty()) {
      probe.problem = "cannot be decoded (truncated or corrupt " + probe.format + ")";
      return probe;
    }
    probe.width = image.cols;
    probe.height = image.rows;
  }
  probe.ok = true;
  return probe;
}

}  // namespace crop4d::io
