// Codec::Meshopt: meshoptimizer 0.18's vertex, index and index-sequence codecs.
//
// Float blob: BlobHeader (mode lossless / lossy, flags kFlagReference), f64 step if lossy, then
// meshopt_encodeVertexBuffer of the rows x comps uint32 words (vertex size comps * 4 bytes):
// lossless: float bits minus reference bits; lossy: the int32 quantized residual, two's
// complement (meshopt's own byte deltas handle the sign better than a zigzag: measured 0.30 vs
// 0.32 of raw size on positions, 0.09 vs 0.13 on a sample against its reference).
// Triangle blob: BlobHeader, u64 n = size of the meshopt index buffer, its n bytes, and if
// kFlagRotations a zstd frame of one byte per triangle (0..2): the encoder may rotate a
// triangle's corners (keeping the winding), and the byte says how to rotate them back.
// Tet blob: BlobHeader, meshopt_encodeIndexSequence of the rows * 4 indices.
#include <meshoptimizer.h>
#include <zstd.h>

#include <cstring>

#include "format/codec.h"

static_assert(MESHOPTIMIZER_VERSION >= 180, "meshoptimizer 0.18 or newer");

namespace cadinterp::format::detail {
namespace {

constexpr std::uint8_t kFlagRotations = 2;

}  // namespace

std::vector<std::uint8_t> meshopt_encode_floats(const float* data, std::size_t rows, int comps,
                                                const float* reference, double max_abs_error) {
  const std::size_t n = rows * static_cast<std::size_t>(comps);
  BlobHeader h;
  h.width = static_cast<std::uint8_t>(comps);
  h.rows = rows;
  h.flags = reference ? kFlagReference : 0;
  std::vector<std::uint32_t> words(n);
  double step = 0.0;
  if (max_abs_error == 0.0) {
    h.mode = kModeLossless;
    bits_residual(data, reference, n, words.data());
  } else {
    h.mode = kModeLossy;
    step = quant_step(max_abs_error, max_abs_value(data, n));
    std::vector<std::int32_t> q(n);
    quantize(data, reference, n, step, q.data());
    if (n) std::memcpy(words.data(), q.data(), n * 4u);
  }
  std::vector<std::uint8_t> out;
  write_header(out, h);
  if (h.mode == kModeLossy) put_f64(out, step);
  if (rows == 0) return out;
  const std::size_t vsize = static_cast<std::size_t>(comps) * 4u;
  const std::size_t head = out.size();
  out.resize(head + meshopt_encodeVertexBufferBound(rows, vsize));
  const std::size_t m =
      meshopt_encodeVertexBuffer(out.data() + head, out.size() - head, words.data(), rows, vsize);
  if (m == 0) throw std::runtime_error("meshopt_encodeVertexBuffer failed");
  out.resize(head + m);
  return out;
}

bool meshopt_decode_floats(const std::uint8_t* bytes, std::size_t size, std::size_t rows, int comps,
                           const float* reference, float* out) {
  std::size_t pos = 0;
  const BlobHeader h = read_header(bytes, size, pos, static_cast<std::uint8_t>(comps), rows, 0);
  if (h.mode != kModeLossless && h.mode != kModeLossy) corrupt("not a float blob");
  if (h.flags & ~kFlagReference) corrupt("unknown flags");
  if ((h.flags & kFlagReference) && !reference) {
    fail(CodecError::Kind::InvalidArgument, "blob was coded against a reference; none given");
  }
  const float* ref = (h.flags & kFlagReference) ? reference : nullptr;
  double step = 0.0;
  if (h.mode == kModeLossy) {
    step = get_f64(bytes, size, pos);
    if (!(step > 0.0 && step <= 0x1p128)) corrupt("invalid quantization step");
  }
  if (rows == 0) {
    if (pos != size) corrupt("trailing bytes");
    return true;
  }
  const std::size_t n = rows * static_cast<std::size_t>(comps);
  thread_local std::vector<std::uint32_t> words;
  if (words.size() < n) words.resize(n);
  // comps <= 64 keeps the vertex size within meshopt's 256-byte limit (asserted, not checked,
  // by the library).
  const int rc = meshopt_decodeVertexBuffer(
      words.data(), rows, static_cast<std::size_t>(comps) * 4u, bytes + pos, size - pos);
  if (rc != 0) corrupt("meshopt vertex decoder error " + std::to_string(rc));
  if (h.mode == kModeLossless) return bits_unresidual(words.data(), ref, n, out);
  // Finite by construction (decode_floats_finite).
  dequantize(reinterpret_cast<const std::int32_t*>(words.data()), ref, n, step, out);
  return true;
}

std::vector<std::uint8_t> meshopt_encode_indices(const std::uint32_t* idx, std::size_t rows,
                                                 int per_row, std::uint32_t vertex_count) {
  const std::size_t n = rows * static_cast<std::size_t>(per_row);
  BlobHeader h;
  h.mode = kModeIndices;
  h.width = static_cast<std::uint8_t>(per_row);
  h.rows = rows;
  h.vertex_count = vertex_count;
  std::vector<std::uint8_t> out;
  if (per_row == 4) {
    write_header(out, h);
    const std::size_t head = out.size();
    out.resize(head + meshopt_encodeIndexSequenceBound(n, vertex_count));
    const std::size_t m = meshopt_encodeIndexSequence(out.data() + head, out.size() - head, idx, n);
    if (m == 0) throw std::runtime_error("meshopt_encodeIndexSequence failed");
    out.resize(head + m);
    return out;
  }
  std::vector<std::uint8_t> enc(meshopt_encodeIndexBufferBound(n, vertex_count));
  enc.resize(meshopt_encodeIndexBuffer(enc.data(), enc.size(), idx, n));
  if (enc.empty()) throw std::runtime_error("meshopt_encodeIndexBuffer failed");
  // Find how the encoder rotated each triangle: decoded (a, b, c) is one of the rotations of the
  // original (a, b, c), (b, c, a), (c, a, b).
  std::vector<std::uint32_t> dec(n);
  if (meshopt_decodeIndexBuffer(dec.data(), n, 4, enc.data(), enc.size()) != 0) {
    throw std::runtime_error("meshopt index buffer does not decode");
  }
  std::vector<std::uint8_t> rot(rows, 0);
  bool any = false;
  for (std::size_t t = 0; t < rows; ++t) {
    const std::uint32_t* o = idx + 3 * t;
    const std::uint32_t* d = dec.data() + 3 * t;
    std::uint8_t r = 3;
    for (std::uint8_t s = 0; s < 3 && r == 3; ++s) {
      if (d[s] == o[0] && d[(s + 1) % 3] == o[1] && d[(s + 2) % 3] == o[2]) r = s;
    }
    if (r == 3) throw std::runtime_error("meshopt index codec changed a triangle");
    rot[t] = r;
    any = any || r != 0;
  }
  h.flags = any ? kFlagRotations : 0;
  write_header(out, h);
  put_u64(out, enc.size());
  out.insert(out.end(), enc.begin(), enc.end());
  if (any) {
    const std::size_t head = out.size();
    out.resize(head + ZSTD_compressBound(rows));
    const std::size_t z = ZSTD_compress(out.data() + head, out.size() - head, rot.data(), rows, 3);
    if (ZSTD_isError(z)) throw std::runtime_error("zstd compression failed");
    out.resize(head + z);
  }
  return out;
}

void meshopt_decode_indices(const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                            int per_row, std::uint32_t vertex_count, std::uint32_t* out) {
  const std::size_t n = rows * static_cast<std::size_t>(per_row);
  std::size_t pos = 0;
  const BlobHeader h =
      read_header(bytes, size, pos, static_cast<std::uint8_t>(per_row), rows, vertex_count);
  if (h.mode != kModeIndices) corrupt("not an index blob");
  if (per_row == 4) {
    if (h.flags != 0) corrupt("unknown flags");
    if (meshopt_decodeIndexSequence(out, n, 4, bytes + pos, size - pos) != 0) {
      corrupt("meshopt index sequence decoder error");
    }
    check_decoded_indices(out, n, vertex_count);
    return;
  }
  if (h.flags & ~kFlagRotations) corrupt("unknown flags");
  const std::uint64_t m = get_u64(bytes, size, pos);
  if (m > size - pos) corrupt("meshopt index buffer length exceeds the blob");
  if (meshopt_decodeIndexBuffer(out, n, 4, bytes + pos, static_cast<std::size_t>(m)) != 0) {
    corrupt("meshopt index buffer decoder error");
  }
  pos += static_cast<std::size_t>(m);
  check_decoded_indices(out, n, vertex_count);
  if (!(h.flags & kFlagRotations)) {
    if (pos != size) corrupt("trailing bytes");
    return;
  }
  const std::uint8_t* src = bytes + pos;
  const std::size_t src_size = size - pos;
  const unsigned long long content = ZSTD_getFrameContentSize(src, src_size);
  if (content != rows) corrupt("rotation stream has a wrong or unknown size");
  const std::size_t frame = ZSTD_findFrameCompressedSize(src, src_size);
  if (ZSTD_isError(frame) || frame != src_size) corrupt("rotation stream is not one zstd frame");
  thread_local std::vector<std::uint8_t> rot;
  if (rot.size() < rows) rot.resize(rows);
  const std::size_t got = ZSTD_decompress(rot.data(), rows, src, src_size);
  if (ZSTD_isError(got) || got != rows) corrupt("rotation stream does not decode");
  for (std::size_t t = 0; t < rows; ++t) {
    const std::uint8_t r = rot[t];
    if (r > 2) corrupt("invalid triangle rotation");
    std::uint32_t* d = out + 3 * t;
    const std::uint32_t a = d[r], b = d[(r + 1) % 3], c = d[(r + 2) % 3];
    d[0] = a;
    d[1] = b;
    d[2] = c;
  }
}

}  // namespace cadinterp::format::detail
