// Dispatch, argument checks, blob headers, the shared quantizer and the Raw codec.
#include "format/codec.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the codecs write host-order words as little-endian blobs");
static_assert(std::numeric_limits<float>::is_iec559 && sizeof(float) == 4, "IEEE float32");

namespace cadinterp::format {

const char* codec_name(Codec c) {
  switch (c) {
    case Codec::Raw:
      return "raw";
    case Codec::QuantDeltaZstd:
      return "quant-delta-zstd";
    case Codec::Meshopt:
      return "meshopt";
    case Codec::Draco:
      return "draco";
  }
  return "unknown";
}

bool codec_is_known(std::uint8_t value) { return value <= static_cast<std::uint8_t>(Codec::Draco); }

CodecError::CodecError(Kind k, const std::string& what) : std::runtime_error(what), kind(k) {}

const char* codec_error_kind_name(CodecError::Kind k) {
  switch (k) {
    case CodecError::Kind::Corrupt:
      return "corrupt";
    case CodecError::Kind::Unsupported:
      return "unsupported";
    case CodecError::Kind::InvalidArgument:
      return "invalid argument";
  }
  return "unknown";
}

bool strict_error_bound(double max_abs_error, double max_abs_value) {
  return max_abs_error > 0.0 && max_abs_error >= 0x1p-22 * (max_abs_value + max_abs_error);
}

double float_error_bound(double max_abs_error, float v) {
  if (max_abs_error == 0.0) return 0.0;
  return max_abs_error + 0x1p-23 * (std::fabs(static_cast<double>(v)) + max_abs_error);
}

namespace detail {

void fail(CodecError::Kind k, const std::string& what) { throw CodecError(k, what); }
void corrupt(const std::string& what) { throw CodecError(CodecError::Kind::Corrupt, what); }

namespace {
void invalid(const std::string& what) { fail(CodecError::Kind::InvalidArgument, what); }

template <typename T>
void put_le(std::vector<std::uint8_t>& out, T v) {
  std::uint8_t b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.insert(out.end(), b, b + sizeof(T));
}

template <typename T>
T get_le(const std::uint8_t* bytes, std::size_t size, std::size_t& pos) {
  if (size - pos < sizeof(T)) corrupt("truncated header");
  T v;
  std::memcpy(&v, bytes + pos, sizeof(T));
  pos += sizeof(T);
  return v;
}

// Lossy mode bounds: |v| <= 2^126 and max_abs_error <= 2^126 keep float(ref + q * step) finite.
constexpr double kMaxLossyMagnitude = 0x1p126;

void check_lossy_values(const float* a, std::size_t n, const char* what) {
  for (std::size_t i = 0; i < n; ++i) {
    // Written so that NaN fails the comparison.
    if (!(std::fabs(a[i]) <= static_cast<float>(kMaxLossyMagnitude))) {
      invalid(std::string("lossy mode needs finite ") + what + " values of magnitude <= 2^126");
    }
  }
}
}  // namespace

void write_header(std::vector<std::uint8_t>& out, const BlobHeader& h) {
  out.push_back(BlobHeader::kVersion);
  out.push_back(h.mode);
  out.push_back(h.flags);
  out.push_back(h.width);
  put_le<std::uint64_t>(out, h.rows);
  put_le<std::uint32_t>(out, h.vertex_count);
}

BlobHeader read_header(const std::uint8_t* bytes, std::size_t size, std::size_t& pos,
                       std::uint8_t width, std::size_t rows, std::uint32_t vertex_count) {
  if (size - pos < BlobHeader::kSize) corrupt("blob shorter than its header");
  BlobHeader h;
  const std::uint8_t version = bytes[pos];
  if (version != BlobHeader::kVersion) {
    fail(version > BlobHeader::kVersion ? CodecError::Kind::Unsupported : CodecError::Kind::Corrupt,
         "unknown blob version " + std::to_string(version));
  }
  h.mode = bytes[pos + 1];
  h.flags = bytes[pos + 2];
  h.width = bytes[pos + 3];
  pos += 4;
  h.rows = get_le<std::uint64_t>(bytes, size, pos);
  h.vertex_count = get_le<std::uint32_t>(bytes, size, pos);
  if (h.width != width) corrupt("blob width differs from the expected comps/per_row");
  if (h.rows != rows) corrupt("blob row count differs from the expected rows");
  if (h.vertex_count != vertex_count) corrupt("blob vertex count differs from the expected one");
  return h;
}

void put_f64(std::vector<std::uint8_t>& out, double v) { put_le<double>(out, v); }
double get_f64(const std::uint8_t* bytes, std::size_t size, std::size_t& pos) {
  return get_le<double>(bytes, size, pos);
}
void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) { put_le<std::uint32_t>(out, v); }
std::uint32_t get_u32(const std::uint8_t* bytes, std::size_t size, std::size_t& pos) {
  return get_le<std::uint32_t>(bytes, size, pos);
}
void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v) { put_le<std::uint64_t>(out, v); }
std::uint64_t get_u64(const std::uint8_t* bytes, std::size_t size, std::size_t& pos) {
  return get_le<std::uint64_t>(bytes, size, pos);
}

