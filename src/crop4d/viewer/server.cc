#include "crop4d/viewer/server.h"

#include <arpa/inet.h>
#include <sys/socket.h>
#include <httplib.h>

#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include "crop4d/core/error.h"
#include "crop4d/viewer/bundle.h"

namespace crop4d::viewer {
namespace {

namespace fs = std::filesystem;

const char* MimeType(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".json") return "application/json";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".csv" || ext == ".txt") return "text/plain; charset=utf-8";
  return "application/octet-stream";
}

// Whether `inner` is `outer` or below it (both canonical).
bool IsWithin(const fs::path& outer, const fs::path& inner) {
  auto a = outer.begin(), b = inner.begin();
  for (; a != outer.end(); ++a, ++b) {
    if (b == inner.end() || *a != *b) return false;
  }
  return true;
}

}  // namespace

ResolvedPath ResolveServedPath(const fs::path& root, std::string_view relative) {
  ResolvedPath out;
  out.status = 403;
  if (relative.empty() || relative.front() == '/') return out;
  if (relative.find('\\') != std::string_view::npos ||
      relative.find('\0') != std::string_view::npos)
    return out;
  std::size_t start = 0;
  while (start <= relative.size()) {
    std::size_t end = relative.find('/', start);
    if (end == std::string_view::npos) end = relative.size();
    const std::string_view segment = relative.substr(start, end - start);
    if (segment.empty() || segment == "." || segment == "..") return out;
    start = end + 1;
  }
  std::error_code ec;
  const fs::path root_canonical = fs::canonical(root, ec);
  if (ec) return out;
  const fs::path file = fs::canonical(root / fs::path(std::string(relative)), ec);
  if (ec) {
    out.status = 404;
    return out;
  }
  if (!IsWithin(root_canonical, file)) return out;  // a symbolic link leading out
  if (!fs::is_regular_file(file, ec)) {
    out.status = 404;
    return out;
  }
  out.status = 200;
  out.file = file;
  return out;
}

bool IsLoopbackHost(const std::string& host) {
  if (host == "localhost" || host == "::1") return true;
  in_addr addr{};
  if (::inet_pton(AF_INET, host.c_str(), &addr) == 1)
    return (ntohl(addr.s_addr) >> 24) == 127;
  return false;
}

struct ViewerServer::Impl {
  std::string workspace;
  ServerOptions options;
  httplib::Server server;
};

ViewerServer::ViewerServer(std::string workspace, ServerOptions options)
    : impl_(std::make_unique<Impl>()) {
  impl_->workspace = std::move(workspace);
  impl_->options = std::move(options);
  const fs::path root = impl_->workspace;
  auto handler = [root](const httplib::Request& req, httplib::Response& res) {
    res.set_header("Cache-Control", "no-cache");
    res.set_header("X-Content-Type-Options", "nosniff");
    const std::string& path = req.path;  // percent-decoded by httplib
    constexpr std::string_view kWs = "/ws/";
    if (path.rfind(kWs, 0) == 0) {
      const ResolvedPath resolved = ResolveServedPath(root, std::string_view(path).substr(4));
      res.status = resolved.status;
      if (resolved.status != 200) {
        res.set_content(resolved.status == 403 ? "forbidden: outside the workspace\n"
                                               : "not found\n",
                        "text/plain");
        return;
      }
      std::ifstream in(resolved.file, std::ios::binary);
      std::ostringstream bytes;
      bytes << in.rdbuf();
      res.set_content(bytes.str(), MimeType(resolved.file));
      return;
    }
    const std::string name = path == "/" ? "index.html" : path.substr(1);
    if (const BundledFile* file = FindBundledFile(name)) {
      res.status = 200;
      res.set_content(std::string(file->bytes()), MimeType(name));
      return;
    }
    res.status = 404;
    res.set_content("not found\n", "text/plain");
  };
  impl_->server.Get(R"(/.*)", handler);
  // httplib's default also sets SO_REUSEPORT, which would let a second server share the port
  // silently; SO_REUSEADDR alone restarts quickly and still reports a port in use.
  impl_->server.set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
}

ViewerServer::~ViewerServer() { Stop(); }

int ViewerServer::Bind() {
  const ServerOptions& o = impl_->options;
  int port = o.port;
  if (o.port == 0) {
    port = impl_->server.bind_to_any_port(o.host);
    if (port < 0) port = 0;
  } else if (!impl_->server.bind_to_port(o.host, o.port)) {
    port = 0;
  }
  if (port <= 0)
    throw InputError("--host/--port", 0,
                     "cannot listen on " + o.host + ":" + std::to_string(o.port) +
                         " (port in use, or not an address of this machine): " +
                         std::strerror(errno));
  return port;
}

void ViewerServer::Serve() { impl_->server.listen_after_bind(); }

void ViewerServer::Stop() {
  if (impl_ && impl_->server.is_running()) impl_->server.stop();
}

const BundledFile* FindBundledFile(std::string_view path) {
  for (const BundledFile* f = kViewerBundle; f->path != nullptr; ++f)
    if (path == f->path) return f;
  return nullptr;
}

}  // namespace crop4d::viewer
