#pragma once

// Union-find over nodes 0..n-1 (path halving, union by size), and its consistent variant that
// refuses a union whose two sets share a group (one 3D point is seen at most once per image:
// the group of a feature is its image). Feature tracks within a pass (features/tracks.h) and
// the landmarks across passes (fusion/cross_pass_tracks.h) are both built with them.

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <numeric>
#include <utility>
#include <vector>

namespace crop4d::features {

class UnionFind {
 public:
  explicit UnionFind(std::size_t n) : parent_(n), size_(n, 1) {
    std::iota(parent_.begin(), parent_.end(), std::size_t{0});
  }
  std::size_t Find(std::size_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  // Joins the sets of a and b; returns the new root (the root of the larger set, of a's on a
  // tie).
  std::size_t Union(std::size_t a, std::size_t b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return a;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
    return a;
  }
  std::size_t size() const { return parent_.size(); }

 private:
  std::vector<std::size_t> parent_;
  std::vector<std::size_t> size_;
};

// A union-find whose sets never hold two nodes of one group: `Union` of two sets that share a
// group is refused and changes nothing. Replaying edges best first, the weakest link of a
// conflict is the one cut.
class ConsistentUnionFind {
 public:
  // group_of[i]: the group of node i.
  explicit ConsistentUnionFind(std::vector<std::uint64_t> group_of)
      : sets_(group_of.size()), group_of_(std::move(group_of)), groups_of_root_(group_of_.size()) {}
  std::size_t Find(std::size_t x) { return sets_.Find(x); }
  // Joins the sets of a and b; false (and nothing changes) when they share a group. True when
  // a and b are already in one set.
  bool Union(std::size_t a, std::size_t b) {
    a = sets_.Find(a);
    b = sets_.Find(b);
    if (a == b) return true;
    std::vector<std::uint64_t>& ga = Groups(a);
    std::vector<std::uint64_t>& gb = Groups(b);
    if (Intersect(ga, gb)) return false;
    std::vector<std::uint64_t> merged;
    merged.reserve(ga.size() + gb.size());
    std::merge(ga.begin(), ga.end(), gb.begin(), gb.end(), std::back_inserter(merged));
    ga.clear();
    gb.clear();
    groups_of_root_[sets_.Union(a, b)] = std::move(merged);
    return true;
  }

 private:
  // Whether two sorted lists share an element.
  static bool Intersect(const std::vector<std::uint64_t>& a, const std::vector<std::uint64_t>& b) {
    auto i = a.begin();
    auto j = b.begin();
    while (i != a.end() && j != b.end()) {
      if (*i == *j) return true;
      if (*i < *j) {
        ++i;
      } else {
        ++j;
      }
    }
    return false;
  }

  // The groups of the set with this root; a lone node's list is made when first needed (most
  // nodes of a large graph are never joined).
  std::vector<std::uint64_t>& Groups(std::size_t root) {
    std::vector<std::uint64_t>& groups = groups_of_root_[root];
    if (groups.empty()) groups.push_back(group_of_[root]);
    return groups;
  }

  UnionFind sets_;
  std::vector<std::uint64_t> group_of_;
  // The sorted groups of each set, kept at its root (empty: not made yet).
  std::vector<std::vector<std::uint64_t>> groups_of_root_;
};

}  // namespace crop4d::features