double max_abs_value(const float* v, std::size_t n) {
  float m = 0.f;
  for (std::size_t i = 0; i < n; ++i) m = std::max(m, std::fabs(v[i]));
  return m;
}

// Why the bound of FloatParams holds. Let e = max_abs_error, M = max |v|, s = step = 2 m (1 -
// 2^-18) with m <= e, and |q| <= 2^31 - 2 (quantize() rejects more).
//  - Encoding: t = fl(fl(v - ref) * fl(1/s)) has relative error < 3 * 2^-53, so |t - (v - ref)/s|
//    < 3 * 2^-53 * 2^31 < 2^-21 and |ref + q s - v| <= s (1/2 + 2^-21) <= m (1 - 3 * 2^-20).
//  - Decoding: q * s (|q s| < 2^32 e) and ref + q s are rounded in double: errors below
//    2^-53 * 2^32 e = 2^-21 e and 2^-53 (|v| + e). So the double D has |D - v| <=
//    m (1 - 3 * 2^-20) + 2^-21 e + 2^-53 (|v| + e) <= m + 2^-53 (|v| + e), as m >= e/2.
//  - Rounding D to float32 adds at most 2^-24 |D| <= 2^-24 (|v| + e) (or 2^-150 in the
//    subnormal range, below the 2^-20 m slack since m >= e/2 >= 2^-127).
// With m = e: |d - v| <= e + 2^-23 (|v| + e), the second case. With m = e - 2^-23 (M + e) (the
// strict case, where that keeps m >= e/2): |d - v| <= e - 2^-23 (M + e) + 2^-24 (1 + 2^-28)
// (M + e) < e.
double quant_step(double max_abs_error, double max_abs) {
  double m = max_abs_error;
  if (strict_error_bound(max_abs_error, max_abs)) m -= 0x1p-23 * (max_abs + max_abs_error);
  return 2.0 * m * (1.0 - 0x1p-18);
}

void quantize(const float* data, const float* ref, std::size_t n, double step, std::int32_t* q) {
  const double inv = 1.0 / step;
  constexpr double kLimit = 2147483646.0;  // |q| <= 2^31 - 2, so deltas wrap safely mod 2^32
  for (std::size_t i = 0; i < n; ++i) {
    const double d = static_cast<double>(data[i]) - (ref ? static_cast<double>(ref[i]) : 0.0);
    const double t = d * inv;
    if (!(std::fabs(t) <= kLimit)) {
      invalid("lossy value too far from its reference for max_abs_error (int32 overflow)");
    }
    q[i] = static_cast<std::int32_t>(std::lrint(t));
  }
}

