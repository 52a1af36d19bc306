// The .cadi file layout (fileformat/SPEC.md) and the format layer's error type.
//
//   [header, 48 bytes][index: FlatBuffers "CADI", 8-aligned][blob section]
//
// Blob offsets are relative to the blob section, which starts right after the index and ends at
// the end of the file; the blobs tile it exactly (no gaps, no overlaps, no trailing bytes). So
// every byte of a valid file is covered by a header check, the index checksum or a blob checksum:
// no bit can flip unnoticed.
//
// The header is little-endian:
//   0  u8[8]  magic 89 43 41 44 49 0D 0A 1A  ("\x89CADI\r\n\x1a": catches text-mode and 7-bit
//             transfers like PNG's signature)
//   8  u16    format major (readers reject any other major)
//   10 u16    format minor (readers read newer minors too; writers stamp the lowest minor
//             whose schema holds what the file uses: 1.1 only with field units, 1.3 with
//             scalar outputs; from 1.2 on repeated in the index)
//   12 u32    header size (exactly 48 in every 1.x)
//   16 u64    file size in bytes (a shorter file is truncated, a longer one corrupt)
//   24 u64    index offset (exactly 48 in every 1.x: the index follows the header)
//   32 u64    index size
//   40 u64    XXH64 (seed 0) of the index bytes
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "cadinterp/cadinterp_status.h"

namespace cadinterp::format {

inline constexpr std::uint8_t kMagic[8] = {0x89, 'C', 'A', 'D', 'I', '\r', '\n', 0x1A};
inline constexpr std::uint16_t kFormatMajor = 1;
/// The newest minor this code knows (its schema: fileformat/cadinterp.fbs). Readers open newer
/// minors too, ignoring what they do not know (format_version.h, SPEC.md "Versions and
/// features").
inline constexpr std::uint16_t kFormatMinor = 3;
/// 1.1 appended FieldDesc.unit.
inline constexpr std::uint16_t kMinorFieldUnits = 1;
/// 1.2 appended Asset.format_minor and Asset.required_features.
inline constexpr std::uint16_t kMinorFeatures = 2;
/// 1.3 appended SampleOutput and Asset.outputs (per-sample scalar outputs).
inline constexpr std::uint16_t kMinorOutputs = 3;
inline constexpr std::size_t kHeaderSize = 48;

/// Outcome of reading or writing an asset. The values equal the C ABI's cadinterp_status values
/// (include/cadinterp/cadinterp_status.h), which the runtime and the builder return by casting
/// the number; the static_asserts below pin each one. Explicit and only ever appended.
enum class Status : int {
  Ok = 0,
  InvalidArgument = 1,
  OutOfMemory = 2,
  Io = 3,                  ///< cannot open, map or read the file
  BadMagic = 4,            ///< not a cadinterp asset
  UnsupportedVersion = 5,  ///< another format major, or an unknown required feature
  Truncated = 6,           ///< the file is shorter than its header says
  CorruptIndex = 7,        ///< the index fails verification (structure, sizes, ranges, values)
  ChecksumMismatch = 8,    ///< index or blob bytes differ from their XXH64
  OutOfRange = 9,          ///< a blob lies outside the file
  LimitExceeded = 10,      ///< a count exceeds the reader's limits (memory exhaustion guard)
  CorruptBlob = 11,        ///< a blob fails to decode or its decoded values are invalid
  OutsideDomain = 12,      ///< x lies outside the parameter box
  Infeasible = 13,         ///< x lies in an element that depends on an infeasible sample
  Internal = 14,
};

// A code appended here must be appended to cadinterp_status.h with the same number.
constexpr bool same_code(Status s, cadinterp_status c) { return static_cast<int>(s) == c; }
static_assert(same_code(Status::Ok, CADINTERP_OK));
static_assert(same_code(Status::InvalidArgument, CADINTERP_E_INVALID_ARGUMENT));
static_assert(same_code(Status::OutOfMemory, CADINTERP_E_OUT_OF_MEMORY));
static_assert(same_code(Status::Io, CADINTERP_E_IO));
static_assert(same_code(Status::BadMagic, CADINTERP_E_BAD_MAGIC));
static_assert(same_code(Status::UnsupportedVersion, CADINTERP_E_UNSUPPORTED_VERSION));
static_assert(same_code(Status::Truncated, CADINTERP_E_TRUNCATED));
static_assert(same_code(Status::CorruptIndex, CADINTERP_E_CORRUPT_INDEX));
static_assert(same_code(Status::ChecksumMismatch, CADINTERP_E_CHECKSUM));
static_assert(same_code(Status::OutOfRange, CADINTERP_E_OUT_OF_RANGE));
static_assert(same_code(Status::LimitExceeded, CADINTERP_E_LIMIT));
static_assert(same_code(Status::CorruptBlob, CADINTERP_E_CORRUPT_BLOB));
static_assert(same_code(Status::OutsideDomain, CADINTERP_E_OUTSIDE_DOMAIN));
static_assert(same_code(Status::Infeasible, CADINTERP_E_INFEASIBLE));
static_assert(same_code(Status::Internal, CADINTERP_E_INTERNAL));

/// Fixed English name of a status ("ok", "bad magic", ...).
const char* status_name(Status s);

/// Every failure of the format layer; `status` names it, what() gives the detail.
struct FormatError : std::runtime_error {
  FormatError(Status s, const std::string& what) : std::runtime_error(what), status(s) {}
  Status status;
};

/// Limits a reader enforces before allocating anything; the defaults accept any asset the
/// builder writes on a 64-bit machine and refuse counts that could only exhaust memory.
struct ReadLimits {
  std::uint64_t max_vertices = 1u << 26;                     ///< per element
  std::uint64_t max_tets = 1u << 27;                         ///< per element
  std::uint64_t max_triangles = 1u << 26;                    ///< per element
  std::uint64_t max_decoded_bytes = std::uint64_t(1) << 32;  ///< one element's decoded meshes
  /// An element may decode to at most this many times its stored bytes (+ 4 KiB): a few bytes
  /// claiming huge counts must not make the reader allocate gigabytes. Mesh data compresses
  /// 2-50x; 1024 leaves a wide margin.
  std::uint64_t max_expansion = 1024;
};

}  // namespace cadinterp::format
