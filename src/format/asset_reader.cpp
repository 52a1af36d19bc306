#include "format/asset_reader.h"

#include <xxhash.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <set>
#include <thread>
#include <tuple>

#include "cadinterp_generated.h"
#include "format/codec.h"
#include "format/format_version.h"
#include "format/mapped_file.h"

namespace cadinterp::format {

const char* status_name(Status s) {
  switch (s) {
    case Status::Ok:
      return "ok";
    case Status::InvalidArgument:
      return "invalid argument";
    case Status::OutOfMemory:
      return "out of memory";
    case Status::Io:
      return "i/o error";
    case Status::BadMagic:
      return "not a cadinterp asset";
    case Status::UnsupportedVersion:
      return "unsupported format version";
    case Status::Truncated:
      return "truncated file";
    case Status::CorruptIndex:
      return "corrupt index";
    case Status::ChecksumMismatch:
      return "checksum mismatch";
    case Status::OutOfRange:
      return "blob out of range";
    case Status::LimitExceeded:
      return "limit exceeded";
    case Status::CorruptBlob:
      return "corrupt blob";
    case Status::OutsideDomain:
      return "outside the parameter domain";
    case Status::Infeasible:
      return "infeasible parameters";
    case Status::Internal:
      return "internal error";
  }
  return "unknown status";
}

std::size_t Topology::bytes() const {
  return (tets.size() + triangles.size()) * sizeof(std::uint32_t) +
         triangle_tags.size() * sizeof(std::int32_t);
}

std::size_t DecodedElement::bytes() const {
  std::size_t b = canonical.size() * sizeof(float);
  for (const auto& a : positions) b += a.size() * sizeof(float);
  return b;
}

namespace {

std::uint64_t get_le(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

[[noreturn]] void corrupt(const std::string& what) {
  throw FormatError(Status::CorruptIndex, "corrupt index: " + what);
}

// FlatBuffers' Verifier (2.0.8) checks the alignment of a vector's length, not of its
// elements: a crafted index can place [double], [long] or [BlobRef] data 4 bytes off, and reading
// them would be a misaligned load. Writers always align them, so misalignment is corruption.
template <class U>
void require_aligned(const flatbuffers::Vector<U>* v, const char* name) {
  if (v && v->size() > 0 && reinterpret_cast<std::uintptr_t>(v->Data()) % alignof(U) != 0)
    corrupt(std::string("misaligned ") + name + " array");
}

// Copies a verified FlatBuffers vector (possibly absent) into a std::vector.
template <class T, class U>
std::vector<T> to_vector(const flatbuffers::Vector<U>* v) {
  require_aligned(v, "index");
  std::vector<T> out;
  if (v) out.assign(v->begin(), v->end());
  return out;
}

// Runs task(i) for every i in [0, n) on up to `threads` threads, the caller's included. Each
// thread takes the next untaken task when it finishes one, so tasks of uneven cost (a tet blob
// beside position blobs, or 8 terms on 3 threads) still balance to within one task. After a
// failure no new task starts; the error rethrown is that of the lowest failing index, the one a
// serial run would report, so the status does not depend on scheduling.
template <class F>
void run_tasks(std::size_t n, std::size_t threads, const F& task) {
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex error_mu;
  std::size_t error_index = n;
  std::exception_ptr error;
  auto worker = [&] {
    while (!failed.load(std::memory_order_relaxed)) {
      const std::size_t i = next.fetch_add(1, std::memory_order_relaxed);
      if (i >= n) return;
      try {
        task(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mu);
        if (i < error_index) {
          error_index = i;
          error = std::current_exception();
        }
        failed.store(true, std::memory_order_relaxed);
      }
    }
  };
  std::vector<std::thread> pool;
  try {
    pool.reserve(threads > 1 ? threads - 1 : 0);
    for (std::size_t t = 1; t < std::min(threads, n); ++t) pool.emplace_back(worker);
  } catch (...) {
    // No thread (or no memory for one): the threads already started and this one do the work.
  }
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

// Threads for decoding `values` 4-byte values: one below a few hundred thousand, where starting
// threads (tens of microseconds each) costs more than it saves.
std::size_t decode_threads(std::uint64_t values) {
  if (values < (std::uint64_t(1) << 18)) return 1;
  return std::max(1u, std::thread::hardware_concurrency());
}

Codec codec_of(const fb::BlobRef* r) { return static_cast<Codec>(r->codec()); }

// An array of n floats: the spare with the smallest sufficient capacity if there is one (its
// pages are mapped already), else a new allocation. Values are left as they are: the caller
// overwrites all of them.
DecodedArray<float> take_array(SpareArrays* spare, std::size_t n) {
  DecodedArray<float> a;
  if (spare) {
    auto best = spare->end();
    for (auto it = spare->begin(); it != spare->end(); ++it)
      if (it->capacity() >= n && (best == spare->end() || it->capacity() < best->capacity()))
        best = it;
    if (best != spare->end()) {
      a = std::move(*best);
      spare->erase(best);
    }
  }
  a.resize(n);
  return a;
}

[[noreturn]] void non_finite(int e, const char* what) {
  throw FormatError(Status::CorruptBlob,
                    "element " + std::to_string(e) + ": non-finite values in a " + what + " blob");
}

// The header's fields after the magic and version (SPEC.md, "Layout").
struct Header {
  std::uint64_t file_size, index_offset, index_size, index_hash;
};

// Checks the header of the `size` bytes at `data`: magic, version, then every field, since
// every format 1.x has exactly one header layout and the index right after it (growing the
// header needs a new major). Sets *minor from the version field.
Header check_header(const std::uint8_t* data, std::uint64_t size, std::uint16_t* minor) {
  if (size < sizeof kMagic || std::memcmp(data, kMagic, sizeof kMagic) != 0)
    throw FormatError(Status::BadMagic, "not a cadinterp asset (bad magic)");
  if (size < kHeaderSize) throw FormatError(Status::Truncated, "file shorter than its header");
  const auto major = static_cast<std::uint16_t>(get_le(data + 8, 2));
  *minor = static_cast<std::uint16_t>(get_le(data + 10, 2));
  check_format_version(major, *minor);
  const std::uint64_t header_size = get_le(data + 12, 4);
  Header h;
  h.file_size = get_le(data + 16, 8);
  h.index_offset = get_le(data + 24, 8);
  h.index_size = get_le(data + 32, 8);
  h.index_hash = get_le(data + 40, 8);
  if (header_size != kHeaderSize) throw FormatError(Status::CorruptIndex, "header size field");
  if (h.file_size > size)
    throw FormatError(Status::Truncated, "file has " + std::to_string(size) +
                                             " bytes, header says " + std::to_string(h.file_size));
  if (h.file_size < size)
    throw FormatError(Status::CorruptIndex, "trailing bytes after the end the header gives");
  if (h.index_offset != kHeaderSize) throw FormatError(Status::CorruptIndex, "index offset field");
  if (h.index_size > h.file_size || h.index_offset > h.file_size - h.index_size)
    throw FormatError(Status::OutOfRange, "index outside the file");
  if (h.index_size > std::numeric_limits<std::uint32_t>::max() / 2)
    throw FormatError(Status::LimitExceeded, "index larger than 2 GB");
  return h;
}

// Checks the index's checksum and verifies it as a FlatBuffer; returns its root. A misaligned
// index is copied into `copy` first, as FlatBuffers reads scalars in place and needs 8-aligned
// memory.
const fb::Asset* verify_index(const std::uint8_t* data, const Header& h,
                              std::vector<std::uint64_t>& copy) {
  // A FlatBuffer has at least its root offset and file identifier (8 bytes); the identifier
  // check below reads them before the verifier runs, so a shorter index would be read past its
  // end.
  if (h.index_size < 8) corrupt("index shorter than a FlatBuffers header");
  const std::uint8_t* index = data + h.index_offset;
  if (XXH64(index, static_cast<std::size_t>(h.index_size), 0) != h.index_hash)
    throw FormatError(Status::ChecksumMismatch, "index checksum mismatch");
  if (reinterpret_cast<std::uintptr_t>(index) % 8 != 0) {
    copy.resize(static_cast<std::size_t>((h.index_size + 7) / 8));
    std::memcpy(copy.data(), index, static_cast<std::size_t>(h.index_size));
    index = reinterpret_cast<const std::uint8_t*>(copy.data());
  }
  // FlatBuffers verification with explicit limits: depth, table count bounded by the size.
  flatbuffers::Verifier verifier(index, static_cast<std::size_t>(h.index_size), 64,
                                 static_cast<flatbuffers::uoffset_t>(h.index_size / 4 + 16));
  if (!fb::AssetBufferHasIdentifier(index) || !fb::VerifyAssetBuffer(verifier))
    corrupt("FlatBuffers verification failed");
  return fb::GetAsset(index);
}

// The index's basis and parameter domain, every array checked by from_parts.
core::CompiledBasis read_basis(const fb::Asset& index) {
  const fb::Basis* b = index.basis();
  const auto* params = index.parameters();
  core::CompiledBasis::Parts p;
  p.K = b->dim();
  if (p.K < 1 || p.K > core::kMaxDim || static_cast<int>(params->size()) != p.K)
    corrupt("dimension and parameter count");
  if (b->degree() != 1 && b->degree() != 3) corrupt("basis degree");
  p.degree = static_cast<core::Degree>(b->degree());
  for (const fb::Parameter* prm : *params) {
    p.lo.push_back(prm->lower());
    p.hi.push_back(prm->upper());
  }
  p.sample_unit = to_vector<double>(b->sample_unit());
  p.node_dir = to_vector<std::int8_t>(b->node_dir());
  p.node_split = to_vector<double>(b->node_split());
  p.node_child = to_vector<std::int32_t>(b->node_child());
  p.node_elem = to_vector<std::int32_t>(b->node_elem());
  p.elem_box = to_vector<double>(b->elem_box());
  p.elem_feasible = to_vector<std::uint8_t>(b->elem_feasible());
  p.elem_bs_begin = to_vector<std::int64_t>(b->elem_bs_begin());
  p.elem_term_begin = to_vector<std::int64_t>(b->elem_term_begin());
  p.bs_centre = to_vector<double>(b->bs_centre());
  p.bs_inv_width = to_vector<double>(b->bs_inv_width());
  p.bs_col_begin = to_vector<std::int64_t>(b->bs_col_begin());
  p.term_sample = to_vector<std::int32_t>(b->term_sample());
  p.col_term = to_vector<std::int32_t>(b->col_term());
  p.col_value = to_vector<double>(b->col_value());
  try {
    return core::CompiledBasis::from_parts(std::move(p));
  } catch (const std::invalid_argument& e) {
    corrupt(e.what());
  }
}

// The C ABI hands strings out NUL-terminated, so an embedded NUL would make a name read back
// differently from what cadinterp_find_field compares.
void check_text(const flatbuffers::String* str, const char* what) {
  if (str && std::memchr(str->data(), '\0', str->size()))
    corrupt(std::string(what) + " contains a NUL character");
}

// Checks the descriptive tables of a K-parameter asset: their strings and the infeasible points'
// coordinates.
void check_descriptions(const fb::Asset& index, int K) {
  for (const fb::Parameter* prm : *index.parameters()) {
    check_text(prm->name(), "parameter name");
    check_text(prm->unit(), "parameter unit");
  }
  if (const auto* fields = index.fields())
    for (const fb::FieldDesc* f : *fields) {
      check_text(f->name(), "field name");
      check_text(f->unit(), "field unit");  // format 1.1
    }
  if (const auto* regions = index.regions())
    for (const fb::BoundaryRegion* r : *regions) {
      check_text(r->name(), "region name");
      check_text(r->kind(), "region kind");
    }
  if (const auto* inf = index.infeasible())
    for (const fb::InfeasiblePoint* f : *inf) {
      if (!f->x() || static_cast<int>(f->x()->size()) != K)
        corrupt("infeasible point with other than K coordinates");
      for (double v : *f->x())
        if (!std::isfinite(v)) corrupt("infeasible point not finite");
      check_text(f->message(), "infeasible message");
    }
  if (const fb::Provenance* pv = index.provenance()) {
    check_text(pv->builder_version(), "builder version");
    check_text(pv->host(), "host name");
    check_text(pv->options(), "build options");
  }
}

// Format 1.3 outputs: names present, unique and without NUL, one value per sample, finite at
// every sample a feasible element uses (so an evaluation never returns a NaN the file stored).
void check_outputs(const fb::Asset& index, const core::CompiledBasis& basis) {
  const auto* outputs = index.outputs();
  if (!outputs) return;
  const core::CompiledBasis::Parts& p = basis.parts();
  const std::size_t S = p.sample_unit.size() / static_cast<std::size_t>(p.K);
  std::set<std::string_view> names;
  for (const fb::SampleOutput* o : *outputs) {
    check_text(o->name(), "output name");
    check_text(o->unit(), "output unit");
    if (!names.insert(o->name()->string_view()).second) corrupt("output name given twice");
    if (!o->values() || o->values()->size() != S) corrupt("output without one value per sample");
    for (std::size_t e = 0; e + 1 < p.elem_term_begin.size(); ++e) {
      if (!p.elem_feasible[e]) continue;
      for (auto t = p.elem_term_begin[e]; t < p.elem_term_begin[e + 1]; ++t)
        if (!std::isfinite(o->values()->Get(
                static_cast<flatbuffers::uoffset_t>(p.term_sample[static_cast<std::size_t>(t)]))))
          corrupt("output value not finite at a sample of a feasible element");
    }
  }
}

// Checks the field descriptions and adds up the values each vertex and each tet carries.
void count_field_values(const fb::Asset& index, std::size_t& per_vertex, std::size_t& per_tet) {
  if (const auto* fields = index.fields())
    for (const fb::FieldDesc* f : *fields) {
      if (f->components() < 1 || f->components() > kMaxComps) corrupt("field components");
      if (f->location() == fb::FieldLocation::Vertex)
        per_vertex += f->components();
      else if (f->location() == fb::FieldLocation::Tet)
        per_tet += f->components();
      else
        corrupt("field location");
      if (!(f->max_abs_error() >= 0.0f)) corrupt("field error bound");
    }
}

// Where a blob reference points inside the blob section; all four fields equal name one
// shared blob.
struct Extent {
  std::uint64_t offset, size, checksum;
  std::uint8_t codec;
  auto tie() const { return std::tie(offset, size, checksum, codec); }
  bool operator<(const Extent& o) const { return tie() < o.tie(); }
  bool operator==(const Extent& o) const { return tie() == o.tie(); }
};

// Checks that a blob reference is present, has a known codec and lies inside the blob section
// of `section` bytes; appends its extent.
void check_ref(const fb::BlobRef* r, const char* what, std::uint64_t section,
               std::vector<Extent>& extents) {
  if (!r) corrupt(std::string("missing ") + what + " blob");
  if (!codec_is_known(static_cast<std::uint8_t>(r->codec())))
    corrupt(std::string("unknown codec of a ") + what + " blob");
  if (r->size() > section || r->offset() > section - r->size())
    throw FormatError(Status::OutOfRange, std::string(what) + " blob outside the file");
  extents.push_back({r->offset(), r->size(), r->checksum(), static_cast<std::uint8_t>(r->codec())});
}

// Element e's error model (format 1.3; error_model.h): absent (and no floors), or `rows`
// (1 + #fields) by (K + 1) finite values, a finite geometry floor >= 0 and no field floors or
// one finite value >= 0 per field, in a file that says 1.3 or more.
void check_error_model(const fb::ElementMeshes* m, int e, int K, std::size_t rows,
                       std::uint16_t minor) {
  const auto* model = m->error_model();
  const std::string where = "element " + std::to_string(e) + ": ";
  if (!model) {
    if (m->geometry_floor() != 0) corrupt(where + "geometry floor without an error model");
    if (m->field_floors()) corrupt(where + "field floors without an error model");
    return;
  }
  if (!std::isfinite(m->geometry_floor()) || !(m->geometry_floor() >= 0))
    corrupt(where + "geometry floor not finite and >= 0");
  if (const auto* floors = m->field_floors()) {
    if (floors->size() != rows - 1) corrupt(where + "field floors size");
    for (double v : *floors)
      if (!std::isfinite(v) || !(v >= 0)) corrupt(where + "field floor not finite and >= 0");
  }
  if (minor < kMinorOutputs)
    corrupt(where + "error model in a file of format 1." + std::to_string(minor) +
            " (1.3 content)");
  if (model->size() != rows * static_cast<std::size_t>(K + 1)) corrupt(where + "error model size");
  for (double v : *model)
    if (!std::isfinite(v)) corrupt(where + "non-finite error model");
}

// Checks element e of the index against the basis and the limits: counts within limits, one
// blob per term, every blob inside the section, and no more expansion than the limits allow.
// Appends the extents of its blobs.
void check_element(const fb::ElementMeshes* m, int e, const core::CompiledBasis& basis,
                   const ReadLimits& limits, std::size_t per_vertex, std::size_t per_tet,
                   std::size_t model_rows, std::uint16_t minor, std::uint64_t section,
                   std::vector<Extent>& extents) {
  int terms = 0;
  basis.element_samples(e, &terms);
  // Before the infeasible-element shortcut: error_estimate answers for every element.
  if (!std::isfinite(m->error_estimate())) corrupt("non-finite error estimate");
  if (m->vertex_count() == 0) {
    if (basis.element_feasible(e)) corrupt("feasible element without meshes");
    if (m->error_model() || m->geometry_floor() != 0 || m->field_floors())
      corrupt("element " + std::to_string(e) + ": error model without meshes");
    return;
  }
  check_error_model(m, e, basis.dim(), model_rows, minor);
  if (m->vertex_count() > limits.max_vertices || m->tet_count() > limits.max_tets ||
      m->triangle_count() > limits.max_triangles)
    throw FormatError(Status::LimitExceeded,
                      "element " + std::to_string(e) + " counts exceed limits");
  const std::uint64_t field_values =
      std::uint64_t(m->vertex_count()) * per_vertex + std::uint64_t(m->tet_count()) * per_tet;
  const std::uint64_t decoded =
      4 * (std::uint64_t(m->tet_count()) * 4 + std::uint64_t(m->triangle_count()) * 4 +
           std::uint64_t(m->vertex_count()) * 3 * std::uint64_t(terms + 1) +
           field_values * std::uint64_t(terms));
  if (decoded > limits.max_decoded_bytes)
    throw FormatError(Status::LimitExceeded, "element " + std::to_string(e) + " decodes too large");
  const std::size_t first_extent = extents.size();
  check_ref(m->tets(), "tets", section, extents);
  check_ref(m->triangles(), "triangles", section, extents);
  check_ref(m->triangle_tags(), "triangle tags", section, extents);
  check_ref(m->canonical_positions(), "canonical positions", section, extents);
  if (!m->positions() || static_cast<int>(m->positions()->size()) != terms)
    corrupt("element " + std::to_string(e) + ": one position blob per term needed");
  require_aligned(m->positions(), "position blob");
  require_aligned(m->fields(), "field blob");
  for (const fb::BlobRef* r : *m->positions()) check_ref(r, "positions", section, extents);
  const int field_blobs = m->fields() ? static_cast<int>(m->fields()->size()) : 0;
  if (field_values ? field_blobs != terms : field_blobs != 0)
    corrupt("element " + std::to_string(e) + ": field blob count");
  if (m->fields())
    for (const fb::BlobRef* r : *m->fields()) check_ref(r, "fields", section, extents);
  std::uint64_t stored = 0;
  for (std::size_t i = first_extent; i < extents.size(); ++i) stored += extents[i].size;
  if (decoded / limits.max_expansion > stored + 4096)
    throw FormatError(Status::LimitExceeded, "element " + std::to_string(e) + " claims " +
                                                 std::to_string(decoded) + " decoded bytes from " +
                                                 std::to_string(stored) + " stored bytes");
}

// The blobs tile the blob section of `section` bytes exactly: no byte of the file escapes every
// checksum. Identical references name one shared blob (SPEC.md, "Layout"); any other overlap
// is corruption. Sorting puts identical references side by side. With `gaps` (a file of a newer
// minor, whose unknown fields may reference blobs of their own) bytes no known reference covers
// are skipped; overlaps are still corruption.
void check_tiling(std::vector<Extent>& extents, std::uint64_t section, bool gaps) {
  std::sort(extents.begin(), extents.end());
  std::uint64_t end = 0;
  for (std::size_t i = 0; i < extents.size(); ++i) {
    const Extent& x = extents[i];
    if (i > 0 && x == extents[i - 1]) continue;
    if (x.offset < end || (x.offset > end && !gaps))
      corrupt("blob section has a gap or an overlap");
    end = x.offset + x.size;
  }
  if (end > section || (end < section && !gaps)) corrupt("blob section has unreferenced bytes");
}

}  // namespace

AssetReader::~AssetReader() = default;

std::unique_ptr<AssetReader> AssetReader::open_file(const std::string& path,
                                                    const ReadLimits& limits) {
  std::unique_ptr<AssetReader> r(new AssetReader());
  r->map_ = std::make_unique<MappedFile>(path);
  r->data_ = r->map_->data();
  r->size_ = r->map_->size();
  r->open(limits);
  return r;
}

std::unique_ptr<AssetReader> AssetReader::open_memory(const void* data, std::size_t size, bool copy,
                                                      const ReadLimits& limits) {
  if (!data && size) throw FormatError(Status::InvalidArgument, "null buffer");
  std::unique_ptr<AssetReader> r(new AssetReader());
  r->size_ = size;
  if (copy) {
    r->owned_.assign(static_cast<const std::uint8_t*>(data),
                     static_cast<const std::uint8_t*>(data) + size);
    r->data_ = r->owned_.data();
  } else {
    r->data_ = static_cast<const std::uint8_t*>(data);
  }
  r->open(limits);
  return r;
}

// Verifies the whole file before anything is decoded, in the order of its layout; each step
// throws FormatError with the status of the first check that fails.
void AssetReader::open(const ReadLimits& limits) {
  limits_ = limits;
  const Header h = check_header(data_, size_, &minor_);
  index_ = verify_index(data_, h, index_copy_);
  // Before anything else of the index: a required feature may change what the rest means.
  check_index_version(*index_, minor_);
  basis_ = read_basis(*index_);
  check_descriptions(*index_, basis_.dim());
  check_outputs(*index_, basis_);
  count_field_values(*index_, per_vertex_, per_tet_);

  const auto* elems = index_->elements();
  if (static_cast<int>(elems->size()) != basis_.element_count()) corrupt("element count");
  blobs_ = h.index_offset + h.index_size;
  const std::uint64_t section = h.file_size - blobs_;
  std::vector<Extent> extents;
  const std::size_t model_rows = 1 + (index_->fields() ? index_->fields()->size() : 0);
  for (int e = 0; e < basis_.element_count(); ++e)
    check_element(elems->Get(static_cast<flatbuffers::uoffset_t>(e)), e, basis_, limits_,
                  per_vertex_, per_tet_, model_rows, minor_, section, extents);
  check_tiling(extents, section, newer_minor(minor_));
}

AssetReader::Bytes AssetReader::blob(const void* ref) const {
  const auto* r = static_cast<const fb::BlobRef*>(ref);
  const std::uint8_t* p = data_ + blobs_ + r->offset();
  const auto n = static_cast<std::size_t>(r->size());
  if (map_) map_->will_need(p, n);  // the blob's pages in one go (the map reads at random)
  if (XXH64(p, n, 0) != r->checksum())
    throw FormatError(Status::ChecksumMismatch,
                      "blob at offset " + std::to_string(r->offset()) + ": checksum mismatch");
  // Decoded in place: no copy. Should a mapped file change after the check, the decoders still
  // never leave the blob's bounds (codec.h), so the worst case is wrong values, never a crash.
  return {p, n};
}

void AssetReader::verify_blobs() const {
  std::set<std::uint64_t> seen;  // blob offsets: identical references share one blob (SPEC.md)
  const auto verify = [&](const fb::BlobRef* r) {
    if (r && r->size() > 0 && seen.insert(r->offset()).second) blob(r);
  };
  for (const fb::ElementMeshes* m : *index_->elements()) {
    for (const fb::BlobRef* r :
         {m->tets(), m->triangles(), m->triangle_tags(), m->canonical_positions()})
      verify(r);
    for (const auto* list : {m->positions(), m->fields()})
      if (list)
        for (const fb::BlobRef* r : *list) verify(r);
  }
}

AssetReader::TopologyKey AssetReader::topology_key(int e) const {
  const fb::ElementMeshes* m = index_->elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
  TopologyKey k{};
  std::size_t at = 0;
  for (const fb::BlobRef* r : {m->tets(), m->triangles(), m->triangle_tags()}) {
    k[at++] = r->offset();
    k[at++] = r->size();
    k[at++] = r->checksum();
    k[at++] = static_cast<std::uint64_t>(r->codec());
  }
  k[at++] = m->vertex_count();
  k[at++] = m->tet_count();
  k[at] = m->triangle_count();
  return k;
}

std::shared_ptr<const Topology> AssetReader::find_topology(const TopologyKey& key) const {
  std::lock_guard<std::mutex> lock(topologies_mu_);
  const auto it = topologies_.find(key);
  return it == topologies_.end() ? nullptr : it->second.lock();
}

std::shared_ptr<const Topology> AssetReader::remember_topology(
    const TopologyKey& key, std::shared_ptr<const Topology> t) const {
  std::lock_guard<std::mutex> lock(topologies_mu_);
  // Entries whose topology every holder released go here: the table stays as small as the set of
  // topologies alive.
  for (auto it = topologies_.begin(); it != topologies_.end();)
    it = it->second.expired() ? topologies_.erase(it) : std::next(it);
  std::weak_ptr<const Topology>& slot = topologies_[key];
  // Another thread may have decoded the same topology meanwhile: the first one stays, so that
  // every holder shares it.
  if (auto live = slot.lock()) return live;
  slot = t;
  return t;
}

namespace {

// Decodes part `part` (0 tets, 1 triangles, 2 triangle tags) of a topology into `t`, whose arrays
// are already sized.
template <class BlobFn>
void decode_topology_part(const fb::ElementMeshes* m, int part, const BlobFn& blob, Topology& t) {
  const std::uint32_t nv = m->vertex_count();
  if (part == 0) {
    const auto b = blob(m->tets());
    decode_indices(codec_of(m->tets()), b.data, b.size, m->tet_count(), 4, nv, t.tets.data());
  } else if (part == 1) {
    const auto b = blob(m->triangles());
    decode_indices(codec_of(m->triangles()), b.data, b.size, m->triangle_count(), 3, nv,
                   t.triangles.data());
  } else {
    const auto b = blob(m->triangle_tags());
    if (codec_of(m->triangle_tags()) != Codec::Raw ||
        b.size != std::size_t(m->triangle_count()) * 4)
      throw CodecError(CodecError::Kind::Corrupt, "triangle tags blob");
    if (b.size) std::memcpy(t.triangle_tags.data(), b.data, b.size);
  }
}

std::shared_ptr<Topology> sized_topology(const fb::ElementMeshes* m) {
  auto t = std::make_shared<Topology>();
  t->tets.resize(std::size_t(m->tet_count()) * 4);
  t->triangles.resize(std::size_t(m->triangle_count()) * 3);
  t->triangle_tags.resize(m->triangle_count());
  return t;
}

[[noreturn]] void corrupt_blob(int e, const CodecError& err) {
  throw FormatError(Status::CorruptBlob,
                    std::string("element ") + std::to_string(e) + ": " + err.what());
}

}  // namespace

std::shared_ptr<const Topology> AssetReader::decode_topology(int e) const {
  if (e < 0 || e >= basis_.element_count())
    throw FormatError(Status::InvalidArgument, "element index out of range");
  const fb::ElementMeshes* m = index_->elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
  if (m->vertex_count() == 0) return nullptr;
  const TopologyKey key = topology_key(e);
  if (auto live = find_topology(key)) return live;
  const std::shared_ptr<Topology> t = sized_topology(m);
  auto blob_fn = [this](const fb::BlobRef* r) { return blob(r); };
  try {
    for (int part = 0; part < 3; ++part) decode_topology_part(m, part, blob_fn, *t);
  } catch (const CodecError& err) {
    corrupt_blob(e, err);
  }
  return remember_topology(key, t);
}

DecodedElement AssetReader::decode_element(int e, SpareArrays* spare) const {
  if (e < 0 || e >= basis_.element_count())
    throw FormatError(Status::InvalidArgument, "element index out of range");
  const fb::ElementMeshes* m = index_->elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
  DecodedElement d;
  d.vertex_count = m->vertex_count();
  if (d.vertex_count == 0) return d;
  const std::size_t nv = d.vertex_count;
  const std::size_t terms = m->positions()->size();
  try {
    // The canonical array first: position blobs may be coded against it, and a lossy decode is
    // finite by construction only with a finite reference.
    const Bytes cb = blob(m->canonical_positions());
    d.canonical = take_array(spare, nv * 3);
    if (!decode_floats_finite(codec_of(m->canonical_positions()), cb.data, cb.size, nv, 3, nullptr,
                              d.canonical.data()))
      non_finite(e, "canonical positions");

    // A topology still held by another element (the neighbour a cell switch leaves) is reused;
    // otherwise its three blobs are decoded alongside the positions, as tasks of the same pool.
    const TopologyKey key = topology_key(e);
    std::shared_ptr<const Topology> shared = find_topology(key);
    std::shared_ptr<Topology> fresh;
    if (!shared) fresh = sized_topology(m);
    // Buffers are allocated here and first written by the decoding threads, so the page faults
    // of fresh memory are taken in parallel too.
    d.positions.reserve(terms);
    for (std::size_t t = 0; t < terms; ++t) d.positions.push_back(take_array(spare, nv * 3));
    // Task order: the tet blob first (the largest single task: started first, it balances best),
    // then one task per term, then the small triangle and tag blobs.
    const std::size_t topo_tasks = fresh ? 3 : 0;
    auto blob_fn = [this](const fb::BlobRef* r) { return blob(r); };
    auto task = [&](std::size_t i) {
      const std::size_t t = fresh ? i - 1 : i;  // term, if < terms
      if (fresh && (i == 0 || t >= terms)) {
        decode_topology_part(m, i == 0 ? 0 : static_cast<int>(t - terms + 1), blob_fn, *fresh);
        return;
      }
      const fb::BlobRef* r = m->positions()->Get(static_cast<flatbuffers::uoffset_t>(t));
      const Bytes pb = blob(r);
      if (!decode_floats_finite(codec_of(r), pb.data, pb.size, nv, 3, d.canonical.data(),
                                d.positions[t].data()))
        non_finite(e, "positions");
    };
    const std::uint64_t values =
        std::uint64_t(terms) * nv * 3 +
        (fresh ? std::uint64_t(m->tet_count()) * 4 + std::uint64_t(m->triangle_count()) * 4 : 0);
    run_tasks(terms + topo_tasks, decode_threads(values), task);
    d.topology = fresh ? remember_topology(key, std::move(fresh)) : std::move(shared);
  } catch (const CodecError& err) {
    corrupt_blob(e, err);
  }
  return d;
}

std::vector<DecodedArray<float>> AssetReader::decode_fields(int e, SpareArrays* spare) const {
  if (e < 0 || e >= basis_.element_count())
    throw FormatError(Status::InvalidArgument, "element index out of range");
  const fb::ElementMeshes* m = index_->elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
  std::vector<DecodedArray<float>> fields;
  if (m->vertex_count() == 0 || !m->fields() || m->fields()->size() == 0) return fields;
  const std::size_t nf =
      std::size_t(m->vertex_count()) * per_vertex_ + std::size_t(m->tet_count()) * per_tet_;
  const std::size_t terms = m->fields()->size();
  fields.reserve(terms);
  for (std::size_t t = 0; t < terms; ++t) fields.push_back(take_array(spare, nf));
  try {
    run_tasks(terms, decode_threads(std::uint64_t(terms) * nf), [&](std::size_t t) {
      const fb::BlobRef* r = m->fields()->Get(static_cast<flatbuffers::uoffset_t>(t));
      const Bytes fb = blob(r);
      // Field blobs are coded without a reference (asset_writer.cpp); one that claims a reference
      // fails with InvalidArgument, reported as a corrupt blob below.
      if (!decode_floats_finite(codec_of(r), fb.data, fb.size, nf, 1, nullptr, fields[t].data()))
        non_finite(e, "field");
    });
  } catch (const CodecError& err) {
    corrupt_blob(e, err);
  }
  return fields;
}

double element_error_floor(const fb::ElementMeshes& m, int q) {
  if (q == 0) return m.geometry_floor();
  const auto* floors = m.field_floors();
  return floors ? floors->Get(static_cast<flatbuffers::uoffset_t>(q - 1)) : 0.0;
}

}  // namespace cadinterp::format
