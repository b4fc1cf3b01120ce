#include "crop4d/viewer/octree.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <unordered_set>

#include "crop4d/core/error.h"

namespace crop4d::viewer {
namespace {

constexpr char kMagic[4] = {'C', '4', 'D', 'T'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 48;

template <typename T>
void Put(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <typename T>
T Get(const std::string& bytes, std::size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}

}  // namespace

OptionCheck OctreeOptions::Check() const {
  OptionChecker c;
  c.AtLeast("max_points_per_node", max_points_per_node, 1)
      .InRange("grid_cells", grid_cells, 2, 1024)
      .InRange("max_depth", max_depth, 0, 20);
  return c.Result();
}

Octree BuildOctree(const std::vector<Eigen::Vector3d>& points, const OctreeOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "BuildOctree");
  Octree tree;
  if (points.empty()) return tree;
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : points) {
    CROP4D_CHECK(p.allFinite());
    box.extend(p);
  }
  OctreeNode root;
  root.name = "r";
  root.min = box.min();
  root.side = box.sizes().maxCoeff() + 1e-3;
  root.points.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) root.points[i] = std::uint32_t(i);

  // Breadth-first: a node is split when it holds too many points; its subsample stays, the
  // rest goes to the children, which are appended after it.
  tree.nodes.push_back(std::move(root));
  const std::int64_t g = options.grid_cells;
  std::unordered_set<std::int64_t> occupied;
  for (std::size_t n = 0; n < tree.nodes.size(); ++n) {
    if (tree.nodes[n].points.size() <= std::size_t(options.max_points_per_node) ||
        tree.nodes[n].depth >= options.max_depth) {
      continue;
    }
    const Eigen::Vector3d min = tree.nodes[n].min;
    const double side = tree.nodes[n].side;
    const Eigen::Vector3d centre = min + Eigen::Vector3d::Constant(side / 2);
    std::vector<std::uint32_t> kept;
    std::array<std::vector<std::uint32_t>, 8> children;
    occupied.clear();
    const auto cell = [&](double v, double lo) {
      return std::clamp<std::int64_t>(std::int64_t(std::floor((v - lo) / side * double(g))), 0,
                                      g - 1);
    };
    for (std::uint32_t i : tree.nodes[n].points) {
      const Eigen::Vector3d& p = points[i];
      const std::int64_t key =
          (cell(p.x(), min.x()) * g + cell(p.y(), min.y())) * g + cell(p.z(), min.z());
      if (occupied.insert(key).second) {
        kept.push_back(i);
        continue;
      }
      const int child = (p.x() >= centre.x() ? 1 : 0) | (p.y() >= centre.y() ? 2 : 0) |
                        (p.z() >= centre.z() ? 4 : 0);
      children[child].push_back(i);
    }
    tree.nodes[n].points = std::move(kept);
    for (int c = 0; c < 8; ++c) {
      if (children[c].empty()) continue;
      OctreeNode child;
      child.name = tree.nodes[n].name + char('0' + c);
      child.depth = tree.nodes[n].depth + 1;
      child.side = side / 2;
      child.min = min + Eigen::Vector3d((c & 1) ? side / 2 : 0, (c & 2) ? side / 2 : 0,
                                        (c & 4) ? side / 2 : 0);
      child.points = std::move(children[c]);
      tree.nodes[n].child_mask |= std::uint8_t(1u << c);
      tree.nodes.push_back(std::move(child));  // may reallocate: no references held across
    }
  }
  return tree;
}

Eigen::Vector3d Tile::Position(std::size_t i) const {
  const auto& q = positions[i];
  return min + Eigen::Vector3d(q[0], q[1], q[2]) * (side / 65535.0);
}

std::string EncodeTile(const OctreeNode& node, const std::vector<Eigen::Vector3d>& points,
                       const std::vector<std::array<std::uint8_t, 3>>& colors) {
  std::string out;
  const std::size_t n = node.points.size();
  out.reserve(kHeaderBytes + 9 * n);
  out.append(kMagic, 4);
  Put(&out, kVersion);
  Put(&out, std::uint32_t(n));
  Put(&out, std::uint32_t(0));
  for (int k = 0; k < 3; ++k) Put(&out, node.min[k]);
  Put(&out, node.side);
  for (std::uint32_t i : node.points) {
    const Eigen::Vector3d u = (points[i] - node.min) / node.side;
    for (int k = 0; k < 3; ++k) {
      CROP4D_CHECK(u[k] >= -1e-9 && u[k] <= 1.0 + 1e-9);
      Put(&out, std::uint16_t(std::lround(std::clamp(u[k], 0.0, 1.0) * 65535.0)));
    }
  }
  for (std::uint32_t i : node.points) {
    const std::array<std::uint8_t, 3> rgb =
        colors.empty() ? std::array<std::uint8_t, 3>{160, 160, 160} : colors[i];
    out.append(reinterpret_cast<const char*>(rgb.data()), 3);
  }
  return out;
}

Tile DecodeTile(const std::string& bytes, const std::string& name) {
  if (bytes.size() < kHeaderBytes || std::memcmp(bytes.data(), kMagic, 4) != 0)
    throw InputError(name, 0, "not a crop4d viewer tile (no C4DT header)");
  if (Get<std::uint32_t>(bytes, 4) != kVersion)
    throw InputError(
        name, 0,
        "tile format version " + std::to_string(Get<std::uint32_t>(bytes, 4)) + ", expected 1");
  const std::size_t n = Get<std::uint32_t>(bytes, 8);
  if (bytes.size() != kHeaderBytes + 9 * n)
    throw InputError(name, 0,
                     "tile of " + std::to_string(n) + " points has " +
                         std::to_string(bytes.size()) + " bytes, expected " +
                         std::to_string(kHeaderBytes + 9 * n));
  Tile tile;
  for (int k = 0; k < 3; ++k) tile.min[k] = Get<double>(bytes, 16 + 8 * k);
  tile.side = Get<double>(bytes, 40);
  if (!tile.min.allFinite() || !std::isfinite(tile.side) || tile.side <= 0)
    throw InputError(name, 0, "tile cube is not finite or has no size");
  tile.positions.resize(n);
  tile.colors.resize(n);
  if (n > 0) {
    std::memcpy(tile.positions.data(), bytes.data() + kHeaderBytes, 6 * n);
    std::memcpy(tile.colors.data(), bytes.data() + kHeaderBytes + 6 * n, 3 * n);
  }
  return tile;
}

}  // namespace crop4d::viewer