void dequantize(const std::int32_t* q, const float* ref, std::size_t n, double step, float* out) {
  if (ref) {
    for (std::size_t i = 0; i < n; ++i) out[i] = dequantize_one(q[i], ref[i], step);
  } else {
    for (std::size_t i = 0; i < n; ++i) out[i] = dequantize_one(q[i], 0.0, step);
  }
}

void bits_residual(const float* data, const float* ref, std::size_t n, std::uint32_t* r) {
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t b;
    std::memcpy(&b, &data[i], 4);
    if (ref) {
      std::uint32_t rb;
      std::memcpy(&rb, &ref[i], 4);
      b -= rb;
    }
    r[i] = b;
  }
}

// The finiteness tests below accumulate `exponent all ones` into one flag in the loop that writes
// the value, so the array is not read a second time, and the flag, not a branch, keeps the loops
// vectorizable. GCC vectorizes at -O2 only loops whose trip count it knows: the work is done in
// blocks of kBlock values plus a tail.
namespace {
constexpr std::size_t kBlock = 64;

inline std::uint32_t is_non_finite(std::uint32_t bits) {
  return static_cast<std::uint32_t>((bits & kFloatExponentMask) == kFloatExponentMask);
}

template <std::size_t L>
std::uint32_t unresidual_block(const std::uint32_t* __restrict r, const float* __restrict ref,
                               float* __restrict out) {
  std::uint32_t bad = 0;
  for (std::size_t i = 0; i < L; ++i) {
    std::uint32_t b = r[i];
    if (ref) {
      std::uint32_t rb;
      std::memcpy(&rb, &ref[i], 4);
      b += rb;
    }
    bad |= is_non_finite(b);
    std::memcpy(&out[i], &b, 4);
  }
  return bad;
}

template <std::size_t L>
std::uint32_t copy_block(const std::uint8_t* __restrict in, float* __restrict out) {
  std::uint32_t bad = 0;
  for (std::size_t i = 0; i < L; ++i) {
    std::uint32_t b;
    std::memcpy(&b, in + 4 * i, 4);
    bad |= is_non_finite(b);
    std::memcpy(&out[i], &b, 4);
  }
  return bad;
}

template <std::size_t L>
std::uint32_t check_block(const float* __restrict v) {
  std::uint32_t bad = 0;
  for (std::size_t i = 0; i < L; ++i) {
    std::uint32_t b;
    std::memcpy(&b, &v[i], 4);
    bad |= is_non_finite(b);
  }
  return bad;
}
}  // namespace

bool bits_unresidual(const std::uint32_t* r, const float* ref, std::size_t n, float* out) {
  std::uint32_t bad = 0;
  std::size_t i = 0;
  if (ref) {
    for (; i + kBlock <= n; i += kBlock) bad |= unresidual_block<kBlock>(r + i, ref + i, out + i);
    for (; i < n; ++i) bad |= unresidual_block<1>(r + i, ref + i, out + i);
  } else {
    for (; i + kBlock <= n; i += kBlock) bad |= unresidual_block<kBlock>(r + i, nullptr, out + i);
    for (; i < n; ++i) bad |= unresidual_block<1>(r + i, nullptr, out + i);
  }
  return bad == 0;
}

bool copy_floats_finite(const std::uint8_t* bytes, std::size_t n, float* out) {
  std::uint32_t bad = 0;
  std::size_t i = 0;
  for (; i + kBlock <= n; i += kBlock) bad |= copy_block<kBlock>(bytes + 4 * i, out + i);
  for (; i < n; ++i) bad |= copy_block<1>(bytes + 4 * i, out + i);
  return bad == 0;
}

bool all_finite(const float* v, std::size_t n) {
  std::uint32_t bad = 0;
  std::size_t i = 0;
  for (; i + kBlock <= n; i += kBlock) bad |= check_block<kBlock>(v + i);
  for (; i < n; ++i) bad |= check_block<1>(v + i);
  return bad == 0;
}

