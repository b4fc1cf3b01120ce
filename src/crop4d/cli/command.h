#pragma once

// One crop4d subcommand. Each lives in its own <name>_command.cc and is listed once in the
// table in main.cc. `setup` adds the command's options to its CLI11 sub-app and returns the
// function that runs it once the command line has been parsed; that function returns the
// process exit code (0 ok, 2 bad input, 1 other failure) or throws (InputError → 2).

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <string>

#include "crop4d/io/workspace_lock.h"

namespace crop4d::cli {

using RunFunction = std::function<int()>;

// The lock of a workspace for a command that writes into it (io/workspace_lock.h), held until
// the returned object is destroyed. The folder is created first when `create`; otherwise a
// missing folder is not locked (the stage then says what it lacks). Throws InputError (exit 2)
// naming the holder when another crop4d process writes into the workspace.
std::unique_ptr<io::WorkspaceLock> LockWorkspace(const std::string& workspace,
                                                 const std::string& command, bool create);

struct Command {
  const char* name;
  const char* summary;
  RunFunction (*setup)(CLI::App& app);
};

RunFunction SetupValidate(CLI::App& app);
RunFunction SetupSimulate(CLI::App& app);
RunFunction SetupImport(CLI::App& app);
RunFunction SetupSlam(CLI::App& app);
RunFunction SetupAssociate(CLI::App& app);
RunFunction SetupFuse(CLI::App& app);
RunFunction SetupEval(CLI::App& app);
RunFunction SetupSection(CLI::App& app);
RunFunction SetupAnalyze(CLI::App& app);
RunFunction SetupDensify(CLI::App& app);
RunFunction SetupRun(CLI::App& app);
RunFunction SetupExport(CLI::App& app);
RunFunction SetupReport(CLI::App& app);
RunFunction SetupView(CLI::App& app);
RunFunction SetupTask(CLI::App& app);
RunFunction SetupStatus(CLI::App& app);

}  // namespace crop4d::cli
