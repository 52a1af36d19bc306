// One build request (cadinterp_build_request: a CADINTERP_REQUEST_SAMPLE at x, or a
// CADINTERP_REQUEST_SIMULATE at x on a mesh) as bytes, for the two transports that carry requests
// to another process: the isolated build's worker pipe (host_worker_protocol.h) and the MPI ranks
// (mpi_driver.h). Both ends run the same build, so numbers are in native byte order.
//
// Layout: uint64 kind, uint64 K, then for SIMULATE uint64 #V #T #F; then K doubles x, and for
// SIMULATE 3#V doubles (vertices), 4#T uint32 (tets), 3#F uint32 (triangles), #F int32 (tags).
// Every 8-byte field comes before the 4-byte ones.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cadinterp/cadinterp_builder.h"

namespace cadinterp::tools::request_codec {

/// The bytes of a request of `kind` (a cadinterp_request_kind) at x[0..k); `mesh` is required for
/// CADINTERP_REQUEST_SIMULATE and must be NULL otherwise. Throws std::invalid_argument for an
/// unknown kind or a mesh that does not match it.
std::vector<std::uint8_t> encode(int kind, const double* x, std::size_t k,
                                 const cadinterp_host_mesh* mesh);

/// Why bytes are not a request: each value names one way they can be malformed.
enum class DecodeError {
  kNone,
  kTruncated,            ///< the bytes end before the layout their counts announce
  kWrongKind,            ///< the kind is neither SAMPLE nor SIMULATE
  kWrongParameterCount,  ///< K is not the receiving host's parameter count
  kOversizeCount,        ///< a count larger than the message could hold
  kTrailingBytes         ///< bytes left after the layout
};
/// A sentence for `e` (static storage).
const char* describe(DecodeError e);

/// A decoded request; owns its arrays (no alignment demands on the received bytes).
struct Request {
  int kind = 0;
  std::vector<double> x, vertices;
  std::vector<std::uint32_t> tets, triangles;
  std::vector<std::int32_t> tags;
  /// A view of the arrays above, valid while this Request lives unchanged.
  cadinterp_host_mesh mesh() const;
};

/// Decodes `size` bytes at `data` for a host of `parameter_count` parameters into *out. Returns
/// kNone, or the first problem found (then *out is unspecified). Never reads past data + size.
DecodeError decode(const void* data, std::size_t size, std::size_t parameter_count, Request* out);

/// Answers a decoded request on `host`: cadinterp_host_evaluate_serialized (SAMPLE) or
/// cadinterp_host_simulate_serialized (SIMULATE). Returns its status; *bytes (free with
/// cadinterp_bytes_free) and *size as those functions set them.
cadinterp_status answer(const cadinterp_host& host, const Request& request, void** bytes,
                        std::size_t* size);

}  // namespace cadinterp::tools::request_codec
