#include "format/asset_writer.h"

#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <unordered_map>
#include <utility>

#include "cadinterp_generated.h"

namespace cadinterp::format {

namespace {

[[noreturn]] void bad(const std::string& what) {
  throw FormatError(Status::InvalidArgument, "write_asset: " + what);
}

void put_le(std::vector<std::uint8_t>& out, std::size_t at, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i)
    out[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}

// Appends blobs to the blob section (no padding) and returns their references. Content-addressed:
// a blob whose bytes and codec equal those of a blob already stored gets that blob's reference
// (SPEC.md, "Layout"). Elements of a model whose mesh never changes combinatorics thus store
// their topology once, and the reader decodes it once; field blobs of a sample that several
// elements share (coded without a reference) are stored once too. Equal checksums are only a
// hint: the bytes are compared.
class BlobSink {
 public:
  explicit BlobSink(std::vector<std::uint8_t>& section) : file_(section) {}
  fb::BlobRef add(const std::vector<std::uint8_t>& bytes, Codec codec) {
    const std::uint64_t hash = XXH64(bytes.data(), bytes.size(), 0);
    const auto fb_codec = static_cast<fb::Codec>(codec);
    const auto [lo, hi] = stored_.equal_range(hash);
    for (auto it = lo; it != hi; ++it) {
      const fb::BlobRef& r = it->second;
      if (r.size() == bytes.size() && r.codec() == fb_codec &&
          (bytes.empty() ||
           std::memcmp(file_.data() + r.offset(), bytes.data(), bytes.size()) == 0))
        return r;
    }
    const fb::BlobRef ref(file_.size(), bytes.size(), hash, fb_codec);
    file_.insert(file_.end(), bytes.begin(), bytes.end());
    stored_.emplace(hash, ref);
    return ref;
  }

