// Codec::Draco: Draco 1.5.5 sequential encodings, which keep point and face order.
//
// Float blob: BlobHeader (mode lossless / lossy, flags kFlagReference), then a Draco point cloud
// (POINT_CLOUD_SEQUENTIAL_ENCODING) of `rows` points with one GENERIC float32 attribute of
// `comps` components, identity-mapped.
//   lossless: the attribute unquantized (Draco stores such floats as they are: no compression);
//             the reference is not used.
//   lossy:    the attribute holds float(v - ref) (or v), quantized by Draco with the fewest bits
//             (<= 24) for which the decoded output, ref + value in float, meets the bound of
//             FloatParams; the encoder decodes its own output to check. Draco quantizes against
//             the largest extent over the components, so one wide component costs bits for all.
// Triangle blob: BlobHeader (flags kFlagVertexMap), u32 k = number of distinct vertices used,
// [if kFlagVertexMap: u64 n, n bytes of a zstd frame of k u32 gaps between the sorted used
// vertex ids], then a Draco mesh (MESH_SEQUENTIAL_ENCODING, compressed connectivity) of k points,
// no attributes, the triangles as faces in order with ids compacted to 0..k-1. The compaction is
// needed because Draco 1.5.5's decoder rejects meshes with more than 3 points per face (a
// boundary references few of the tet mesh's vertices). Tets: Unsupported.
#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/mesh/mesh.h>
#include <draco/point_cloud/point_cloud.h>
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "format/codec.h"

namespace cadinterp::format::detail {
namespace {

// Draco accepts up to 30 bits, but it quantizes in float32 (24-bit significand), so more than 24
// bits cannot lower the error, and its encoder allocates a histogram of 2^bits words
// (ComputeShannonEntropy): 4 GiB at 30 bits.
constexpr int kMaxDracoBits = 24;
constexpr std::uint8_t kFlagVertexMap = 2;  // triangle blob holds a compact id -> vertex id map

void append_draco(std::vector<std::uint8_t>& out, const draco::EncoderBuffer& eb) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(eb.data());
  out.insert(out.end(), p, p + eb.size());
}

std::vector<std::uint8_t> encode_point_cloud(const BlobHeader& h, const float* values,
                                             std::size_t rows, int comps, int bits) {
  draco::PointCloud pc;
  pc.set_num_points(static_cast<draco::PointIndex::ValueType>(rows));
  draco::GeometryAttribute ga;
  const std::int64_t stride = static_cast<std::int64_t>(comps) * 4;
  ga.Init(draco::GeometryAttribute::GENERIC, nullptr, static_cast<std::uint8_t>(comps),
          draco::DT_FLOAT32, false, stride, 0);
  const int id =
      pc.AddAttribute(ga, true, static_cast<draco::AttributeValueIndex::ValueType>(rows));
  if (id < 0) throw std::runtime_error("draco: cannot add attribute");
  pc.attribute(id)->buffer()->Write(0, values, rows * static_cast<std::size_t>(stride));

  draco::ExpertEncoder enc(pc);
  enc.SetEncodingMethod(draco::POINT_CLOUD_SEQUENTIAL_ENCODING);
  if (bits > 0) enc.SetAttributeQuantization(id, bits);
  draco::EncoderBuffer eb;
  const draco::Status st = enc.EncodeToBuffer(&eb);
  if (!st.ok())
    throw std::runtime_error(std::string("draco point cloud encoder: ") + st.error_msg());
  std::vector<std::uint8_t> out;
  write_header(out, h);
  append_draco(out, eb);
  return out;
}

// Draco allocates from counts in its stream before reading the data they describe (a flipped
// bit in a point count asks for gigabytes), so the counts and the attribute layout are checked
// against the expected shape before the buffer reaches the Draco decoder. The layout is the one
// Draco 1.5.5 writes for our encoder settings (bitstream 2.3 point cloud, 2.2 mesh):
//   "DRACO", u8 major, u8 minor, u8 geometry type, u8 method, u16 flags, then
//   point cloud: i32 num_points, u8 num_attribute_decoders, varint num_attributes, per attribute
//                u8 type, u8 data type, u8 components, u8 normalized, varint unique id,
//                then u8 sequential decoder type per attribute;
//   mesh:        varint num_faces, varint num_points, u8 connectivity method.
class DracoPrefix {
 public:
  DracoPrefix(const std::uint8_t* p, std::size_t n) : p_(p), n_(n) {}
  std::uint8_t u8() {
    if (pos_ >= n_) corrupt("draco: truncated header");
    return p_[pos_++];
  }
  std::uint32_t u32() {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(u8()) << (8 * i);
    return v;
  }
  std::uint32_t varint() {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 35; shift += 7) {
      const std::uint8_t b = u8();
      v |= static_cast<std::uint64_t>(b & 0x7f) << shift;
      if (!(b & 0x80)) {
        if (v > 0xffffffffu) break;
        return static_cast<std::uint32_t>(v);
      }
    }
    corrupt("draco: bad varint");
  }
  void header(std::uint8_t minor, draco::EncodedGeometryType type, int method) {
    static const char kMagic[5] = {'D', 'R', 'A', 'C', 'O'};
    for (char c : kMagic) {
      if (u8() != static_cast<std::uint8_t>(c)) corrupt("draco: bad magic");
    }
    if (u8() != 2 || u8() != minor) corrupt("draco: unexpected bitstream version");
    if (u8() != static_cast<std::uint8_t>(type)) corrupt("draco: not the expected geometry type");
    if (u8() != method) corrupt("draco: unexpected encoding method");
    if (u8() != 0 || u8() != 0) corrupt("draco: unexpected flags (metadata)");
  }

