// Association ceiling: how many correct keypoint pairs the image pairs of `crop4d associate` hold
// at all, against the correct matches that the robust and the naive methods found in them
// (bench/RESULTS.md, "Association and 4D fusion"). Every method that matches the images'
// keypoints — both of ours — can find at most this many correct matches.
//
// The counting is `crop4d eval`'s (eval/association_ceiling.h: true points, 2 cm, 5 m, image b
// shifted 10 cm for the chance pairs); this program runs only the association part of the
// evaluation and prints it as a Markdown table for RESULTS.
//
// Usage: association_ceiling WS FIELD [DEPTH_CACHE] [--by-session]
//   DEPTH_CACHE   as `crop4d eval --depth-cache`
//   --by-session  one table per session, of its pairs of rows (the cross-session pairs need two
//                 sessions and are left out): the crop grows over a season, and with it what
//                 either method can match across rows

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "crop4d/eval/workspace_eval.h"
#include "crop4d/workspace/layout.h"

using namespace crop4d;

namespace {

// Evaluates the associations of `sessions` (all when empty) and prints their table; false when
// nothing could be evaluated.
bool PrintTable(const std::string& ws, const std::string& field, const std::string& depth_cache,
                const std::vector<std::string>& sessions) {
  eval::WorkspaceEvalOptions options;
  options.depth_cache_dir = depth_cache;
  options.sessions = sessions;
  options.fused = options.canopy = options.dense = false;
  const eval::WorkspaceEval result = eval::EvaluateWorkspace(ws, field, options);
  if (!result.association) {
    std::fprintf(stderr, "%s: no association files\n", ws.c_str());
    return false;
  }
  const eval::WorkspaceAssociationEval& a = *result.association;
  if (!a.error.empty()) {
    std::fprintf(stderr, "association files not evaluated: %s\n", a.error.c_str());
    return false;
  }
  for (const std::string& error : a.ceiling.errors) {
    std::fprintf(stderr, "ceiling not counted for %s\n", error.c_str());
  }

  std::printf(
      "| pair type | image pairs | keypoints with a partner within 2 cm (within 5 m) | by chance "
      "within 5 m | naive correct (within 5 m) | robust correct (within 5 m) | naive, robust "
      "share of the ceiling within 5 m | robust ÷ naive within 5 m |\n"
      "|---|---|---|---|---|---|---|---|\n");
  for (const eval::CeilingGroup& g : a.ceiling.groups) {
    const eval::CeilingCounts& c = g.counts;
    const eval::MatchCounts naive = a.eval.GroupCounts(g.type, "naive");
    const eval::MatchCounts robust = a.eval.GroupCounts(g.type, "robust");
    const auto share = [&](const eval::MatchCounts& m) {
      return c.partners_near > 0 ? 100.0 * static_cast<double>(m.correct_near) /
                                       static_cast<double>(c.partners_near)
                                 : 0.0;
    };
    char ratio[32] = "–";
    if (naive.correct_near > 0) {
      std::snprintf(
          ratio, sizeof ratio, "%.2f×",
          static_cast<double>(robust.correct_near) / static_cast<double>(naive.correct_near));
    }
    std::printf(
        "| %s | %lld | %lld (%lld) | %lld | %lld (%lld) | %lld (%lld) | %.1f %%, %.1f %% | %s |\n",
        eval::PairTypeName(g.type), static_cast<long long>(c.image_pairs),
        static_cast<long long>(c.partners), static_cast<long long>(c.partners_near),
        static_cast<long long>(c.chance_near), static_cast<long long>(naive.correct),
        static_cast<long long>(naive.correct_near), static_cast<long long>(robust.correct),
        static_cast<long long>(robust.correct_near), share(naive), share(robust), ratio);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args;
  bool by_session = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--by-session") == 0) {
      by_session = true;
    } else {
      args.emplace_back(argv[i]);
    }
  }
  if (args.size() < 2 || args.size() > 3) {
    std::fprintf(stderr, "usage: %s WS FIELD [DEPTH_CACHE] [--by-session]\n", argv[0]);
    return 2;
  }
  const std::string depth_cache = args.size() > 2 ? args[2] : "";
  if (!by_session) return PrintTable(args[0], args[1], depth_cache, {}) ? 0 : 1;

  const std::vector<std::string> sessions = workspace::Layout(args[0]).SessionFolders();
  if (sessions.empty()) {
    std::fprintf(stderr, "%s: no sessions\n", args[0].c_str());
    return 1;
  }
  bool any = false;
  for (const std::string& session : sessions) {
    std::printf("\n%s:\n\n", session.c_str());
    any = PrintTable(args[0], args[1], depth_cache, {session}) || any;
  }
  return any ? 0 : 1;
}
