// Did a change cost canopy accuracy? (bench/RESULTS.md, "Is a canopy difference real?"). Two or
// more workspaces of the same field — the same recordings run two ways — are compared on the
// canopy heights of their sites: each run's RMSE with its 95 % interval over the sites, and each
// run's RMSE against the first run's as a ratio with its paired interval (the same sites drawn
// for both: eval/site_bootstrap.h). A ratio whose interval holds 1 is a difference this field
// cannot tell from the choice of sites. With --dense, the dense clouds' plant tops at the true
// stems too (eval/dense_eval.h): every plant of every session rather than a dozen sites.
// Several fields, separated by "--", are pooled at the end: their sites drawn together, each run
// against the first run of its field (the k-th run of every field is one way of running).
//
//   build/release/bench/canopy_paired [--dense] FIELD WS_A WS_B [WS ...] [-- FIELD WS_A WS_B ...]

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include "crop4d/eval/canopy_eval.h"
#include "crop4d/eval/dense_eval.h"
#include "crop4d/eval/site_bootstrap.h"
#include "crop4d/workspace/layout.h"

namespace {

using namespace crop4d;

std::string Cm(double m) { return std::isfinite(m) ? fmt::format("{:.2f}", 100.0 * m) : "-"; }

std::string Ratio(double r) { return std::isfinite(r) ? fmt::format("{:.3f}", r) : "-"; }

struct Run {
  std::string workspace;
  eval::CanopyMethodEval canopy;
  eval::PlantTopStats dense_tops;  // pooled over the sessions (with --dense)
};

Run Evaluate(const std::string& field, const std::string& workspace, bool dense) {
  Run run;
  run.workspace = workspace;
  const workspace::Layout ws(workspace);
  run.canopy =
      eval::EvaluateCanopyHeights(eval::ReadSiteHeights(ws.SiteHeights()),
                                  eval::ReadSiteTruth(field + "/ground_truth/site_truth.csv"));
  if (dense) {
    const eval::DenseEval d =
        eval::EvaluateDenseClouds(workspace, field, eval::FindDenseClouds(workspace, {}, {}));
    if (!d.error.empty()) throw std::runtime_error(workspace + ": " + d.error);
    run.dense_tops = d.tops;
  }
  return run;
}

// One field's runs (the first is the reference).
struct FieldRuns {
  std::string field;
  std::vector<std::string> workspaces;
};

// The errors of `run`, site ids prefixed with the field's index: sites of different fields are
// different sites when pooled.
std::vector<eval::SiteError> PooledErrors(const Run& run, std::size_t field_index) {
  std::vector<eval::SiteError> errors = eval::SiteErrors(run.canopy.pairs);
  for (eval::SiteError& e : errors) e.site_id = fmt::format("{}/{}", field_index, e.site_id);
  return errors;
}

std::string PairedCells(const std::vector<eval::SiteError>& first,
                        const std::vector<eval::SiteError>& other) {
  const eval::RmseRatio r = eval::PairedRmseRatio(first, other);
  const std::string interval =
      r.interval.valid() ? fmt::format("{}–{}", Ratio(r.interval.low), Ratio(r.interval.high))
                         : "-";
  return fmt::format("{} | {}", Ratio(r.ratio), interval);
}

void PrintField(std::size_t index, const FieldRuns& f, const std::vector<Run>& runs, bool dense) {
  fmt::print("field {}: {}\n\n", index, f.field);
  fmt::print(
      "| run | site/dates | canopy RMSE cm | 95 % interval over the sites | > 4 cm | "
      "RMSE / first run's | paired 95 % interval |{}\n",
      dense ? " dense plant tops: plants, RMSE cm |" : "");
  fmt::print("|---|---|---|---|---|---|---|{}\n", dense ? "---|" : "");
  const std::vector<eval::SiteError> first = eval::SiteErrors(runs.front().canopy.pairs);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const Run& run = runs[i];
    const eval::CanopyErrorStats& s = run.canopy.overall;
    const eval::BootstrapInterval& own = run.canopy.rmse_interval;
    const std::string paired =
        i == 0 ? "(first) | " : PairedCells(first, eval::SiteErrors(run.canopy.pairs));
    fmt::print(
        "| {} | {}/{} | {} | {}–{} | {} | {} |{}\n", run.workspace, s.num_pairs, s.num_truth,
        Cm(s.rmse_m), Cm(own.low), Cm(own.high), s.num_failures, paired,
        dense ? fmt::format(" {}, {} |", run.dense_tops.num_found, Cm(run.dense_tops.rmse_m)) : "");
  }
  fmt::print("\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<FieldRuns> fields(1);
  bool dense = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--dense") {
      dense = true;
    } else if (arg == "--") {
      fields.emplace_back();
    } else if (!arg.empty() && arg[0] == '-') {
      std::fprintf(stderr, "canopy_paired: unknown option %s\n", arg.c_str());
      return 2;
    } else if (fields.back().field.empty()) {
      fields.back().field = arg;
    } else {
      fields.back().workspaces.push_back(arg);
    }
  }
  for (const FieldRuns& f : fields) {
    if (f.workspaces.size() < 2) {
      std::fprintf(stderr,
                   "usage: canopy_paired [--dense] FIELD WS_A WS_B [WS ...] "
                   "[-- FIELD WS_A WS_B ...]\n");
      return 2;
    }
  }
  try {
    std::size_t min_runs = fields.front().workspaces.size();
    std::vector<std::vector<Run>> runs(fields.size());
    for (std::size_t f = 0; f < fields.size(); ++f) {
      for (const std::string& ws : fields[f].workspaces) {
        std::fprintf(stderr, "canopy_paired: %s\n", ws.c_str());
        runs[f].push_back(Evaluate(fields[f].field, ws, dense));
      }
      PrintField(f + 1, fields[f], runs[f], dense);
      min_runs = std::min(min_runs, runs[f].size());
    }
    if (fields.size() < 2) return 0;
    // Pooled: the k-th run of every field against the first of its field.
    int num_sites = 0;
    for (const auto& r : runs) num_sites += r.front().canopy.rmse_interval.num_sites;
    fmt::print("all {} fields pooled ({} sites drawn together):\n\n", fields.size(), num_sites);
    fmt::print("| run | RMSE / first run's | paired 95 % interval |\n|---|---|---|\n");
    for (std::size_t k = 1; k < min_runs; ++k) {
      std::vector<eval::SiteError> first, other;
      for (std::size_t f = 0; f < fields.size(); ++f) {
        for (eval::SiteError& e : PooledErrors(runs[f][0], f)) first.push_back(std::move(e));
        for (eval::SiteError& e : PooledErrors(runs[f][k], f)) other.push_back(std::move(e));
      }
      fmt::print("| run {} of each field | {} |\n", k + 1, PairedCells(first, other));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "canopy_paired: %s\n", e.what());
    return 1;
  }
  return 0;
}
