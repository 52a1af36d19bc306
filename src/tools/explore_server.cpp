// `cadinterp explore`'s embedded HTTP server (cpp-httplib). Routes:
//   /api/asset.cadi   the validated asset bytes (from memory)
//   /api/asset.json   name, size and the native runtime's summary
//   /api/optimize     GET: whether the optimizer is available; POST: run it (explore_optimize.h)
//   /wasm/...         the WebAssembly runtime (scripts/build-wasm.sh output)
//   /...              the built explorer page
// Everything is sent with Cache-Control: no-store: this is a local tool whose asset and page
// change between runs on the same port, and a stale cached asset would silently show another
// model.
#include "explore_server.h"

#include "explore_optimize.h"

#include <httplib.h>
#include <pthread.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdio>
#include <stdexcept>
#include <thread>

namespace cadinterp::cli {

namespace {

struct MimeEntry {
  const char* extension;
  const char* type;
};

// The types a built page and the Emscripten output use; JavaScript modules must be served as
// JavaScript (browsers refuse module scripts of other types) and wasm as application/wasm.
constexpr MimeEntry kMimeTypes[] = {
    {"html", "text/html; charset=utf-8"},
    {"htm", "text/html; charset=utf-8"},
    {"js", "text/javascript; charset=utf-8"},
    {"mjs", "text/javascript; charset=utf-8"},
    {"css", "text/css; charset=utf-8"},
    {"json", "application/json"},
    {"map", "application/json"},
    {"wasm", "application/wasm"},
    {"svg", "image/svg+xml"},
    {"png", "image/png"},
    {"jpg", "image/jpeg"},
    {"ico", "image/x-icon"},
    {"txt", "text/plain; charset=utf-8"},
    {"cadi", "application/octet-stream"},
};

std::string extension_of(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  const std::size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot + 1);
  std::transform(e.begin(), e.end(), e.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}

}  // namespace

const char* mime_type_for(const std::string& path) {
  const std::string e = extension_of(path);
  for (const MimeEntry& m : kMimeTypes)
    if (e == m.extension) return m.type;
  return "application/octet-stream";
}

int run_explore_server(const ExploreServerOptions& o,
                       void (*on_listening)(const std::string& url, void* user), void* user) {
  if (!o.asset_bytes) throw std::invalid_argument("run_explore_server: no asset bytes");
  httplib::Server server;
  for (const MimeEntry& m : kMimeTypes)
    server.set_file_extension_and_mimetype_mapping(m.extension, m.type);
  // Mount order matters: httplib tries mount points in registration order.
  if (!server.set_mount_point("/wasm", o.wasm_dir))
    throw std::runtime_error("the wasm directory " + o.wasm_dir + " is not a directory");
  if (!server.set_mount_point("/", o.web_root))
    throw std::runtime_error("the web root " + o.web_root + " is not a directory");
  server.set_default_headers({{"Cache-Control", "no-store"}});
  // httplib's default sets SO_REUSEPORT, which lets a second `cadinterp explore` bind the same
  // port and silently take half the requests (with another asset). SO_REUSEADDR alone still
  // allows a restart while old connections linger in TIME_WAIT.
  server.set_socket_options([](int sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });

  const std::vector<std::uint8_t>* bytes = o.asset_bytes;
  server.Get("/api/asset.cadi", [bytes](const httplib::Request&, httplib::Response& res) {
    // Streamed from the validated buffer in 1 MiB pieces rather than copied into a body string.
    res.set_content_provider(
        bytes->size(), "application/octet-stream",
        [bytes](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
          const std::size_t n = std::min<std::size_t>(length, std::size_t{1} << 20);
          return sink.write(reinterpret_cast<const char*>(bytes->data()) + offset, n);
        });
  });
  const std::string summary = o.asset_summary_json;
  server.Get("/api/asset.json", [summary](const httplib::Request&, httplib::Response& res) {
    res.set_content(summary, "application/json");
  });
  server.Get("/api/optimize", [](const httplib::Request&, httplib::Response& res) {
    const HttpReply r = optimize_capabilities();
    res.status = r.status;
    res.set_content(r.body, "application/json");
  });
  const cadinterp_asset* asset = o.asset;
  server.Post("/api/optimize", [asset](const httplib::Request& req, httplib::Response& res) {
    // Form fields: httplib parses an application/x-www-form-urlencoded body into params.
    const HttpReply r = optimize_request(asset, req.params);
    res.status = r.status;
    res.set_content(r.body, "application/json");
  });
  server.set_logger([](const httplib::Request& req, const httplib::Response& res) {
    if (res.status >= 400)
      std::fprintf(stderr, "cadinterp explore: %d %s %s\n", res.status, req.method.c_str(),
                   req.path.c_str());
  });

  // SIGINT/SIGTERM are blocked in this thread before the server's threads exist (they inherit
  // the mask), and taken synchronously with sigwait below: stopping the server from a signal
  // handler would not be async-signal-safe.
  sigset_t stop_signals, old_mask;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, &old_mask);

  int port = o.port;
  bool bound;
  if (port == 0) {
    port = server.bind_to_any_port(o.bind);
    bound = port > 0;
  } else {
    bound = server.bind_to_port(o.bind, port);
  }
  if (!bound) {
    pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);
    throw std::runtime_error("cannot listen on " + o.bind + ":" + std::to_string(o.port) +
                             " (address in use or not available; --port 0 picks a free port)");
  }
  // bind_to_port also listen()s, so connections queue from here on even before accept starts.
  const std::string host = o.bind == "0.0.0.0" ? "127.0.0.1" : o.bind;
  const std::string url = "http://" +
                          (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":" +
                          std::to_string(port) + "/";
  std::atomic<bool> stopping{false};
  std::thread loop([&server, &stopping] {
    // listen_after_bind returns when stop() is called, or on an accept error: then wake the
    // waiting thread the same way Ctrl-C would.
    server.listen_after_bind();
    if (!stopping) kill(getpid(), SIGTERM);
  });
  on_listening(url, user);
  int signal_number = 0;
  sigwait(&stop_signals, &signal_number);
  stopping = true;
  server.stop();
  loop.join();
  pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);
  return 0;
}

}  // namespace cadinterp::cli
