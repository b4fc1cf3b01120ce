// crop4d: the command-line interface. Subcommands are one table; each has its own file.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/allocator.h"
#include "crop4d/core/build_info.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/core/progress.h"

namespace {

using crop4d::cli::Command;

constexpr Command kCommands[] = {
    {"run",
     "The whole season in one command: validate, slam, associate, fuse, densify, analyze, eval, "
     "report (resumable)",
     crop4d::cli::SetupRun},
    {"status",
     "Where a workspace's run stands: the stages, and a cluster run's units queued, running, "
     "done and failed",
     crop4d::cli::SetupStatus},
    {"task", "One step of a cluster run, as its Slurm jobs run it (docs/cluster.md)",
     crop4d::cli::SetupTask},
    {"validate", "Check a field folder: every session, sensor, file and line",
     crop4d::cli::SetupValidate},
    {"simulate", "Make a synthetic field: rendered images, IMU, GPS and ground truth",
     crop4d::cli::SetupSimulate},
    {"import", "Make a session from an RTKLIB .pos file and an IMU text file (real recordings)",
     crop4d::cli::SetupImport},
    {"slam", "Multi-sensor SLAM of every row pass: poses, sparse cloud, summary",
     crop4d::cli::SetupSlam},
    {"associate", "Match row passes with their neighbours in space and time (cross matches)",
     crop4d::cli::SetupAssociate},
    {"fuse", "Joint 4D optimisation of every pass of every session with the cross matches",
     crop4d::cli::SetupFuse},
    {"densify", "Dense point cloud per session: soil and plant tops by height-field stereo",
     crop4d::cli::SetupDensify},
    {"analyze", "Canopy height per site and date, cover, growth, terrain and canopy rasters",
     crop4d::cli::SetupAnalyze},
    {"eval",
     "Compare a workspace (trajectories, cross matches, fusion) with a synthetic field's truth",
     crop4d::cli::SetupEval},
    {"section", "Draw the cross-section figure: a slice across a row, points coloured by date",
     crop4d::cli::SetupSection},
    {"export", "Export a workspace: PLY, LAS, COLMAP text, TUM trajectories, GeoTIFF and CSV",
     crop4d::cli::SetupExport},
    {"report", "Write WS/report.html: one self-contained page with the season's results",
     crop4d::cli::SetupReport},
    {"view", "Show the workspace in a 4D web viewer: clouds by date, sites, growth, measuring",
     crop4d::cli::SetupView},
};

}  // namespace

int main(int argc, char** argv) {
  // Before any thread exists (core/allocator.h: large image buffers are reused, not refaulted).
  crop4d::KeepFreedMemoryForReuse();
  CLI::App app{
      "crop4d — 4D crop monitoring: registered 3D models of a field over a season, and "
      "the crop measurements that follow.",
      "crop4d"};
  // "crop4d 0.1.0 (commit 83319cf, Release)": version, git commit, build type.
  app.set_version_flag("--version", crop4d::VersionLine());
  app.require_subcommand(1);
  int verbose = 0;
  bool quiet = false;
  app.add_flag("-v,--verbose", verbose, "More messages (-vv for trace)");
  app.add_flag("-q,--quiet", quiet, "Only warnings and errors; no progress bars");

  crop4d::cli::RunFunction run;
  for (const Command& command : kCommands) {
    CLI::App* sub = app.add_subcommand(command.name, command.summary);
    // Global flags are accepted after the subcommand too: `crop4d validate F -v`.
    sub->add_flag("-v,--verbose", verbose, "More messages (-vv for trace)");
    sub->add_flag("-q,--quiet", quiet, "Only warnings and errors; no progress bars");
    crop4d::cli::RunFunction command_run = command.setup(*sub);
    // A command's long description goes under its options in `crop4d CMD --help`; the
    // command list of `crop4d --help` keeps the one-line summary.
    if (sub->get_description() != command.summary) {
      sub->footer("\n" + sub->get_description());
      sub->description(command.summary);
    }
    sub->callback([&run, command_run] { run = command_run; });
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; a usage error is bad input: exit code 2.
    return app.exit(e) == 0 ? 0 : 2;
  }

  crop4d::InitLogging(crop4d::VerbosityFromFlags(verbose, quiet));
  crop4d::Progress::SetGloballySilent(quiet);
  try {
    return run();
  } catch (const crop4d::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