 private:
  std::vector<std::uint8_t>& file_;
  std::unordered_multimap<std::uint64_t, fb::BlobRef> stored_;  // by checksum
};

// Field values each vertex and each tet carries, summed over the field descriptors.
struct FieldSizes {
  std::size_t per_vertex = 0, per_tet = 0;
};

// Outputs: unique non-empty names, one value per sample, finite wherever a feasible element
// reads it (the reader checks the same, SPEC.md "Scalar outputs").
void check_outputs(const AssetContent& c) {
  const core::CompiledBasis::Parts& p = c.basis->parts();
  const std::size_t S = p.sample_unit.size() / static_cast<std::size_t>(p.K);
  std::vector<std::string> names;
  for (const OutputInfo& o : c.outputs) {
    if (o.name.empty() || o.name.find('\0') != std::string::npos ||
        o.unit.find('\0') != std::string::npos)
      bad("output name empty, or name or unit contains a NUL");
    if (std::find(names.begin(), names.end(), o.name) != names.end())
      bad("output '" + o.name + "' given twice");
    names.push_back(o.name);
    if (o.values.size() != S) bad("output '" + o.name + "': one value per sample needed");
    for (int e = 0; e < c.basis->element_count(); ++e) {
      if (!p.elem_feasible[static_cast<std::size_t>(e)]) continue;
      for (auto t = p.elem_term_begin[static_cast<std::size_t>(e)];
           t < p.elem_term_begin[static_cast<std::size_t>(e) + 1]; ++t)
        if (!std::isfinite(
                o.values[static_cast<std::size_t>(p.term_sample[static_cast<std::size_t>(t)])]))
          bad("output '" + o.name + "' is not finite at a sample of element " + std::to_string(e));
    }
  }
}

// Checks the content's descriptors against its basis: parameters, element count, fields,
// regions and outputs. Throws FormatError(InvalidArgument) naming the first mismatch.
FieldSizes check_content(const AssetContent& c) {
  if (!c.basis) bad("no basis");
  const core::CompiledBasis::Parts& p = c.basis->parts();
  const int K = p.K;
  if (static_cast<int>(c.parameters.size()) != K) bad("one parameter per basis direction needed");
  for (int d = 0; d < K; ++d) {
    const ParameterInfo& pi = c.parameters[static_cast<std::size_t>(d)];
    if (pi.name.empty()) bad("parameter without a name");
    if (pi.lower != p.lo[static_cast<std::size_t>(d)] ||
        pi.upper != p.hi[static_cast<std::size_t>(d)])
      bad("parameter range differs from the basis domain");
  }
  const int E = c.basis->element_count();
  if (static_cast<int>(c.elements.size()) != E) bad("one ElementData per basis element needed");
  FieldSizes sizes;
  for (const FieldInfo& f : c.fields) {
    if (f.name.empty() || f.components < 1 || f.components > kMaxComps) bad("field descriptor");
    if (f.name.find('\0') != std::string::npos || f.unit.find('\0') != std::string::npos)
      bad("field name or unit contains a NUL");
    (f.location == FieldLocation::Vertex ? sizes.per_vertex : sizes.per_tet) +=
        static_cast<std::size_t>(f.components);
  }
  for (const RegionInfo& r : c.regions)
    if (r.name.empty()) bad("boundary region without a name");
  check_outputs(c);
  return sizes;
}

// Checks element e's encoded meshes against the asset: one position array per basis term, and
// one field array per term of the descriptors' size (none when they hold no values), encoded
// with the options the asset is written with.
void check_element_meshes(const EncodedMeshes& m, std::size_t nv, int e, int terms,
                          const FieldSizes& sizes, const WriteOptions& o) {
  if (!(m.options == o)) bad("element " + std::to_string(e) + ": encoded with other write options");
  if (static_cast<int>(m.positions.size()) != terms)
    bad("element " + std::to_string(e) + ": one position array per term needed");
  const std::size_t field_size = nv * sizes.per_vertex + m.tet_count * sizes.per_tet;
  if (!(m.fields.empty() && field_size == 0) &&
      (static_cast<int>(m.fields.size()) != terms || m.field_values != field_size))
    bad("element " + std::to_string(e) + ": one field array per term of the fields' size needed");
}

// Checks element e's error model: empty (and no floors), or (1 + #fields) by (K + 1) finite
// values, a finite geometry floor >= 0 and no field floors or one finite value >= 0 per field.
void check_error_model(const AssetContent& c, const ElementData& ed, int e) {
  if (ed.error_model.empty()) {
    if (ed.geometry_floor != 0 || !ed.field_floors.empty())
      bad("element " + std::to_string(e) + ": floor without a model");
    return;
  }
  if (!ed.field_floors.empty() && ed.field_floors.size() != c.fields.size())
    bad("element " + std::to_string(e) + ": field floors size");
  for (double v : ed.field_floors)
    if (!(v >= 0) || !std::isfinite(v))
      bad("element " + std::to_string(e) + ": field floor not finite and >= 0");
  const std::size_t want = (1 + c.fields.size()) * static_cast<std::size_t>(c.basis->dim() + 1);
  if (ed.error_model.size() != want) bad("element " + std::to_string(e) + ": error model size");
  for (double v : ed.error_model)
    if (!std::isfinite(v)) bad("element " + std::to_string(e) + ": error model not finite");
  if (!(ed.geometry_floor >= 0) || !std::isfinite(ed.geometry_floor))
    bad("element " + std::to_string(e) + ": geometry floor not finite and >= 0");
}

// Element `who`'s meshes encoded as write_asset stores them (encode_element_meshes).
EncodedMeshes encode_meshes(const ElementData& ed, const WriteOptions& o, const std::string& who) {
  if (ed.encoded) bad(who + ": already encoded");
  const std::size_t nv = ed.vertex_count;
  const std::size_t ntet = ed.tets.size() / 4, ntri = ed.triangles.size() / 3;
  if (nv == 0 || ed.tets.size() % 4 || ed.triangles.size() % 3 || ed.triangle_tags.size() != ntri)
    bad(who + ": topology array sizes");
  if (ed.canonical.size() != nv * 3) bad(who + ": canonical size");
  for (const auto& a : ed.positions)
    if (a.size() != nv * 3) bad(who + ": position array size");
  if (!ed.fields.empty() && ed.fields.size() != ed.positions.size())
    bad(who + ": one field array per position array needed");
  for (const auto& a : ed.fields)
    if (a.size() != ed.fields.front().size()) bad(who + ": field array size");
  EncodedMeshes m;
  m.options = o;
  m.tet_count = static_cast<std::uint32_t>(ntet);
  m.triangle_count = static_cast<std::uint32_t>(ntri);
  m.field_values = ed.fields.empty() ? 0 : ed.fields.front().size();
  const FloatParams pos_params{o.position_max_abs_error};
  const FloatParams field_params{o.field_max_abs_error};
  // Draco has no tet codec (SPEC.md): tets fall back to the fast codec.
  const Codec tet_codec = o.index_codec == Codec::Draco ? Codec::QuantDeltaZstd : o.index_codec;
  const auto vc = static_cast<std::uint32_t>(nv);
  // Held until the asset is written, so at its size: an encoder may reserve its worst case
  // (zstd's bound, above the raw size) and keep that capacity.
  auto blob = [](Codec c, std::vector<std::uint8_t> bytes) {
    bytes.shrink_to_fit();
    return EncodedBlob{c, std::move(bytes)};
  };
  m.tets = blob(tet_codec, encode_indices(tet_codec, ed.tets.data(), ntet, 4, vc));
  m.triangles =
      blob(o.index_codec, encode_indices(o.index_codec, ed.triangles.data(), ntri, 3, vc));
  m.triangle_tags.bytes.resize(ntri * 4);
  if (ntri) std::memcpy(m.triangle_tags.bytes.data(), ed.triangle_tags.data(), ntri * 4);
  m.canonical = blob(Codec::Raw,
                     encode_floats(Codec::Raw, ed.canonical.data(), nv, 3, nullptr, FloatParams{}));
  for (const auto& a : ed.positions)
    m.positions.push_back(blob(o.float_codec, encode_floats(o.float_codec, a.data(), nv, 3,
                                                            ed.canonical.data(), pos_params)));
  for (const auto& a : ed.fields)
    m.fields.push_back(blob(
        o.float_codec, encode_floats(o.float_codec, a.data(), a.size(), 1, nullptr, field_params)));
  return m;
}

// Encodes element e's meshes into the blob section and returns its index table; an element
// without meshes (only an infeasible one may lack them) stores its error estimate alone.
flatbuffers::Offset<fb::ElementMeshes> write_element(flatbuffers::FlatBufferBuilder& fbb,
                                                     BlobSink& sink, const AssetContent& c, int e,
                                                     const WriteOptions& o,
                                                     const FieldSizes& sizes) {
  const ElementData& ed = c.elements[static_cast<std::size_t>(e)];
  int terms = 0;
  c.basis->element_samples(e, &terms);
  const std::size_t nv = ed.vertex_count;
  if (nv == 0) {
    if (c.basis->element_feasible(e))
      bad("feasible element " + std::to_string(e) + " without meshes");
    fb::ElementMeshesBuilder eb(fbb);
    eb.add_error_estimate(ed.error_estimate);
    return eb.Finish();
  }
  EncodedMeshes local;
  if (!ed.encoded) local = encode_meshes(ed, o, "element " + std::to_string(e));
  const EncodedMeshes& m = ed.encoded ? *ed.encoded : local;
  check_element_meshes(m, nv, e, terms, sizes, o);
  check_error_model(c, ed, e);
  auto add = [&](const EncodedBlob& b) { return sink.add(b.bytes, b.codec); };
  const fb::BlobRef tets = add(m.tets), tris = add(m.triangles), tags = add(m.triangle_tags),
                    canonical = add(m.canonical);
  std::vector<fb::BlobRef> pos, fields;
  for (const EncodedBlob& b : m.positions) pos.push_back(add(b));
  for (const EncodedBlob& b : m.fields) fields.push_back(add(b));
  const auto pos_v = fbb.CreateVectorOfStructs(pos);
  const auto field_v = fbb.CreateVectorOfStructs(fields);
  flatbuffers::Offset<flatbuffers::Vector<double>> model_v;
  if (!ed.error_model.empty()) model_v = fbb.CreateVector(ed.error_model);
  flatbuffers::Offset<flatbuffers::Vector<double>> floors_v;
  if (!ed.field_floors.empty()) floors_v = fbb.CreateVector(ed.field_floors);
  fb::ElementMeshesBuilder eb(fbb);
  eb.add_vertex_count(static_cast<std::uint32_t>(nv));
  eb.add_tet_count(m.tet_count);
  eb.add_triangle_count(m.triangle_count);
  eb.add_tets(&tets);
  eb.add_triangles(&tris);
  eb.add_triangle_tags(&tags);
  eb.add_positions(pos_v);
  eb.add_fields(field_v);
  eb.add_error_estimate(ed.error_estimate);
  eb.add_canonical_positions(&canonical);
  if (!ed.error_model.empty()) eb.add_error_model(model_v);
  eb.add_geometry_floor(ed.geometry_floor);  // the default, 0, is not written
  if (!ed.field_floors.empty()) eb.add_field_floors(floors_v);
  return eb.Finish();
}

// The lowest minor whose schema holds c (SPEC.md, "Versions and features"): 1.3 with outputs
// or error models, else 1.1 when a field has a unit, else 1.0.
std::uint16_t file_minor(const AssetContent& c) {
  const bool model = std::any_of(c.elements.begin(), c.elements.end(),
                                 [](const ElementData& ed) { return !ed.error_model.empty(); });
  if (!c.outputs.empty() || model) return kMinorOutputs;
  const bool unit = std::any_of(c.fields.begin(), c.fields.end(),
                                [](const FieldInfo& f) { return !f.unit.empty(); });
  return unit ? kMinorFieldUnits : 0;
}

// Builds the index around the element tables already in `fbb` and finishes the buffer.
void write_index(flatbuffers::FlatBufferBuilder& fbb, const AssetContent& c, const WriteOptions& o,
                 const std::vector<flatbuffers::Offset<fb::ElementMeshes>>& elements) {
  // format_minor is written only when non-zero (FlatBuffers omits a scalar equal to its
  // default), so files without outputs stay byte for byte minor 0 or 1 files.
  const core::CompiledBasis::Parts& p = c.basis->parts();
  const int K = p.K;
  std::vector<flatbuffers::Offset<fb::Parameter>> params;
  for (const ParameterInfo& pi : c.parameters)
    params.push_back(
        fb::CreateParameterDirect(fbb, pi.name.c_str(), pi.unit.c_str(), pi.lower, pi.upper));
  std::vector<flatbuffers::Offset<fb::FieldDesc>> fields;
  for (const FieldInfo& f : c.fields) {
    // Absent, not empty, without a unit: such a file is byte for byte a format 1.0 file.
    fields.push_back(fb::CreateFieldDescDirect(
        fbb, f.name.c_str(), static_cast<fb::FieldLocation>(f.location),
        static_cast<std::uint8_t>(f.components), static_cast<float>(o.field_max_abs_error),
        f.unit.empty() ? nullptr : f.unit.c_str()));
  }
  std::vector<flatbuffers::Offset<fb::BoundaryRegion>> regions;
  for (const RegionInfo& r : c.regions)
    regions.push_back(
        fb::CreateBoundaryRegionDirect(fbb, r.name.c_str(), r.kind.c_str(), &r.face_tags));
  const auto prov = fb::CreateProvenanceDirect(fbb, c.builder_version.c_str(), c.host.c_str(),
                                               c.options_json.c_str());
  const auto basis = fb::CreateBasisDirect(
      fbb, static_cast<std::uint8_t>(K), static_cast<std::uint8_t>(p.degree), &p.sample_unit,
      &p.node_dir, &p.node_split, &p.node_child, &p.node_elem, &p.elem_box, &p.elem_feasible,
      &p.elem_bs_begin, &p.elem_term_begin, &p.bs_centre, &p.bs_inv_width, &p.bs_col_begin,
      &p.term_sample, &p.col_term, &p.col_value);
  std::vector<flatbuffers::Offset<fb::InfeasiblePoint>> infeasible;
  for (const InfeasibleInfo& f : c.infeasible) {
    if (static_cast<int>(f.x.size()) != K) bad("infeasible point with other than K coordinates");
    for (double v : f.x)
      if (!std::isfinite(v)) bad("infeasible point not finite");
    if (f.message.find('\0') != std::string::npos) bad("infeasible message contains a NUL");
    infeasible.push_back(fb::CreateInfeasiblePointDirect(fbb, &f.x, f.message.c_str()));
  }
  std::vector<flatbuffers::Offset<fb::SampleOutput>> outputs;
  for (const OutputInfo& out : c.outputs)
    outputs.push_back(fb::CreateSampleOutputDirect(
        fbb, out.name.c_str(), out.unit.empty() ? nullptr : out.unit.c_str(), &out.values));
  // Absent, not empty, when there is none: assets without failures or outputs keep their bytes.
  // Outputs and error models are 1.3 content: such a file repeats its minor in the index
  // (SPEC.md).
  const bool with_outputs = !outputs.empty();
  const auto asset = fb::CreateAssetDirect(fbb, &params, basis, &elements, &fields, &regions, prov,
                                           static_cast<float>(o.position_max_abs_error),
                                           infeasible.empty() ? nullptr : &infeasible,
                                           file_minor(c) >= kMinorFeatures ? file_minor(c) : 0,
                                           nullptr, with_outputs ? &outputs : nullptr);
  fb::FinishAssetBuffer(fbb, asset);
}

// The file's header (SPEC.md, "Layout") for the finished index `fbb` and a blob section of
// `section_size` bytes, which follow it in that order.
std::vector<std::uint8_t> file_header(const flatbuffers::FlatBufferBuilder& fbb,
                                      std::size_t section_size, std::uint16_t minor) {
  const std::uint64_t index_offset = kHeaderSize;  // 48: 8-aligned
  std::vector<std::uint8_t> header(kHeaderSize, 0);
  std::memcpy(header.data(), kMagic, sizeof kMagic);
  put_le(header, 8, kFormatMajor, 2);
  // The lowest minor whose schema holds what this file uses (SPEC.md, "Versions and features"):
  // 1.0 readers keep opening assets without field units, and every reader from 1.2 on opens
  // those with outputs (an optional addition). No feature a reader must implement exists beyond
  // 1.0 (the list is empty), so it never writes required_features.
  put_le(header, 10, minor, 2);
  put_le(header, 12, kHeaderSize, 4);
  put_le(header, 16, kHeaderSize + fbb.GetSize() + section_size, 8);
  put_le(header, 24, index_offset, 8);
  put_le(header, 32, fbb.GetSize(), 8);
  put_le(header, 40, XXH64(fbb.GetBufferPointer(), fbb.GetSize(), 0), 8);
  return header;
}

// The file's three parts: the header, the finished index and the blob section.
struct FileParts {
  flatbuffers::FlatBufferBuilder fbb{1 << 16};
  std::vector<std::uint8_t> section, header;
};

void serialize(const AssetContent& c, const WriteOptions& o, FileParts& f) {
  const FieldSizes sizes = check_content(c);
  BlobSink sink(f.section);
  std::vector<flatbuffers::Offset<fb::ElementMeshes>> elements;
  for (int e = 0; e < c.basis->element_count(); ++e)
    elements.push_back(write_element(f.fbb, sink, c, e, o, sizes));
  write_index(f.fbb, c, o, elements);
  f.header = file_header(f.fbb, f.section.size(), file_minor(c));
}

}  // namespace

std::size_t EncodedMeshes::bytes() const {
  std::size_t n = tets.bytes.size() + triangles.bytes.size() + triangle_tags.bytes.size() +
                  canonical.bytes.size();
  for (const EncodedBlob& b : positions) n += b.bytes.size();
  for (const EncodedBlob& b : fields) n += b.bytes.size();
  return n;
}

std::size_t element_array_bytes(const ElementData& ed) {
  std::size_t n =
      4 * (ed.tets.size() + ed.triangles.size() + ed.triangle_tags.size() + ed.canonical.size());
  for (const auto& a : ed.positions) n += 4 * a.size();
  for (const auto& a : ed.fields) n += 4 * a.size();
  return n;
}

EncodedMeshes encode_element_meshes(const ElementData& ed, const WriteOptions& o) {
  return encode_meshes(ed, o, "element");
}

std::vector<std::uint8_t> write_asset(const AssetContent& c, const WriteOptions& o) {
  FileParts f;
  serialize(c, o, f);
  std::vector<std::uint8_t> file(f.header);
  file.insert(file.end(), f.fbb.GetBufferPointer(), f.fbb.GetBufferPointer() + f.fbb.GetSize());
  file.insert(file.end(), f.section.begin(), f.section.end());
  return file;
}

void check_asset_file_writable(const std::string& path) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw FormatError(Status::Io, "cannot create " + tmp + ": " + std::strerror(errno));
  std::fclose(f);
  std::remove(tmp.c_str());
}

// Written part by part, not assembled first: the blob section is most of the file, and a copy
// of it would double what writing a large asset holds.
void write_asset_file(const AssetContent& content, const WriteOptions& options,
                      const std::string& path) {
  FileParts f;
  serialize(content, options, f);
  const std::string tmp = path + ".tmp";
  std::FILE* out = std::fopen(tmp.c_str(), "wb");
  if (!out) throw FormatError(Status::Io, "cannot create " + tmp);
  auto put = [&](const void* p, std::size_t n) { return n == 0 || std::fwrite(p, 1, n, out) == n; };
  const bool ok = put(f.header.data(), f.header.size()) &&
                  put(f.fbb.GetBufferPointer(), f.fbb.GetSize()) &&
                  put(f.section.data(), f.section.size());
  if (std::fclose(out) != 0 || !ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw FormatError(Status::Io, "cannot write " + path);
  }
}

}  // namespace cadinterp::format
