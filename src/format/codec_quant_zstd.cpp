// Codec::QuantDeltaZstd: integers per value, delta to the previous row per component, zigzag,
// byte-plane shuffle (plane b holds byte b of every value, components one after another), zstd
// level 3.
//   lossless floats: float bits minus the reference's bits (mod 2^32), or the bits;
//   lossy floats:    q = round((v - ref) / step), int32 (codec.cpp: quantize);
//   indices:         the rows * per_row indices as one column (delta to the previous index).
//
// Blob: BlobHeader (mode lossless / lossy / indices, flags kFlagReference | kFlagRowDelta),
// f64 step if lossy, then exactly one zstd frame with its content size, rows * width * 4 bytes.
// Measured alternatives (irregular 100k-vertex mesh): no delta costs 4-12 % more, a second-order
// delta 5-12 % more (it wins only on a perfectly regular grid); without the byte shuffle 25-90 %
// more; zstd level 6-9 saves 1-3 % for half the speed.
#include <zstd.h>

#include <cstring>
#include <memory>

#include "format/codec.h"

namespace cadinterp::format::detail {
namespace {

constexpr int kZstdLevel = 3;
constexpr std::uint8_t kFlagRowDelta = 2;  // values are deltas to the previous row

struct CCtxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxFree {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

// One context per thread: creating one costs more than compressing a small blob.
ZSTD_CCtx* cctx() {
  thread_local std::unique_ptr<ZSTD_CCtx, CCtxFree> c(ZSTD_createCCtx());
  if (!c) throw std::bad_alloc();
  return c.get();
}
ZSTD_DCtx* dctx() {
  thread_local std::unique_ptr<ZSTD_DCtx, DCtxFree> d(ZSTD_createDCtx());
  if (!d) throw std::bad_alloc();
  return d.get();
}

inline std::uint32_t zigzag(std::uint32_t v) {
  return (v << 1) ^ (0u - (v >> 31));  // == (int32 << 1) ^ (int32 >> 31), without signed shifts
}
inline std::uint32_t unzigzag(std::uint32_t u) { return (u >> 1) ^ (0u - (u & 1u)); }

// v: rows x width row-major words. Writes 4 byte planes of rows * width bytes each.
void shuffle(const std::uint32_t* v, std::size_t rows, int width, bool row_delta,
             std::uint8_t* planes) {
  const std::size_t n = rows * static_cast<std::size_t>(width);
  std::uint8_t* p0 = planes;
  std::uint8_t* p1 = planes + n;
  std::uint8_t* p2 = planes + 2 * n;
  std::uint8_t* p3 = planes + 3 * n;
  std::size_t k = 0;
  for (int c = 0; c < width; ++c) {
    std::uint32_t prev = 0;
    for (std::size_t i = 0; i < rows; ++i, ++k) {
      const std::uint32_t x = v[i * width + c];
      const std::uint32_t u = zigzag(row_delta ? x - prev : x);
      prev = x;
      p0[k] = static_cast<std::uint8_t>(u);
      p1[k] = static_cast<std::uint8_t>(u >> 8);
      p2[k] = static_cast<std::uint8_t>(u >> 16);
      p3[k] = static_cast<std::uint8_t>(u >> 24);
    }
  }
}

// Inverse of shuffle(): calls f(k, word) for every word k = i * width + c of the rows x width
// array, component by component (so f writes with stride `width`).
template <typename F>
void unshuffle_each(const std::uint8_t* planes, std::size_t rows, int width, bool row_delta,
                    F&& f) {
  const std::size_t n = rows * static_cast<std::size_t>(width);
  const std::uint8_t* p0 = planes;
  const std::uint8_t* p1 = planes + n;
  const std::uint8_t* p2 = planes + 2 * n;
  const std::uint8_t* p3 = planes + 3 * n;
  std::size_t k = 0;
  for (int c = 0; c < width; ++c) {
    std::uint32_t prev = 0;
    const std::uint32_t keep = row_delta ? ~0u : 0u;  // branch-free: prev is 0 without delta
    for (std::size_t i = 0; i < rows; ++i, ++k) {
      const std::uint32_t u =
          static_cast<std::uint32_t>(p0[k]) | (static_cast<std::uint32_t>(p1[k]) << 8) |
          (static_cast<std::uint32_t>(p2[k]) << 16) | (static_cast<std::uint32_t>(p3[k]) << 24);
      const std::uint32_t x = (prev & keep) + unzigzag(u);
      prev = x;
      f(i * width + c, x);
    }
  }
}

// Appends header, [step], zstd(shuffle(words)) to a new blob.
std::vector<std::uint8_t> pack(const BlobHeader& h, const double* step, const std::uint32_t* words,
                               std::size_t rows, int width) {
  const std::size_t nbytes = rows * static_cast<std::size_t>(width) * 4u;
  std::vector<std::uint8_t> planes(nbytes);
  shuffle(words, rows, width, (h.flags & kFlagRowDelta) != 0, planes.data());

  std::vector<std::uint8_t> out;
  write_header(out, h);
  if (step) put_f64(out, *step);
  const std::size_t head = out.size();
  out.resize(head + ZSTD_compressBound(nbytes));
  ZSTD_CCtx* c = cctx();
  ZSTD_CCtx_reset(c, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(c, ZSTD_c_compressionLevel, kZstdLevel);
  ZSTD_CCtx_setParameter(c, ZSTD_c_contentSizeFlag, 1);
  const std::size_t z =
      ZSTD_compress2(c, out.data() + head, out.size() - head, planes.data(), nbytes);
  if (ZSTD_isError(z)) {
    throw std::runtime_error(std::string("zstd compression failed: ") + ZSTD_getErrorName(z));
  }
  out.resize(head + z);
  return out;
}

// Decompresses the single zstd frame at bytes[pos, size) into the byte planes of a rows x width
// array; returns them (a per-thread buffer, valid until the next call on this thread).
const std::uint8_t* decompress_planes(const std::uint8_t* bytes, std::size_t size, std::size_t pos,
                                      std::size_t rows, int width) {
  const std::size_t nbytes = rows * static_cast<std::size_t>(width) * 4u;
  const std::uint8_t* src = bytes + pos;
  const std::size_t src_size = size - pos;
  const unsigned long long content = ZSTD_getFrameContentSize(src, src_size);
  if (content == ZSTD_CONTENTSIZE_ERROR || content == ZSTD_CONTENTSIZE_UNKNOWN) {
    corrupt("zstd frame header is invalid or lacks the content size");
  }
  if (content != nbytes) corrupt("zstd frame content size differs from rows * width * 4");
  const std::size_t frame = ZSTD_findFrameCompressedSize(src, src_size);
  if (ZSTD_isError(frame) || frame != src_size) {
    corrupt("blob is not exactly one zstd frame");
  }
  // Scratch per thread: decoding is on the runtime's hot path; the buffer keeps the size of the
  // largest array this thread decoded.
  thread_local std::vector<std::uint8_t> planes;
  if (planes.size() < nbytes) planes.resize(nbytes);
  const std::size_t got = ZSTD_decompressDCtx(dctx(), planes.data(), nbytes, src, src_size);
  if (ZSTD_isError(got)) corrupt(std::string("zstd: ") + ZSTD_getErrorName(got));
  if (got != nbytes) corrupt("zstd frame decoded to a wrong size");
  return planes.data();
}

}  // namespace

std::vector<std::uint8_t> qdz_encode_floats(const float* data, std::size_t rows, int comps,
                                            const float* reference, double max_abs_error) {
  const std::size_t n = rows * static_cast<std::size_t>(comps);
  BlobHeader h;
  h.width = static_cast<std::uint8_t>(comps);
  h.rows = rows;
  h.flags = static_cast<std::uint8_t>((reference ? kFlagReference : 0) | kFlagRowDelta);
  if (max_abs_error == 0.0) {
    h.mode = kModeLossless;
    std::vector<std::uint32_t> words(n);
    bits_residual(data, reference, n, words.data());
    return pack(h, nullptr, words.data(), rows, comps);
  }
  h.mode = kModeLossy;
  const double step = quant_step(max_abs_error, max_abs_value(data, n));
  std::vector<std::int32_t> q(n);
  quantize(data, reference, n, step, q.data());
  // int32 storage read as uint32: the unsigned variant of a type may alias it.
  return pack(h, &step, reinterpret_cast<const std::uint32_t*>(q.data()), rows, comps);
}

bool qdz_decode_floats(const std::uint8_t* bytes, std::size_t size, std::size_t rows, int comps,
                       const float* reference, float* out) {
  std::size_t pos = 0;
  const BlobHeader h =
      read_header(bytes, size, pos, static_cast<std::uint8_t>(comps), rows, /*vertex_count=*/0);
  if (h.mode != kModeLossless && h.mode != kModeLossy) corrupt("not a float blob");
  if (h.flags & ~(kFlagReference | kFlagRowDelta)) corrupt("unknown flags");
  const float* ref = (h.flags & kFlagReference) ? reference : nullptr;
  if ((h.flags & kFlagReference) && !reference) {
    fail(CodecError::Kind::InvalidArgument, "blob was coded against a reference; none given");
  }
  double step = 0.0;
  if (h.mode == kModeLossy) {
    step = get_f64(bytes, size, pos);
    if (!(step > 0.0 && step <= 0x1p128)) corrupt("invalid quantization step");
  }
  const std::uint8_t* planes = decompress_planes(bytes, size, pos, rows, comps);
  const bool delta = (h.flags & kFlagRowDelta) != 0;
  // One pass from the planes to `out`, the reference test hoisted out of the loop. Lossless bits
  // are tested for inf/NaN as they are stored; lossy values are finite by construction
  // (decode_floats_finite).
  if (h.mode == kModeLossless) {
    std::uint32_t bad = 0;
    auto put = [out, &bad](std::size_t k, std::uint32_t b) {
      bad |= static_cast<std::uint32_t>((b & kFloatExponentMask) == kFloatExponentMask);
      std::memcpy(&out[k], &b, 4);
    };
    if (ref) {
      unshuffle_each(planes, rows, comps, delta, [&](std::size_t k, std::uint32_t x) {
        std::uint32_t rb;
        std::memcpy(&rb, &ref[k], 4);
        put(k, x + rb);
      });
    } else {
      unshuffle_each(planes, rows, comps, delta, put);
    }
    return bad == 0;
  }
  if (ref) {
    unshuffle_each(planes, rows, comps, delta, [&](std::size_t k, std::uint32_t x) {
      out[k] = dequantize_one(static_cast<std::int32_t>(x), ref[k], step);
    });
  } else {
    unshuffle_each(planes, rows, comps, delta, [&](std::size_t k, std::uint32_t x) {
      out[k] = dequantize_one(static_cast<std::int32_t>(x), 0.0, step);
    });
  }
  return true;
}

std::vector<std::uint8_t> qdz_encode_indices(const std::uint32_t* idx, std::size_t rows,
                                             int per_row, std::uint32_t vertex_count) {
  BlobHeader h;
  h.mode = kModeIndices;
  h.flags = kFlagRowDelta;
  h.width = static_cast<std::uint8_t>(per_row);
  h.rows = rows;
  h.vertex_count = vertex_count;
  // One stream in row-major order, each index minus the previous one: consecutive tets and
  // triangles share vertices across their corners, which per-corner columns miss (measured on a
  // renumbered tet mesh: 3.5 vs 4.2 bytes per tet, 1.7 vs 2.8 per triangle).
  return pack(h, nullptr, idx, rows * static_cast<std::size_t>(per_row), 1);
}

void qdz_decode_indices(const std::uint8_t* bytes, std::size_t size, std::size_t rows, int per_row,
                        std::uint32_t vertex_count, std::uint32_t* out) {
  std::size_t pos = 0;
  const BlobHeader h =
      read_header(bytes, size, pos, static_cast<std::uint8_t>(per_row), rows, vertex_count);
  if (h.mode != kModeIndices) corrupt("not an index blob");
  if (h.flags & ~kFlagRowDelta) corrupt("unknown flags");
  const std::size_t n = rows * static_cast<std::size_t>(per_row);
  const std::uint8_t* planes = decompress_planes(bytes, size, pos, n, 1);
  // The range check rides along in the output loop rather than re-reading `out`.
  std::uint32_t bad = 0;
  unshuffle_each(planes, n, 1, (h.flags & kFlagRowDelta) != 0,
                 [out, &bad, vertex_count](std::size_t k, std::uint32_t x) {
                   bad |= static_cast<std::uint32_t>(x >= vertex_count);
                   out[k] = x;
                 });
  if (bad) corrupt("decoded index >= vertex_count");
}

}  // namespace cadinterp::format::detail