 private:
  const std::uint8_t* p_;
  std::size_t n_;
  std::size_t pos_ = 0;
};

void check_point_cloud_prefix(const std::uint8_t* p, std::size_t n, std::size_t rows, int comps,
                              bool quantized) {
  DracoPrefix d(p, n);
  d.header(3, draco::POINT_CLOUD, draco::POINT_CLOUD_SEQUENTIAL_ENCODING);
  if (d.u32() != rows) corrupt("draco: point count differs from rows");
  if (d.u8() != 1) corrupt("draco: expected one attribute decoder");
  if (d.varint() != 1) corrupt("draco: expected one attribute");
  if (d.u8() != draco::GeometryAttribute::GENERIC) corrupt("draco: unexpected attribute type");
  if (d.u8() != draco::DT_FLOAT32) corrupt("draco: unexpected attribute data type");
  if (d.u8() != comps) corrupt("draco: attribute components differ from comps");
  if (d.u8() != 0) corrupt("draco: unexpected normalized attribute");
  d.varint();  // unique id
  const std::uint8_t decoder = d.u8();
  if (decoder != (quantized ? draco::SEQUENTIAL_ATTRIBUTE_ENCODER_QUANTIZATION
                            : draco::SEQUENTIAL_ATTRIBUTE_ENCODER_GENERIC)) {
    corrupt("draco: unexpected attribute decoder");
  }
}

void check_mesh_prefix(const std::uint8_t* p, std::size_t n, std::size_t rows,
                       std::uint32_t vertex_count) {
  DracoPrefix d(p, n);
  d.header(2, draco::TRIANGULAR_MESH, draco::MESH_SEQUENTIAL_ENCODING);
  if (d.varint() != rows) corrupt("draco: face count differs from rows");
  if (d.varint() != vertex_count) corrupt("draco: point count differs from vertex_count");
  if (d.u8() > 1) corrupt("draco: unknown connectivity method");
}

}  // namespace