void check_float_args(const float* data, std::size_t rows, int comps, const float* reference,
                      const FloatParams& params) {
  if (comps < 1 || comps > kMaxComps) {
    invalid("comps must be in 1.." + std::to_string(kMaxComps) + ", got " + std::to_string(comps));
  }
  if (rows > std::numeric_limits<std::size_t>::max() / (4u * kMaxComps)) invalid("rows too large");
  if (rows > 0 && data == nullptr) invalid("data is null");
  const double e = params.max_abs_error;
  if (!(e == 0.0 || (e >= FLT_MIN && e <= kMaxLossyMagnitude))) {
    invalid("max_abs_error must be 0 (lossless) or in [FLT_MIN, 2^126]");
  }
  if (e > 0.0) {
    const std::size_t n = rows * static_cast<std::size_t>(comps);
    check_lossy_values(data, n, "data");
    if (reference) check_lossy_values(reference, n, "reference");
  }
}

void check_index_args(const std::uint32_t* idx, std::size_t rows, int per_row,
                      std::uint32_t vertex_count) {
  if (per_row != 3 && per_row != 4) {
    invalid("per_row must be 3 (triangles) or 4 (tets), got " + std::to_string(per_row));
  }
  if (rows > std::numeric_limits<std::size_t>::max() / 16u) invalid("rows too large");
  if (rows > 0 && idx == nullptr) invalid("idx is null");
  const std::size_t n = rows * static_cast<std::size_t>(per_row);
  for (std::size_t i = 0; i < n; ++i) {
    if (idx[i] >= vertex_count) {
      invalid("index " + std::to_string(idx[i]) + " at " + std::to_string(i) + " >= vertex_count " +
              std::to_string(vertex_count));
    }
  }
}

void check_decoded_indices(const std::uint32_t* idx, std::size_t n, std::uint32_t vertex_count) {
  std::uint32_t bad = 0;  // branch-free scan; the message is built only on failure
  for (std::size_t i = 0; i < n; ++i) bad |= static_cast<std::uint32_t>(idx[i] >= vertex_count);
  if (bad) corrupt("decoded index >= vertex_count");
}

}  // namespace detail

namespace {
using detail::corrupt;

void check_decode_shape_floats(const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                               int comps, float* out) {
  if (comps < 1 || comps > kMaxComps) {
    detail::fail(CodecError::Kind::InvalidArgument, "comps must be in 1..64");
  }
  if (rows > std::numeric_limits<std::size_t>::max() / (4u * kMaxComps)) {
    detail::fail(CodecError::Kind::InvalidArgument, "rows too large");
  }
  if (size > 0 && bytes == nullptr) detail::fail(CodecError::Kind::InvalidArgument, "null bytes");
  if (rows > 0 && out == nullptr) detail::fail(CodecError::Kind::InvalidArgument, "null out");
}

void check_decode_shape_indices(const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                                int per_row, std::uint32_t* out) {
  if (per_row != 3 && per_row != 4) {
    detail::fail(CodecError::Kind::InvalidArgument, "per_row must be 3 or 4");
  }
  if (rows > std::numeric_limits<std::size_t>::max() / 16u) {
    detail::fail(CodecError::Kind::InvalidArgument, "rows too large");
  }
  if (size > 0 && bytes == nullptr) detail::fail(CodecError::Kind::InvalidArgument, "null bytes");
  if (rows > 0 && out == nullptr) detail::fail(CodecError::Kind::InvalidArgument, "null out");
}

[[noreturn]] void unknown_codec(Codec c) {
  detail::fail(CodecError::Kind::Unsupported,
               "unknown codec " + std::to_string(static_cast<unsigned>(c)));
}
}  // namespace

std::vector<std::uint8_t> encode_floats(Codec c, const float* data, std::size_t rows, int comps,
                                        const float* reference, const FloatParams& params) {
  detail::check_float_args(data, rows, comps, reference, params);
  const double e = params.max_abs_error;
  switch (c) {
    case Codec::Raw: {
      const std::size_t n = rows * static_cast<std::size_t>(comps) * 4u;
      std::vector<std::uint8_t> out(n);
      if (n) std::memcpy(out.data(), data, n);
      return out;
    }
    case Codec::QuantDeltaZstd:
      return detail::qdz_encode_floats(data, rows, comps, reference, e);
    case Codec::Meshopt:
      return detail::meshopt_encode_floats(data, rows, comps, reference, e);
    case Codec::Draco:
      return detail::draco_encode_floats(data, rows, comps, reference, e);
  }
  unknown_codec(c);
}

