#include "format/asset_writer.h"

#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <unordered_map>

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

// Checks the array sizes of element e's meshes (nv vertices, `terms` basis terms).
void check_element_arrays(const ElementData& ed, int e, int terms, const FieldSizes& sizes) {
  const std::size_t nv = ed.vertex_count;
  const std::size_t ntet = ed.tets.size() / 4, ntri = ed.triangles.size() / 3;
  if (ed.tets.size() % 4 || ed.triangles.size() % 3 || ed.triangle_tags.size() != ntri)
    bad("element " + std::to_string(e) + ": topology array sizes");
  if (ed.canonical.size() != nv * 3) bad("element " + std::to_string(e) + ": canonical size");
  if (static_cast<int>(ed.positions.size()) != terms)
    bad("element " + std::to_string(e) + ": one position array per term needed");
  const std::size_t field_size = nv * sizes.per_vertex + ntet * sizes.per_tet;
  if (!(ed.fields.empty() && field_size == 0) && static_cast<int>(ed.fields.size()) != terms)
    bad("element " + std::to_string(e) + ": one field array per term needed");
  for (const auto& a : ed.positions)
    if (a.size() != nv * 3) bad("element " + std::to_string(e) + ": position array size");
  for (const auto& a : ed.fields)
    if (a.size() != field_size) bad("element " + std::to_string(e) + ": field array size");
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
  const std::size_t ntet = ed.tets.size() / 4, ntri = ed.triangles.size() / 3;
  if (nv == 0) {
    if (c.basis->element_feasible(e))
      bad("feasible element " + std::to_string(e) + " without meshes");
    fb::ElementMeshesBuilder eb(fbb);
    eb.add_error_estimate(ed.error_estimate);
    return eb.Finish();
  }
  check_element_arrays(ed, e, terms, sizes);
  check_error_model(c, ed, e);

  const FloatParams pos_params{o.position_max_abs_error};
  const FloatParams field_params{o.field_max_abs_error};
  const Codec tri_codec = o.index_codec;
  // Draco has no tet codec (SPEC.md): tets fall back to the fast codec.
  const Codec tet_codec = o.index_codec == Codec::Draco ? Codec::QuantDeltaZstd : o.index_codec;
  const auto vc = static_cast<std::uint32_t>(nv);
  const fb::BlobRef tets =
      sink.add(encode_indices(tet_codec, ed.tets.data(), ntet, 4, vc), tet_codec);
  const fb::BlobRef tris =
      sink.add(encode_indices(tri_codec, ed.triangles.data(), ntri, 3, vc), tri_codec);
  std::vector<std::uint8_t> tag_bytes(ntri * 4);
  if (ntri) std::memcpy(tag_bytes.data(), ed.triangle_tags.data(), tag_bytes.size());
  const fb::BlobRef tags = sink.add(tag_bytes, Codec::Raw);
  const fb::BlobRef canonical = sink.add(
      encode_floats(Codec::Raw, ed.canonical.data(), nv, 3, nullptr, FloatParams{}), Codec::Raw);
  std::vector<fb::BlobRef> pos, fields;
  for (const auto& a : ed.positions)
    pos.push_back(
        sink.add(encode_floats(o.float_codec, a.data(), nv, 3, ed.canonical.data(), pos_params),
                 o.float_codec));
  for (const auto& a : ed.fields)
    fields.push_back(sink.add(
        encode_floats(o.float_codec, a.data(), a.size(), 1, nullptr, field_params), o.float_codec));
  const auto pos_v = fbb.CreateVectorOfStructs(pos);
  const auto field_v = fbb.CreateVectorOfStructs(fields);
  flatbuffers::Offset<flatbuffers::Vector<double>> model_v;
  if (!ed.error_model.empty()) model_v = fbb.CreateVector(ed.error_model);
  flatbuffers::Offset<flatbuffers::Vector<double>> floors_v;
  if (!ed.field_floors.empty()) floors_v = fbb.CreateVector(ed.field_floors);
  fb::ElementMeshesBuilder eb(fbb);
  eb.add_vertex_count(vc);
  eb.add_tet_count(static_cast<std::uint32_t>(ntet));
  eb.add_triangle_count(static_cast<std::uint32_t>(ntri));
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

// The file: header, the finished index, then the blob section (SPEC.md, "Layout").
std::vector<std::uint8_t> assemble_file(const flatbuffers::FlatBufferBuilder& fbb,
                                        const std::vector<std::uint8_t>& section,
                                        std::uint16_t minor) {
  const std::uint64_t index_offset = kHeaderSize;  // 48: 8-aligned
  std::vector<std::uint8_t> file(kHeaderSize + fbb.GetSize() + section.size(), 0);
  std::memcpy(file.data() + kHeaderSize, fbb.GetBufferPointer(), fbb.GetSize());
  if (!section.empty())
    std::memcpy(file.data() + kHeaderSize + fbb.GetSize(), section.data(), section.size());
  std::memcpy(file.data(), kMagic, sizeof kMagic);
  put_le(file, 8, kFormatMajor, 2);
  // The lowest minor whose schema holds what this file uses (SPEC.md, "Versions and features"):
  // 1.0 readers keep opening assets without field units, and every reader from 1.2 on opens
  // those with outputs (an optional addition). No feature a reader must implement exists beyond
  // 1.0 (the list is empty), so it never writes required_features.
  put_le(file, 10, minor, 2);
  put_le(file, 12, kHeaderSize, 4);
  put_le(file, 16, file.size(), 8);
  put_le(file, 24, index_offset, 8);
  put_le(file, 32, fbb.GetSize(), 8);
  put_le(file, 40, XXH64(fbb.GetBufferPointer(), fbb.GetSize(), 0), 8);
  return file;
}

}  // namespace

std::vector<std::uint8_t> write_asset(const AssetContent& c, const WriteOptions& o) {
  const FieldSizes sizes = check_content(c);
  std::vector<std::uint8_t> section;
  BlobSink sink(section);
  flatbuffers::FlatBufferBuilder fbb(1 << 16);
  std::vector<flatbuffers::Offset<fb::ElementMeshes>> elements;
  for (int e = 0; e < c.basis->element_count(); ++e)
    elements.push_back(write_element(fbb, sink, c, e, o, sizes));
  write_index(fbb, c, o, elements);
  return assemble_file(fbb, section, file_minor(c));
}

void check_asset_file_writable(const std::string& path) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw FormatError(Status::Io, "cannot create " + tmp + ": " + std::strerror(errno));
  std::fclose(f);
  std::remove(tmp.c_str());
}

void write_asset_file(const AssetContent& content, const WriteOptions& options,
                      const std::string& path) {
  const std::vector<std::uint8_t> bytes = write_asset(content, options);
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw FormatError(Status::Io, "cannot create " + tmp);
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  if (std::fclose(f) != 0 || !ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw FormatError(Status::Io, "cannot write " + path);
  }
}

}  // namespace cadinterp::format