std::vector<std::uint8_t> draco_encode_floats(const float* data, std::size_t rows, int comps,
                                              const float* reference, double max_abs_error) {
  const std::size_t n = rows * static_cast<std::size_t>(comps);
  if (rows > 0x7fffffffu) fail(CodecError::Kind::Unsupported, "draco: more than 2^31 rows");
  BlobHeader h;
  h.width = static_cast<std::uint8_t>(comps);
  h.rows = rows;
  if (max_abs_error == 0.0) {
    h.mode = kModeLossless;
    std::vector<std::uint8_t> out;
    if (rows == 0) {
      write_header(out, h);
      return out;
    }
    return encode_point_cloud(h, data, rows, comps, 0);
  }
  h.mode = kModeLossy;
  h.flags = reference ? kFlagReference : 0;
  if (rows == 0) {
    std::vector<std::uint8_t> out;
    write_header(out, h);
    return out;
  }
  std::vector<float> w(data, data + n);
  if (reference) {
    for (std::size_t i = 0; i < n; ++i) w[i] = data[i] - reference[i];
  }
  // Draco's step is extent / (2^bits - 1) with the extent the largest over the components.
  double extent = 0.0;
  for (int c = 0; c < comps; ++c) {
    float lo = w[static_cast<std::size_t>(c)], hi = lo;
    for (std::size_t i = 0; i < rows; ++i) {
      lo = std::min(lo, w[i * comps + c]);
      hi = std::max(hi, w[i * comps + c]);
    }
    extent = std::max(extent, static_cast<double>(hi) - static_cast<double>(lo));
  }
  int bits = 1;
  while (bits < kMaxDracoBits && extent / (std::ldexp(1.0, bits) - 1.0) > 2.0 * max_abs_error) {
    ++bits;
  }
  std::vector<float> check(n);
  const bool strict = strict_error_bound(max_abs_error, max_abs_value(data, n));
  for (; bits <= kMaxDracoBits; ++bits) {
    std::vector<std::uint8_t> out = encode_point_cloud(h, w.data(), rows, comps, bits);
    draco_decode_floats(out.data(), out.size(), rows, comps, reference, check.data());
    bool ok = true;
    for (std::size_t i = 0; i < n && ok; ++i) {
      const double bound = strict ? max_abs_error : float_error_bound(max_abs_error, data[i]);
      ok = std::fabs(static_cast<double>(check[i]) - static_cast<double>(data[i])) <= bound;
    }
    if (ok) return out;
  }
  fail(CodecError::Kind::Unsupported,
       "draco: max_abs_error is too small for 24-bit quantization of this array");
}

bool draco_decode_floats(const std::uint8_t* bytes, std::size_t size, std::size_t rows, int comps,
                         const float* reference, float* out) {
  std::size_t pos = 0;
  const BlobHeader h = read_header(bytes, size, pos, static_cast<std::uint8_t>(comps), rows, 0);
  if (h.mode != kModeLossless && h.mode != kModeLossy) corrupt("not a float blob");
  if (h.flags & ~kFlagReference) corrupt("unknown flags");
  if (h.mode == kModeLossless && h.flags != 0) corrupt("lossless draco blob with a reference");
  if ((h.flags & kFlagReference) && !reference) {
    fail(CodecError::Kind::InvalidArgument, "blob was coded against a reference; none given");
  }
  if (rows == 0) {
    if (pos != size) corrupt("trailing bytes");
    return true;
  }
  const std::uint8_t* p = bytes + pos;
  const std::size_t m = size - pos;
  check_point_cloud_prefix(p, m, rows, comps, h.mode == kModeLossy);
  draco::DecoderBuffer db;
  db.Init(reinterpret_cast<const char*>(p), m);
  draco::Decoder dec;
  auto res = dec.DecodePointCloudFromBuffer(&db);
  if (!res.ok()) corrupt(std::string("draco: ") + res.status().error_msg());
  if (db.remaining_size() != 0) corrupt("draco: trailing bytes");
  const draco::PointCloud& pc = *res.value();
  if (pc.num_points() != rows) corrupt("draco: point count differs from rows");
  if (pc.num_attributes() != 1) corrupt("draco: expected one attribute");
  const draco::PointAttribute* att = pc.attribute(0);
  const std::size_t stride = static_cast<std::size_t>(comps) * 4u;
  if (att == nullptr || att->data_type() != draco::DT_FLOAT32 || att->num_components() != comps ||
      att->byte_stride() != static_cast<std::int64_t>(stride) || att->byte_offset() != 0 ||
      att->buffer() == nullptr) {
    corrupt("draco: attribute of the wrong type or shape");
  }
  const std::size_t entries = att->size();
  if (att->buffer()->data_size() / stride < entries) corrupt("draco: attribute buffer too small");
  const std::uint8_t* base = att->buffer()->data();
  for (std::size_t i = 0; i < rows; ++i) {
    const std::size_t v =
        att->mapped_index(draco::PointIndex(static_cast<draco::PointIndex::ValueType>(i))).value();
    if (v >= entries) corrupt("draco: point maps outside the attribute");
    std::memcpy(out + i * comps, base + v * stride, stride);
  }
  const std::size_t n = rows * static_cast<std::size_t>(comps);
  if (h.flags & kFlagReference)
    for (std::size_t i = 0; i < n; ++i) out[i] += reference[i];
  // Lossless values pass any bits through, and a lossy float sum can overflow: scanned (Draco's
  // decode costs far more than this pass).
  return all_finite(out, n);
}