void decode_floats(Codec c, const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                   int comps, const float* reference, float* out) {
  check_decode_shape_floats(bytes, size, rows, comps, out);
  switch (c) {
    case Codec::Raw: {
      const std::size_t n = rows * static_cast<std::size_t>(comps) * 4u;
      if (size != n) corrupt("raw blob size differs from rows * comps * 4");
      if (n) std::memcpy(out, bytes, n);
      return;
    }
    case Codec::QuantDeltaZstd:
      detail::qdz_decode_floats(bytes, size, rows, comps, reference, out);
      return;
    case Codec::Meshopt:
      detail::meshopt_decode_floats(bytes, size, rows, comps, reference, out);
      return;
    case Codec::Draco:
      detail::draco_decode_floats(bytes, size, rows, comps, reference, out);
      return;
  }
  unknown_codec(c);
}

bool decode_floats_finite(Codec c, const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                          int comps, const float* reference, float* out) {
  check_decode_shape_floats(bytes, size, rows, comps, out);
  switch (c) {
    case Codec::Raw: {
      const std::size_t n = rows * static_cast<std::size_t>(comps);
      if (size != n * 4u) corrupt("raw blob size differs from rows * comps * 4");
      return detail::copy_floats_finite(bytes, n, out);
    }
    case Codec::QuantDeltaZstd:
      return detail::qdz_decode_floats(bytes, size, rows, comps, reference, out);
    case Codec::Meshopt:
      return detail::meshopt_decode_floats(bytes, size, rows, comps, reference, out);
    case Codec::Draco:
      return detail::draco_decode_floats(bytes, size, rows, comps, reference, out);
  }
  unknown_codec(c);
}

std::vector<std::uint8_t> encode_indices(Codec c, const std::uint32_t* idx, std::size_t rows,
                                         int per_row, std::uint32_t vertex_count) {
  detail::check_index_args(idx, rows, per_row, vertex_count);
  switch (c) {
    case Codec::Raw: {
      const std::size_t n = rows * static_cast<std::size_t>(per_row) * 4u;
      std::vector<std::uint8_t> out(n);
      if (n) std::memcpy(out.data(), idx, n);
      return out;
    }
    case Codec::QuantDeltaZstd:
      return detail::qdz_encode_indices(idx, rows, per_row, vertex_count);
    case Codec::Meshopt:
      return detail::meshopt_encode_indices(idx, rows, per_row, vertex_count);
    case Codec::Draco:
      return detail::draco_encode_indices(idx, rows, per_row, vertex_count);
  }
  unknown_codec(c);
}

void decode_indices(Codec c, const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                    int per_row, std::uint32_t vertex_count, std::uint32_t* out) {
  check_decode_shape_indices(bytes, size, rows, per_row, out);
  switch (c) {
    case Codec::Raw: {
      const std::size_t n = rows * static_cast<std::size_t>(per_row);
      if (size != n * 4u) corrupt("raw blob size differs from rows * per_row * 4");
      if (n) std::memcpy(out, bytes, n * 4u);
      detail::check_decoded_indices(out, n, vertex_count);
      return;
    }
    case Codec::QuantDeltaZstd:
      return detail::qdz_decode_indices(bytes, size, rows, per_row, vertex_count, out);
    case Codec::Meshopt:
      return detail::meshopt_decode_indices(bytes, size, rows, per_row, vertex_count, out);
    case Codec::Draco:
      return detail::draco_decode_indices(bytes, size, rows, per_row, vertex_count, out);
  }
  unknown_codec(c);
}

}  // namespace cadinterp::format
