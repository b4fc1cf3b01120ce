#pragma once

// The HTTP server of `crop4d view` (docs/viewer.md), on cpp-httplib: the bundled page
// (bundle.h) at "/", and files of the workspace under "/ws/<path>": the viewer data
// (WS/viewer/...) and the report. Nothing outside the workspace is served: a request path with
// a ".." or "." segment (also when percent-encoded: paths are decoded first), an empty segment
// (an absolute path after "/ws/"), a backslash or NUL, or one that resolves through a symbolic
// link to a place outside the workspace is refused (403). Only GET and HEAD are answered.

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace crop4d::viewer {

// Where a request for `relative` (decoded, below the served root, without a leading slash)
// leads: status 200 and the canonical file, 403 for a path that is not allowed, 404 for one
// that does not exist or is not a regular file.
struct ResolvedPath {
  int status = 404;
  std::filesystem::path file;
};
ResolvedPath ResolveServedPath(const std::filesystem::path& root, std::string_view relative);

struct ServerOptions {
  // The address to listen on: loopback only by default; "0.0.0.0" or a LAN address serves the
  // workspace to every machine that can reach this one.
  std::string host = "127.0.0.1";
  // 0: any free port (ViewerServer::Bind returns it).
  int port = 8084;
};

// Whether `host` is a loopback address (127.0.0.0/8, ::1, "localhost").
bool IsLoopbackHost(const std::string& host);

class ViewerServer {
 public:
  ViewerServer(std::string workspace, ServerOptions options);
  ~ViewerServer();
  ViewerServer(const ViewerServer&) = delete;
  ViewerServer& operator=(const ViewerServer&) = delete;

  // Binds the socket and returns the port. Throws InputError naming --host/--port when the
  // address cannot be bound (port taken, address not of this machine).
  int Bind();
  // Answers requests until Stop() (from another thread or a signal handler's thread).
  void Serve();
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace crop4d::viewer
