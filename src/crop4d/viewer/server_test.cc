#include "crop4d/viewer/server.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "crop4d/io/test_helpers.h"
#include "crop4d/viewer/bundle.h"

namespace crop4d::viewer {
namespace {

namespace fs = std::filesystem;
using io::testing::TempDir;
using io::testing::WriteText;

// A workspace with a viewer file and a report; a secret next to it; links in and out.
struct Fixture {
  TempDir dir;
  fs::path ws = fs::path(dir.path()) / "ws";
  Fixture() {
    WriteText((ws / "viewer/scene.json").string(), "{\"sessions\": []}");
    WriteText((ws / "report.html").string(), "<p>report</p>");
    WriteText(dir / "secret.txt", "secret");
    fs::create_symlink(fs::path(dir.path()) / "secret.txt", ws / "leak.txt");
    fs::create_symlink(fs::path(dir.path()), ws / "up");
    fs::create_symlink(ws / "report.html", ws / "inside.html");
  }
};

TEST(ServerPathTest, RefusesEverythingThatLeavesTheWorkspace) {
  Fixture f;
  EXPECT_EQ(ResolveServedPath(f.ws, "viewer/scene.json").status, 200);
  EXPECT_EQ(ResolveServedPath(f.ws, "report.html").status, 200);
  EXPECT_EQ(ResolveServedPath(f.ws, "inside.html").status, 200);  // a link that stays inside
  EXPECT_EQ(ResolveServedPath(f.ws, "missing.json").status, 404);
  EXPECT_EQ(ResolveServedPath(f.ws, "viewer").status, 404);  // a folder
  for (const char* bad : {"../secret.txt", "viewer/../../secret.txt", "viewer/../report.html",
                          "./report.html", "/etc/passwd", "", "viewer//scene.json",
                          "..\\secret.txt", "leak.txt", "up/secret.txt"}) {
    EXPECT_EQ(ResolveServedPath(f.ws, bad).status, 403) << bad;
  }
  EXPECT_EQ(ResolveServedPath(f.ws, std::string_view("report.html\0x", 13)).status, 403);
}

TEST(ServerPathTest, LoopbackHosts) {
  EXPECT_TRUE(IsLoopbackHost("127.0.0.1"));
  EXPECT_TRUE(IsLoopbackHost("127.1.2.3"));
  EXPECT_TRUE(IsLoopbackHost("localhost"));
  EXPECT_TRUE(IsLoopbackHost("::1"));
  EXPECT_FALSE(IsLoopbackHost("0.0.0.0"));
  EXPECT_FALSE(IsLoopbackHost("192.168.1.10"));
  EXPECT_TRUE(IsLoopbackHost(ServerOptions().host));  // the default
}

// Whether a TCP socket listens on `port` at 127.0.0.1 only, from /proc/net/tcp.
std::string ListeningAddress(int port) {
  std::ifstream in("/proc/net/tcp");
  std::string line;
  std::getline(in, line);
  char hex_port[8];
  std::snprintf(hex_port, sizeof(hex_port), "%04X", port);
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string slot, local, remote, st;
    fields >> slot >> local >> remote >> st;
    if (st == "0A" && local.substr(local.find(':') + 1) == hex_port)
      return local.substr(0, local.find(':'));
  }
  return "";
}

TEST(ServerTest, ServesThePageAndTheWorkspaceOnLoopbackAndRefusesTheRest) {
  Fixture f;
  ViewerServer server(f.ws.string(), ServerOptions{"127.0.0.1", 0});
  const int port = server.Bind();
  ASSERT_GT(port, 0);
  EXPECT_EQ(ListeningAddress(port), "0100007F");  // 127.0.0.1, not every interface
  std::thread thread([&] { server.Serve(); });
  httplib::Client client("127.0.0.1", port);
  client.set_connection_timeout(5);
  const auto get = [&](const std::string& path) {
    const auto res = client.Get(path.c_str());
    return res ? res->status : -1;
  };
  const auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("app/viewer.js"), std::string::npos);
  EXPECT_EQ(page->get_header_value("Content-Type").rfind("text/html", 0), 0u);
  const auto js = client.Get("/app/viewer.js");
  ASSERT_TRUE(js);
  EXPECT_EQ(js->status, 200);
  EXPECT_EQ(js->body, std::string(FindBundledFile("app/viewer.js")->bytes()));
  const auto scene = client.Get("/ws/viewer/scene.json");
  ASSERT_TRUE(scene);
  EXPECT_EQ(scene->status, 200);
  EXPECT_EQ(scene->body, "{\"sessions\": []}");
  EXPECT_EQ(get("/ws/report.html"), 200);
  EXPECT_EQ(get("/ws/missing.json"), 404);
  EXPECT_EQ(get("/nothing.js"), 404);
  // Leaving the workspace: plain, percent-encoded (also the slash), absolute, through links.
  for (const char* bad :
       {"/ws/../secret.txt", "/ws/viewer/../../secret.txt", "/ws/%2e%2e/secret.txt",
        "/ws/%2E%2E%2Fsecret.txt", "/ws/viewer/%2e%2e/%2e%2e/secret.txt", "/ws//etc/passwd",
        "/ws/%2fetc%2fpasswd", "/ws/leak.txt", "/ws/up/secret.txt", "/ws/..%5csecret.txt"}) {
    const auto res = client.Get(bad);
    ASSERT_TRUE(res) << bad;
    EXPECT_EQ(res->status, 403) << bad;
    EXPECT_EQ(res->body.find("secret"), std::string::npos) << bad;
  }
  server.Stop();
  thread.join();
}

TEST(ServerTest, PortInUseIsAClearError) {
  Fixture f;
  ViewerServer first(f.ws.string(), ServerOptions{"127.0.0.1", 0});
  const int port = first.Bind();
  ViewerServer second(f.ws.string(), ServerOptions{"127.0.0.1", port});
  try {
    second.Bind();
    FAIL() << "bound twice";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("--port"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace crop4d::viewer
