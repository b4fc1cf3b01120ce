#pragma once

// Reading a PLY cloud a strip of the plane at a time: the points whose x (or y) lies in a range,
// from only the parts of the file that hold such points. The analysis reads each session's
// dense cloud so, a tile of the field after the other, and never holds a whole cloud.
//
// The constructor reads the file once, a slice of vertices at a time, and notes per slice the
// range of its kept points along the axis. A strip then reads the slices whose range meets it.
// crop4d's dense clouds are written in order along the longer side of their region (dense/
// cell_window.h), so strips across that side read each slice about once in all; a cloud in no
// order still gives the right points, each strip reading the whole file (read_fraction says
// how much was read).

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "crop4d/io/ply.h"

namespace crop4d::io {

// What the indexing read found: per slice of `slice` vertices the range of its kept points
// along the axis (lo > hi: none), and how many were kept.
struct PlyStripIndex {
  std::size_t slice = 0;
  std::vector<std::pair<double, double>> ranges;
  std::size_t kept = 0;
};

class PlyStripReader {
 public:
  // `keep` selects the points ever returned (e.g. those within an area); `axis` 0 reads strips
  // of x, 1 of y. `index`, when given, is the index() of a reader of the same file, axis and
  // `keep`: the file is then not read to index it (unless the index does not fit its size).
  // Throws InputError when the file cannot be read (see PlyVertexReader).
  PlyStripReader(const std::string& path, int axis,
                 std::function<bool(const Eigen::Vector3d&)> keep,
                 std::size_t slice = std::size_t{1} << 16, const PlyStripIndex* index = nullptr);
  // The index, for a later reader of the same file.
  PlyStripIndex index() const;

  // Vertices in the file, and of them those `keep` selects.
  std::size_t size() const { return reader_.size(); }
  std::size_t kept() const { return kept_; }
  // Normals, colours and scalar fields of the vertices.
  const PlyLayout& layout() const { return reader_.layout(); }
  // The kept points whose coordinate along the axis lies in [lo, hi], with their normals,
  // colours and scalar fields, in file order; their indices in the file into `indices` (when
  // not null).
  PlyPointCloud Read(double lo, double hi, std::vector<std::uint64_t>* indices = nullptr);
  // Vertices read by Read so far over the vertices in the file (the indexing read not counted).
  double read_fraction() const;

 private:
  PlyVertexReader reader_;
  int axis_;
  std::function<bool(const Eigen::Vector3d&)> keep_;
  std::size_t slice_;
  std::size_t kept_ = 0;
  std::vector<std::pair<double, double>> ranges_;  // per slice; empty (lo > hi): none kept
  std::size_t vertices_read_ = 0;
};

}  // namespace crop4d::io
