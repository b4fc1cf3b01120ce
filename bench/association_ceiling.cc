// Association ceiling: how many correct keypoint pairs the image pairs of `crop4d associate` hold
// at all, against the correct matches that the robust and the naive methods found in them
// (bench/RESULTS.md, "Association and 4D fusion"). Every method that matches the images'
// keypoints — both of ours — can find at most this many correct matches.
//
// The counting is `crop4d eval`'s (eval/association_ceiling.h: true points, 2 cm, 5 m, image b
// shifted 10 cm for the chance pairs); this program runs only the association part of the
// evaluation and prints it as a Markdown table for RESULTS.
//
// Usage: association_ceiling WS FIELD [DEPTH_CACHE]   (DEPTH_CACHE as `crop4d eval --depth-cache`)

#include <cstdio>
#include <string>

#include "crop4d/eval/workspace_eval.h"

using namespace crop4d;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s WS FIELD [DEPTH_CACHE]\n", argv[0]);
    return 2;
  }
  eval::WorkspaceEvalOptions options;
  if (argc > 3) options.depth_cache_dir = argv[3];
  options.fused = options.canopy = options.dense = false;
  const eval::WorkspaceEval result = eval::EvaluateWorkspace(argv[1], argv[2], options);
  if (!result.association) {
    std::fprintf(stderr, "%s: no association files\n", argv[1]);
    return 1;
  }
  const eval::WorkspaceAssociationEval& a = *result.association;
  if (!a.error.empty()) {
    std::fprintf(stderr, "association files not evaluated: %s\n", a.error.c_str());
    return 1;
  }
  for (const std::string& error : a.ceiling.errors) {
    std::fprintf(stderr, "ceiling not counted for %s\n", error.c_str());
  }

  std::printf(
      "| pair type | image pairs | keypoints with a partner within 2 cm (within 5 m) | by chance "
      "within 5 m | naive correct (within 5 m) | robust correct (within 5 m) | naive, robust "
      "share of the ceiling within 5 m |\n|---|---|---|---|---|---|---|\n");
  for (const eval::CeilingGroup& g : a.ceiling.groups) {
    const eval::CeilingCounts& c = g.counts;
    const auto share = [&](const char* method) {
      return c.partners_near > 0
                 ? 100.0 * static_cast<double>(a.eval.GroupCounts(g.type, method).correct_near) /
                       static_cast<double>(c.partners_near)
                 : 0.0;
    };
    std::printf(
        "| %s | %lld | %lld (%lld) | %lld | %lld (%lld) | %lld (%lld) | %.1f %%, %.1f %% |\n",
        eval::PairTypeName(g.type), static_cast<long long>(c.image_pairs),
        static_cast<long long>(c.partners), static_cast<long long>(c.partners_near),
        static_cast<long long>(c.chance_near),
        static_cast<long long>(a.eval.GroupCounts(g.type, "naive").correct),
        static_cast<long long>(a.eval.GroupCounts(g.type, "naive").correct_near),
        static_cast<long long>(a.eval.GroupCounts(g.type, "robust").correct),
        static_cast<long long>(a.eval.GroupCounts(g.type, "robust").correct_near), share("naive"),
        share("robust"));
  }
  return 0;
}