std::vector<std::uint8_t> draco_encode_indices(const std::uint32_t* idx, std::size_t rows,
                                               int per_row, std::uint32_t vertex_count) {
  if (per_row != 3) fail(CodecError::Kind::Unsupported, "draco encodes triangles only, not tets");
  if (rows > 0x1fffffffu) fail(CodecError::Kind::Unsupported, "draco: too many triangles");
  const std::size_t n = rows * 3u;
  BlobHeader h;
  h.mode = kModeIndices;
  h.width = 3;
  h.rows = rows;
  h.vertex_count = vertex_count;
  std::vector<std::uint8_t> out;
  if (rows == 0) {
    write_header(out, h);
    return out;
  }
  // Compact the referenced vertices to 0..k-1 (k <= 3 rows, as Draco's decoder demands).
  std::vector<std::uint32_t> used(idx, idx + n);
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  const auto k = static_cast<std::uint32_t>(used.size());
  const bool identity = used.back() == k - 1;  // sorted and unique: used == 0..k-1
  h.flags = identity ? 0 : kFlagVertexMap;
  write_header(out, h);
  put_u32(out, k);
  if (!identity) {
    // Gaps between consecutive used ids (first: the id itself), zstd-compressed.
    std::vector<std::uint32_t> gaps(k);
    gaps[0] = used[0];
    for (std::uint32_t i = 1; i < k; ++i) gaps[i] = used[i] - used[i - 1] - 1;
    const std::size_t head = out.size();
    out.resize(head + 8 + ZSTD_compressBound(k * 4u));
    const std::size_t z =
        ZSTD_compress(out.data() + head + 8, out.size() - head - 8, gaps.data(), k * 4u, 3);
    if (ZSTD_isError(z)) throw std::runtime_error("zstd compression failed");
    const std::uint64_t z64 = z;
    std::memcpy(out.data() + head, &z64, 8);
    out.resize(head + 8 + z);
  }
  draco::Mesh mesh;
  mesh.set_num_points(k);
  mesh.SetNumFaces(rows);
  for (std::size_t t = 0; t < rows; ++t) {
    draco::Mesh::Face f;
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t v = idx[3 * t + c];
      const auto local = identity
                             ? v
                             : static_cast<std::uint32_t>(
                                   std::lower_bound(used.begin(), used.end(), v) - used.begin());
      f[c] = draco::PointIndex(local);
    }
    mesh.SetFace(draco::FaceIndex(static_cast<draco::FaceIndex::ValueType>(t)), f);
  }
  draco::ExpertEncoder enc(mesh);
  enc.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
  // Entropy-coded index deltas. The option is not exposed by ExpertEncoder; it is read by
  // MeshSequentialEncoder::EncodeConnectivity. Without it the indices are plain 8/16/32-bit
  // words or varints.
  enc.options().SetGlobalBool("compress_connectivity", true);
  draco::EncoderBuffer eb;
  const draco::Status st = enc.EncodeToBuffer(&eb);
  if (!st.ok()) throw std::runtime_error(std::string("draco mesh encoder: ") + st.error_msg());
  append_draco(out, eb);
  return out;
}

