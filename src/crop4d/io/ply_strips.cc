#include "crop4d/io/ply_strips.h"

#include <algorithm>
#include <limits>

#include "crop4d/core/error.h"

namespace crop4d::io {

PlyStripReader::PlyStripReader(const std::string& path, int axis,
                               std::function<bool(const Eigen::Vector3d&)> keep, std::size_t slice,
                               const PlyStripIndex* index)
    : reader_(path), axis_(axis), keep_(std::move(keep)), slice_(std::max<std::size_t>(slice, 1)) {
  CROP4D_CHECK(axis_ == 0 || axis_ == 1);
  const std::size_t num_slices = (reader_.size() + slice_ - 1) / slice_;
  if (index != nullptr && index->slice == slice_ && index->ranges.size() == num_slices) {
    ranges_ = index->ranges;
    kept_ = index->kept;
    return;
  }
  for (std::size_t start = 0; start < reader_.size(); start += slice_) {
    const PlyPointCloud part = reader_.Read(start, slice_);
    std::pair<double, double> range{std::numeric_limits<double>::infinity(),
                                    -std::numeric_limits<double>::infinity()};
    for (const Eigen::Vector3d& p : part.points) {
      if (!keep_(p)) continue;
      ++kept_;
      range.first = std::min(range.first, p[axis_]);
      range.second = std::max(range.second, p[axis_]);
    }
    ranges_.push_back(range);
  }
}

PlyPointCloud PlyStripReader::Read(double lo, double hi, std::vector<std::uint64_t>* indices) {
  PlyPointCloud out = reader_.Read(0, 0);  // no point: the scalar fields' names and types
  if (indices) indices->clear();
  for (std::size_t s = 0; s < ranges_.size(); ++s) {
    const auto& [first, last] = ranges_[s];
    if (first > last || last < lo || first > hi) continue;  // none kept, or none in the strip
    const PlyPointCloud part = reader_.Read(s * slice_, slice_);
    vertices_read_ += part.size();
    for (std::size_t i = 0; i < part.size(); ++i) {
      const Eigen::Vector3d& p = part.points[i];
      if (!(p[axis_] >= lo && p[axis_] <= hi) || !keep_(p)) continue;
      out.AppendVertex(part, i);
      if (indices) indices->push_back(s * slice_ + i);
    }
  }
  return out;
}

PlyStripIndex PlyStripReader::index() const { return {slice_, ranges_, kept_}; }

double PlyStripReader::read_fraction() const {
  return reader_.size() == 0
             ? 0.0
             : static_cast<double>(vertices_read_) / static_cast<double>(reader_.size());
}

}  // namespace crop4d::io
