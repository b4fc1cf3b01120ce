// crop4d view: the 4D viewer of a workspace in the browser (docs/viewer.md; viewer/server.h).

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/viewer/server.h"
#include "crop4d/viewer/static_viewer.h"
#include "crop4d/viewer/viewer_data.h"
#include "crop4d/workspace/layout.h"

extern char** environ;

namespace crop4d::cli {
namespace {

struct ViewArgs {
  std::string workspace;
  viewer::ViewerDataOptions data;
  viewer::ServerOptions server;
  bool no_browser = false;
};

viewer::ViewerServer* g_server = nullptr;

// Opens `url` in the desktop's browser (xdg-open) when there is a display; does not wait.
void OpenBrowser(const std::string& url) {
  if (std::getenv("DISPLAY") == nullptr && std::getenv("WAYLAND_DISPLAY") == nullptr) {
    std::printf("no display: open %s in a browser\n", url.c_str());
    return;
  }
  pid_t pid = 0;
  const char* argv[] = {"xdg-open", url.c_str(), nullptr};
  if (::posix_spawnp(&pid, "xdg-open", nullptr, nullptr, const_cast<char**>(argv), environ) != 0)
    std::printf("could not start xdg-open: open %s in a browser\n", url.c_str());
}

int RunView(const ViewArgs& args) {
  namespace fs = std::filesystem;
  const std::string data = workspace::Layout(args.workspace).ViewerDir().string();
  {
    // The viewer data is written under the workspace's lock, then the lock is released: a
    // pipeline stage may run while the viewer is open (reload the page to see its results).
    const auto lock = LockWorkspace(args.workspace, "view", /*create=*/false);
    const viewer::ViewerDataSummary summary =
        viewer::WriteViewerData(args.workspace, data, args.data);
    if (!IsQuiet()) std::fputs(viewer::FormatViewerDataSummary(summary).c_str(), stdout);
  }
  viewer::ViewerServer server(args.workspace, args.server);
  const int port = server.Bind();
  if (!viewer::IsLoopbackHost(args.server.host)) {
    std::fprintf(stderr,
                 "warning: serving on %s: every machine that can reach this one can read the "
                 "workspace's viewer data and report (no authentication)\n",
                 args.server.host.c_str());
  }
  const std::string shown_host = args.server.host == "0.0.0.0" ? "127.0.0.1" : args.server.host;
  const std::string url = "http://" + shown_host + ":" + std::to_string(port) + "/";
  std::printf("crop4d view: serving %s at %s (Ctrl-C to stop)\n", args.workspace.c_str(),
              url.c_str());
  std::fflush(stdout);
  if (!args.no_browser) OpenBrowser(url);
  g_server = &server;
  std::signal(SIGINT, [](int) {
    if (g_server != nullptr) g_server->Stop();
  });
  std::signal(SIGTERM, [](int) {
    if (g_server != nullptr) g_server->Stop();
  });
  server.Serve();
  g_server = nullptr;
  return 0;
}

}  // namespace

RunFunction SetupView(CLI::App& app) {
  auto args = std::make_shared<ViewArgs>();
  app.description(
      "Show the workspace in a 4D web viewer (docs/viewer.md): every session's cloud in the "
      "field frame with a time slider, colour by RGB, height above terrain or change between "
      "two dates, trajectories, measurement sites with their growth curves, the terrain, and "
      "distance/height measuring. The viewer's tiles are written into WS/viewer/ on first use "
      "(rebuilt only when a cloud changed); the page is served on 127.0.0.1 only unless --host "
      "says otherwise, and nothing outside the workspace is served.\n\nExamples:\n"
      "  crop4d view demo/workspace\n"
      "  crop4d view demo/workspace --port 0 --no-browser\n"
      "  crop4d view demo/workspace --host 0.0.0.0 --port 8084   (the LAN can see it)");
  app.add_option("workspace", args->workspace, "Workspace to show")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--field", args->data.field,
                 "Field folder (optional): the analysis terrain model (analysis/dtm.tif) as the "
                 "terrain, and the sites at the centres of its field.yaml")
      ->check(CLI::ExistingDirectory);
  app.add_option("--host", args->server.host,
                 "Address to listen on; anything but loopback shows the workspace to the network")
      ->capture_default_str();
  app.add_option("--port", args->server.port, "Port; 0 picks a free one (printed)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  app.add_flag("--no-browser", args->no_browser, "Do not open a browser (xdg-open)");
  return [args] { return RunView(*args); };
}

}  // namespace crop4d::cli
