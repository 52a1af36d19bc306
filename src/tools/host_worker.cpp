// cadinterp-host-worker: one host library in a process of its own, for `cadinterp build
// --isolate` (isolated_driver.h). A segfault, abort or endless loop in the host's kernel then
// ends this process, not the build.
//
//   cadinterp-host-worker LIBRARY MODEL OPTIONS
//
// MODEL and OPTIONS as `cadinterp build --model/--host-options` ("" for the defaults). Speaks
// host_worker_protocol.h on fds 0 and 1, which the parent connects to one socket. It is not
// meant to be run by hand.
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_builder.h"
#include "host_library.h"
#include "host_request_codec.h"
#include "host_worker_protocol.h"

namespace wp = cadinterp::tools::worker_protocol;
namespace rc = cadinterp::tools::request_codec;

namespace {

// Protocol fds, moved off 0 and 1: a host that prints to stdout must not corrupt the frames, so
// fd 1 becomes a copy of stderr and fd 0 reads /dev/null.
int g_in = -1, g_out = -1;

bool read_full(void* p, std::size_t n) {
  auto* b = static_cast<std::uint8_t*>(p);
  while (n > 0) {
    const ssize_t r = read(g_in, b, n);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    b += r;
    n -= static_cast<std::size_t>(r);
  }
  return true;
}

bool write_full(const void* p, std::size_t n) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  while (n > 0) {
    const ssize_t r = write(g_out, b, n);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    b += r;
    n -= static_cast<std::size_t>(r);
  }
  return true;
}

bool send(wp::Type type, const void* payload, std::size_t size) {
  const std::vector<std::uint8_t> h = wp::header(type, size);
  return write_full(h.data(), h.size()) && (size == 0 || write_full(payload, size));
}

bool send_text(wp::Type type, const std::string& s) { return send(type, s.data(), s.size()); }

// Answers one request; false when the request is malformed (the worker then stops: the parent
// and the worker disagree about the protocol, and it says so on stderr).
bool answer(const cadinterp_host& host, const std::vector<std::uint8_t>& payload) {
  rc::Request request;
  const rc::DecodeError e = rc::decode(payload.data(), payload.size(),
                                       static_cast<std::size_t>(host.parameter_count), &request);
  if (e != rc::DecodeError::kNone) {
    std::fprintf(stderr, "cadinterp-host-worker: %s\n", rc::describe(e));
    return false;
  }
  void* bytes = nullptr;
  size_t size = 0;
  const cadinterp_status s = rc::answer(host, request, &bytes, &size);
  if (s != CADINTERP_OK)
    return send_text(wp::kError, "the worker could not evaluate the host (status " +
                                     std::to_string(static_cast<int>(s)) + ")");
  const bool sent = send(wp::kResult, bytes, size);
  cadinterp_bytes_free(bytes);
  return sent;
}

}  // namespace

int main(int argc, char** argv) {
  g_in = fcntl(0, F_DUPFD_CLOEXEC, 3);
  g_out = fcntl(1, F_DUPFD_CLOEXEC, 3);
  const int null_fd = open("/dev/null", O_RDONLY);
  if (g_in < 0 || g_out < 0 || null_fd < 0 || dup2(null_fd, 0) < 0 || dup2(2, 1) < 0) {
    std::fprintf(stderr, "cadinterp-host-worker: cannot set up its fds: %s\n",
                 std::strerror(errno));
    return 2;
  }
  close(null_fd);
  if (argc != 4) {
    send_text(wp::kError, "usage: cadinterp-host-worker LIBRARY MODEL OPTIONS");
    return 2;
  }
  cadinterp::tools::HostLibrary library;
  const cadinterp_host* host = nullptr;
  try {
    host = library.load(argv[1], argv[2], argv[3]);
  } catch (const cadinterp::tools::HostLoadError& e) {
    send_text(wp::kError, e.what());
    return 2;
  }
  const std::string hello =
      std::string(host->name ? host->name : "") + '\0' + (host->identity ? host->identity : "");
  if (!send_text(wp::kHello, hello)) return 2;
  for (;;) {
    std::uint8_t h[wp::kHeaderSize];
    if (!read_full(h, sizeof h)) return 0;  // the parent closed its end
    std::uint32_t type = 0;
    std::uint64_t size = 0;
    if (!wp::parse_header(h, &type, &size) || type != wp::kRequest) return 3;
    std::vector<std::uint8_t> payload(static_cast<std::size_t>(size));
    if (!read_full(payload.data(), payload.size())) return 0;
    if (!answer(*host, payload)) return 3;
  }
}
