// The pipe protocol between `cadinterp build --isolate` and its cadinterp-host-worker processes
// (host_worker.cpp): framed messages over one stream socket, the worker's fds 0 and 1. Both ends
// run on the same machine from the same build, so numbers are in native byte order.
//
// Frame: uint32 magic, uint32 type, uint64 payload size, payload.
//   worker -> parent, once at start:  kHello (host name, '\0', identity) or kError (message; the
//                                      worker then exits)
//   parent -> worker:                 kRequest (the bytes of request_codec::encode,
//                                      host_request_codec.h)
//   worker -> parent, per request:    kResult (the bytes of cadinterp_host_evaluate_serialized /
//                                      cadinterp_host_simulate_serialized) or kError (message)
// The parent closes its end to stop a worker; a worker that reads end-of-file exits with 0.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace cadinterp::tools::worker_protocol {

constexpr std::uint32_t kMagic = 0x31574943;  // "CIW1"
enum Type : std::uint32_t { kHello = 1, kError = 2, kRequest = 3, kResult = 5 };
constexpr std::size_t kHeaderSize = 16;
/// Largest payload either end accepts (a corrupt size must not become a huge allocation).
constexpr std::uint64_t kMaxPayload = std::uint64_t{1} << 34;

/// The 16 header bytes of a frame.
inline std::vector<std::uint8_t> header(Type type, std::uint64_t payload_size) {
  std::vector<std::uint8_t> h(kHeaderSize);
  const std::uint32_t t = type;
  std::memcpy(h.data(), &kMagic, 4);
  std::memcpy(h.data() + 4, &t, 4);
  std::memcpy(h.data() + 8, &payload_size, 8);
  return h;
}

/// Parses a header; false when the magic or the size is wrong.
inline bool parse_header(const std::uint8_t* h, std::uint32_t* type, std::uint64_t* size) {
  std::uint32_t magic = 0;
  std::memcpy(&magic, h, 4);
  std::memcpy(type, h + 4, 4);
  std::memcpy(size, h + 8, 8);
  return magic == kMagic && *size <= kMaxPayload;
}

}  // namespace cadinterp::tools::worker_protocol
