#pragma once

// Listing workspace folders in the order people expect: "row2" before "row10".

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

namespace crop4d::eval {

// "2" < "10": runs of digits compare as numbers, everything else character by character.
inline bool NaturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      na.erase(0, std::min(na.find_first_not_of('0'), na.size()));
      nb.erase(0, std::min(nb.find_first_not_of('0'), nb.size()));
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  if ((a.size() - i) != (b.size() - j)) return (a.size() - i) < (b.size() - j);
  return a < b;
}

// The sub-folder names of `dir` in natural order; empty when `dir` is not a folder.
inline std::vector<std::string> SubFolders(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return names;
  for (const std::filesystem::directory_entry& entry :
       std::filesystem::directory_iterator(dir, ec)) {
    if (entry.is_directory(ec)) names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end(), NaturalLess);
  return names;
}

// `names` ordered by their position in `order` (those in it first), the rest in natural order.
inline void SortByOrder(const std::vector<std::string>& order, std::vector<std::string>* names) {
  const auto rank = [&](const std::string& name) {
    const auto it = std::find(order.begin(), order.end(), name);
    return static_cast<std::size_t>(it - order.begin());
  };
  std::stable_sort(names->begin(), names->end(), [&](const std::string& a, const std::string& b) {
    const std::size_t ra = rank(a), rb = rank(b);
    if (ra != rb) return ra < rb;
    return NaturalLess(a, b);
  });
}

}  // namespace crop4d::eval
