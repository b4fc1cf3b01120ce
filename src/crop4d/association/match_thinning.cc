#include "crop4d/association/match_thinning.h"

#include <algorithm>
#include <map>

#include "crop4d/core/error.h"

namespace crop4d::association {

std::vector<CrossMatch> ThinCrossMatches(const std::vector<CrossMatch>& all, int width, int height,
                                         int max_per_pair) {
  if (max_per_pair <= 0) return all;
  CROP4D_CHECK_MSG(width > 0 && height > 0, "ThinCrossMatches: an image without pixels");
  std::map<std::pair<int, int>, std::vector<const CrossMatch*>> groups;
  for (const CrossMatch& m : all) groups[{m.image_a, m.image_b}].push_back(&m);
  std::vector<CrossMatch> kept;
  constexpr int kCells = kThinningGridCells;
  for (auto& [key, group] : groups) {
    if (static_cast<int>(group.size()) <= max_per_pair) {
      for (const CrossMatch* m : group) kept.push_back(*m);
      continue;
    }
    std::vector<std::vector<const CrossMatch*>> cells(kCells * kCells);
    for (const CrossMatch* m : group) {
      const int cx = std::clamp(static_cast<int>(m->xa * kCells / width), 0, kCells - 1);
      const int cy = std::clamp(static_cast<int>(m->ya * kCells / height), 0, kCells - 1);
      cells[cy * kCells + cx].push_back(m);
    }
    for (auto& cell : cells) {
      std::stable_sort(cell.begin(), cell.end(),
                       [](const auto* a, const auto* b) { return a->distance < b->distance; });
    }
    int taken = 0;
    for (std::size_t round = 0; taken < max_per_pair; ++round) {
      bool any = false;
      for (auto& cell : cells) {
        if (round >= cell.size() || taken >= max_per_pair) continue;
        kept.push_back(*cell[round]);
        ++taken;
        any = true;
      }
      if (!any) break;
    }
  }
  return kept;
}

}  // namespace crop4d::association