void draco_decode_indices(const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                          int per_row, std::uint32_t vertex_count, std::uint32_t* out) {
  if (per_row != 3) fail(CodecError::Kind::Unsupported, "draco encodes triangles only, not tets");
  std::size_t pos = 0;
  const BlobHeader h = read_header(bytes, size, pos, 3, rows, vertex_count);
  if (h.mode != kModeIndices) corrupt("not an index blob");
  if (h.flags & ~kFlagVertexMap) corrupt("unknown flags");
  if (rows == 0) {
    if (pos != size || h.flags != 0) corrupt("trailing bytes");
    return;
  }
  const std::uint32_t k = get_u32(bytes, size, pos);
  if (k == 0 || k > vertex_count || k > rows * 3u) corrupt("draco: bad used-vertex count");
  thread_local std::vector<std::uint32_t> ids;  // compact id -> vertex id
  if (h.flags & kFlagVertexMap) {
    const std::uint64_t z = get_u64(bytes, size, pos);
    if (z > size - pos) corrupt("draco: vertex map exceeds the blob");
    const std::uint8_t* src = bytes + pos;
    if (ZSTD_getFrameContentSize(src, z) != k * 4ull || ZSTD_findFrameCompressedSize(src, z) != z) {
      corrupt("draco: vertex map is not one zstd frame of the expected size");
    }
    if (ids.size() < k) ids.resize(k);
    const std::size_t got = ZSTD_decompress(ids.data(), k * 4u, src, z);
    if (ZSTD_isError(got) || got != k * 4u) corrupt("draco: vertex map does not decode");
    pos += z;
    std::uint64_t v = ids[0];
    if (v >= vertex_count) corrupt("draco: vertex map out of range");
    for (std::uint32_t i = 1; i < k; ++i) {
      v += 1ull + ids[i];
      if (v >= vertex_count) corrupt("draco: vertex map out of range");
      ids[i] = static_cast<std::uint32_t>(v);
    }
  }
  const std::uint8_t* p = bytes + pos;
  const std::size_t m = size - pos;
  check_mesh_prefix(p, m, rows, k);
  // Draco 1.5.5's MeshSequentialDecoder rejects num_faces > remaining bytes / 3, which any
  // compressed connectivity below 3 bytes per face trips. The payload is decoded from a
  // zero-padded copy, and must end exactly where the padding starts.
  const std::size_t pad = rows * 3u + 16u;
  thread_local std::vector<char> padded;
  padded.assign(m + pad, 0);
  std::memcpy(padded.data(), p, m);
  draco::DecoderBuffer db;
  db.Init(padded.data(), padded.size());
  draco::Decoder dec;
  auto res = dec.DecodeMeshFromBuffer(&db);
  if (!res.ok()) corrupt(std::string("draco: ") + res.status().error_msg());
  if (db.remaining_size() != static_cast<std::int64_t>(pad)) {
    corrupt("draco: payload size differs from the mesh it holds");
  }
  const draco::Mesh& mesh = *res.value();
  if (mesh.num_faces() != rows) corrupt("draco: face count differs from rows");
  if (mesh.num_points() != k) corrupt("draco: point count differs from the used-vertex count");
  const bool map = (h.flags & kFlagVertexMap) != 0;
  for (std::size_t t = 0; t < rows; ++t) {
    const draco::Mesh::Face& f =
        mesh.face(draco::FaceIndex(static_cast<draco::FaceIndex::ValueType>(t)));
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t local = f[c].value();
      if (local >= k) corrupt("draco: face index out of range");
      out[3 * t + c] = map ? ids[local] : local;
    }
  }
  check_decoded_indices(out, rows * 3u, vertex_count);
}

}  // namespace cadinterp::format::detail
