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

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_builder.h"
#include "host_library.h"
#include "host_worker_protocol.h"

namespace wp = cadinterp::tools::worker_protocol;

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

// Reads `count` values of T from the payload at *offset; false when it would run past its end.
template <typename T>
bool take(const std::vector<std::uint8_t>& payload, std::size_t* offset, std::uint64_t count,
          std::vector<T>* out) {
  if (count > (payload.size() - *offset) / sizeof(T)) return false;
  out->resize(static_cast<std::size_t>(count));
  if (count > 0) std::memcpy(out->data(), payload.data() + *offset, count * sizeof(T));
  *offset += static_cast<std::size_t>(count) * sizeof(T);
  return true;
}

// Answers one request; false when the request is malformed (the worker then stops: the parent
// and the worker disagree about the protocol).
bool answer(const cadinterp_host& host, std::uint32_t type,
            const std::vector<std::uint8_t>& payload) {
  const auto k = static_cast<std::size_t>(host.parameter_count);
  std::size_t offset = 0;
  std::vector<double> x;
  if (!take(payload, &offset, k, &x)) return false;
  void* bytes = nullptr;
  size_t size = 0;
  cadinterp_status s;
  if (type == wp::kSample) {
    if (offset != payload.size()) return false;
    s = cadinterp_host_evaluate_serialized(&host, x.data(), &bytes, &size);
  } else {
    std::vector<std::uint64_t> counts;
    std::vector<double> vertices;
    std::vector<std::uint32_t> tets, triangles;
    std::vector<std::int32_t> tags;
    if (!take(payload, &offset, 3, &counts) ||
        std::any_of(counts.begin(), counts.end(),
                    [&payload](std::uint64_t c) { return c > payload.size(); }) ||
        !take(payload, &offset, 3 * counts[0], &vertices) ||
        !take(payload, &offset, 4 * counts[1], &tets) ||
        !take(payload, &offset, 3 * counts[2], &triangles) ||
        !take(payload, &offset, counts[2], &tags) || offset != payload.size())
      return false;
    const cadinterp_host_mesh mesh{counts[0], vertices.data(),  counts[1],  tets.data(),
                                   counts[2], triangles.data(), tags.data()};
    s = cadinterp_host_simulate_serialized(&host, x.data(), &mesh, &bytes, &size);
  }
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
    if (!wp::parse_header(h, &type, &size) || (type != wp::kSample && type != wp::kSimulate))
      return 3;
    std::vector<std::uint8_t> payload(static_cast<std::size_t>(size));
    if (!read_full(payload.data(), payload.size())) return 0;
    if (!answer(*host, type, payload)) return 3;
  }
}
