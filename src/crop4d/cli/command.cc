#include "crop4d/cli/command.h"

#include <filesystem>
#include <system_error>

#include "crop4d/core/error.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::cli {

std::unique_ptr<io::WorkspaceLock> LockWorkspace(const std::string& workspace,
                                                 const std::string& command, bool create) {
  namespace fs = std::filesystem;
  if (workspace.empty()) return nullptr;
  std::error_code ec;
  if (create) fs::create_directories(workspace, ec);
  if (!fs::is_directory(workspace)) {
    if (create)
      throw InputError(workspace, 0, "cannot create the workspace folder: " + ec.message());
    return nullptr;
  }
  return std::make_unique<io::WorkspaceLock>(workspace::Layout(workspace).Lock(), command);
}

}  // namespace crop4d::cli
