#include "format/asset_reader.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <thread>

#include "cadinterp_generated.h"
#include "format/codec.h"

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

std::size_t DecodedElement::bytes() const {
  std::size_t b = (tets.size() + triangles.size() + triangle_tags.size() + canonical.size()) * 4;
  for (const auto& a : positions) b += a.size() * 4;
  for (const auto& a : fields) b += a.size() * 4;
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

}  // namespace

AssetReader::~AssetReader() {
  if (map_) munmap(map_, static_cast<std::size_t>(size_));
}

std::unique_ptr<AssetReader> AssetReader::open_file(const std::string& path,
                                                    const ReadLimits& limits) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw FormatError(Status::Io, "cannot open " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw FormatError(Status::Io, path + " is not a readable regular file");
  }
  std::unique_ptr<AssetReader> r(new AssetReader());
  r->size_ = static_cast<std::uint64_t>(st.st_size);
  if (r->size_ > 0) {
    void* m = mmap(nullptr, static_cast<std::size_t>(r->size_), PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      ::close(fd);
      throw FormatError(Status::Io, "cannot map " + path + ": " + std::strerror(errno));
    }
    r->map_ = m;
    r->data_ = static_cast<const std::uint8_t*>(m);
  }
  ::close(fd);
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

void AssetReader::open(const ReadLimits& limits) {
  limits_ = limits;
  // Header.
  if (size_ < sizeof kMagic || std::memcmp(data_, kMagic, sizeof kMagic) != 0)
    throw FormatError(Status::BadMagic, "not a cadinterp asset (bad magic)");
  if (size_ < kHeaderSize) throw FormatError(Status::Truncated, "file shorter than its header");
  const auto major = static_cast<std::uint16_t>(get_le(data_ + 8, 2));
  minor_ = static_cast<std::uint16_t>(get_le(data_ + 10, 2));
  if (major != kFormatMajor || minor_ > kFormatMinor)
    throw FormatError(Status::UnsupportedVersion,
                      "format " + std::to_string(major) + "." + std::to_string(minor_) +
                          " (this reader: " + std::to_string(kFormatMajor) + "." +
                          std::to_string(kFormatMinor) + ")");
  const std::uint64_t header_size = get_le(data_ + 12, 4);
  const std::uint64_t file_size = get_le(data_ + 16, 8);
  const std::uint64_t index_offset = get_le(data_ + 24, 8);
  const std::uint64_t index_size = get_le(data_ + 32, 8);
  const std::uint64_t index_hash = get_le(data_ + 40, 8);
  // Format 1.0 has exactly one header layout and the index right after it, so every header
  // bit is checked (a newer minor, which could grow the header, is rejected above).
  if (header_size != kHeaderSize) throw FormatError(Status::CorruptIndex, "header size field");
  if (file_size > size_)
    throw FormatError(Status::Truncated, "file has " + std::to_string(size_) +
                                             " bytes, header says " + std::to_string(file_size));
  if (file_size < size_)
    throw FormatError(Status::CorruptIndex, "trailing bytes after the end the header gives");
  if (index_offset != kHeaderSize) throw FormatError(Status::CorruptIndex, "index offset field");
  if (index_size > file_size || index_offset > file_size - index_size)
    throw FormatError(Status::OutOfRange, "index outside the file");
  if (index_size > std::numeric_limits<std::uint32_t>::max() / 2)
    throw FormatError(Status::LimitExceeded, "index larger than 2 GB");
  const std::uint8_t* index = data_ + index_offset;
  if (XXH64(index, static_cast<std::size_t>(index_size), 0) != index_hash)
    throw FormatError(Status::ChecksumMismatch, "index checksum mismatch");
  // FlatBuffers reads scalars in place: the index must be 8-aligned in memory.
  if (reinterpret_cast<std::uintptr_t>(index) % 8 != 0) {
    index_copy_.resize(static_cast<std::size_t>((index_size + 7) / 8));
    std::memcpy(index_copy_.data(), index, static_cast<std::size_t>(index_size));
    index = reinterpret_cast<const std::uint8_t*>(index_copy_.data());
  }

  // FlatBuffers verification with explicit limits: depth, table count bounded by the size.
  flatbuffers::Verifier verifier(index, static_cast<std::size_t>(index_size), 64,
                                 static_cast<flatbuffers::uoffset_t>(index_size / 4 + 16));
  if (!fb::AssetBufferHasIdentifier(index) || !fb::VerifyAssetBuffer(verifier))
    corrupt("FlatBuffers verification failed");
  index_ = fb::GetAsset(index);

  // Basis (every array checked by from_parts).
  const fb::Basis* b = index_->basis();
  const auto* params = index_->parameters();
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
    basis_ = core::CompiledBasis::from_parts(std::move(p));
  } catch (const std::invalid_argument& e) {
    corrupt(e.what());
  }

  // Fields.
  if (const auto* fields = index_->fields())
    for (const fb::FieldDesc* f : *fields) {
      if (f->components() < 1 || f->components() > kMaxComps) corrupt("field components");
      if (f->location() == fb::FieldLocation::Vertex)
        per_vertex_ += f->components();
      else if (f->location() == fb::FieldLocation::Tet)
        per_tet_ += f->components();
      else
        corrupt("field location");
      if (!(f->max_abs_error() >= 0.0f)) corrupt("field error bound");
    }

  // Elements: counts within limits, one blob per term, every blob inside the file.
  const auto* elems = index_->elements();
  if (static_cast<int>(elems->size()) != basis_.element_count()) corrupt("element count");
  blobs_ = index_offset + index_size;
  const std::uint64_t section = file_size - blobs_;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> extents;  // (offset, size)
  auto check_ref = [&](const fb::BlobRef* r, const char* what) {
    if (!r) corrupt(std::string("missing ") + what + " blob");
    if (!codec_is_known(static_cast<std::uint8_t>(r->codec())))
      corrupt(std::string("unknown codec of a ") + what + " blob");
    if (r->size() > section || r->offset() > section - r->size())
      throw FormatError(Status::OutOfRange, std::string(what) + " blob outside the file");
    extents.emplace_back(r->offset(), r->size());
  };
  for (int e = 0; e < basis_.element_count(); ++e) {
    const fb::ElementMeshes* m = elems->Get(static_cast<flatbuffers::uoffset_t>(e));
    int terms = 0;
    basis_.element_samples(e, &terms);
    if (m->vertex_count() == 0) {
      if (basis_.element_feasible(e)) corrupt("feasible element without meshes");
      continue;
    }
    if (m->vertex_count() > limits_.max_vertices || m->tet_count() > limits_.max_tets ||
        m->triangle_count() > limits_.max_triangles)
      throw FormatError(Status::LimitExceeded,
                        "element " + std::to_string(e) + " counts exceed limits");
    const std::uint64_t field_values =
        std::uint64_t(m->vertex_count()) * per_vertex_ + std::uint64_t(m->tet_count()) * per_tet_;
    const std::uint64_t decoded =
        4 * (std::uint64_t(m->tet_count()) * 4 + std::uint64_t(m->triangle_count()) * 4 +
             std::uint64_t(m->vertex_count()) * 3 * std::uint64_t(terms + 1) +
             field_values * std::uint64_t(terms));
    if (decoded > limits_.max_decoded_bytes)
      throw FormatError(Status::LimitExceeded,
                        "element " + std::to_string(e) + " decodes too large");
    const std::size_t first_extent = extents.size();
    check_ref(m->tets(), "tets");
    check_ref(m->triangles(), "triangles");
    check_ref(m->triangle_tags(), "triangle tags");
    check_ref(m->canonical_positions(), "canonical positions");
    if (!m->positions() || static_cast<int>(m->positions()->size()) != terms)
      corrupt("element " + std::to_string(e) + ": one position blob per term needed");
    require_aligned(m->positions(), "position blob");
    require_aligned(m->fields(), "field blob");
    for (const fb::BlobRef* r : *m->positions()) check_ref(r, "positions");
    const int field_blobs = m->fields() ? static_cast<int>(m->fields()->size()) : 0;
    if (field_values ? field_blobs != terms : field_blobs != 0)
      corrupt("element " + std::to_string(e) + ": field blob count");
    if (m->fields())
      for (const fb::BlobRef* r : *m->fields()) check_ref(r, "fields");
    std::uint64_t stored = 0;
    for (std::size_t i = first_extent; i < extents.size(); ++i) stored += extents[i].second;
    if (decoded / limits_.max_expansion > stored + 4096)
      throw FormatError(Status::LimitExceeded,
                        "element " + std::to_string(e) + " claims " + std::to_string(decoded) +
                            " decoded bytes from " + std::to_string(stored) + " stored bytes");
    if (!std::isfinite(m->error_estimate())) corrupt("non-finite error estimate");
  }
  // The blobs tile the blob section exactly: no byte of the file escapes every checksum.
  std::sort(extents.begin(), extents.end());
  std::uint64_t end = 0;
  for (const auto& [offset, n] : extents) {
    if (offset != end) corrupt("blob section has a gap or an overlap");
    end = offset + n;
  }
  if (end != section) corrupt("blob section has unreferenced bytes");
}

AssetReader::Bytes AssetReader::blob(const void* ref) const {
  const auto* r = static_cast<const fb::BlobRef*>(ref);
  const std::uint8_t* p = data_ + blobs_ + r->offset();
  const auto n = static_cast<std::size_t>(r->size());
  if (XXH64(p, n, 0) != r->checksum())
    throw FormatError(Status::ChecksumMismatch,
                      "blob at offset " + std::to_string(r->offset()) + ": checksum mismatch");
  // Decoded in place: no copy. Should a mapped file change after the check, the decoders still
  // never leave the blob's bounds (codec.h), so the worst case is wrong values, never a crash.
  return {p, n};
}

DecodedElement AssetReader::decode_element(int e) const {
  if (e < 0 || e >= basis_.element_count())
    throw FormatError(Status::InvalidArgument, "element index out of range");
  const fb::ElementMeshes* m = index_->elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
  DecodedElement d;
  d.vertex_count = m->vertex_count();
  if (d.vertex_count == 0) return d;
  const std::size_t nv = d.vertex_count, ntet = m->tet_count(), ntri = m->triangle_count();
  auto codec = [](const fb::BlobRef* r) { return static_cast<Codec>(r->codec()); };
  try {
    Bytes bytes = blob(m->tets());
    d.tets.resize(ntet * 4);
    decode_indices(codec(m->tets()), bytes.data, bytes.size, ntet, 4, d.vertex_count,
                   d.tets.data());
    bytes = blob(m->triangles());
    d.triangles.resize(ntri * 3);
    decode_indices(codec(m->triangles()), bytes.data, bytes.size, ntri, 3, d.vertex_count,
                   d.triangles.data());
    bytes = blob(m->triangle_tags());
    if (codec(m->triangle_tags()) != Codec::Raw || bytes.size != ntri * 4)
      throw FormatError(Status::CorruptBlob, "triangle tags blob");
    d.triangle_tags.resize(ntri);
    if (ntri) std::memcpy(d.triangle_tags.data(), bytes.data, bytes.size);
    bytes = blob(m->canonical_positions());
    d.canonical.resize(nv * 3);
    decode_floats(codec(m->canonical_positions()), bytes.data, bytes.size, nv, 3, nullptr,
                  d.canonical.data());
    // The per-term arrays dominate (terms x #V x 3 floats, plus fields): decoded by up to
    // hardware_concurrency threads, each a stride of the terms, when the element is large.
    const std::size_t terms = m->positions()->size();
    const std::size_t nf = nv * per_vertex_ + ntet * per_tet_;
    const bool has_fields = m->fields() != nullptr && m->fields()->size() > 0;
    d.positions.assign(terms, std::vector<float>(nv * 3));
    if (has_fields) d.fields.assign(terms, std::vector<float>(nf));
    auto decode_terms = [&](std::size_t first, std::size_t step) {
      for (std::size_t t = first; t < terms; t += step) {
        const fb::BlobRef* r = m->positions()->Get(static_cast<flatbuffers::uoffset_t>(t));
        const Bytes pb = blob(r);
        decode_floats(codec(r), pb.data, pb.size, nv, 3, d.canonical.data(), d.positions[t].data());
        if (!has_fields) continue;
        const fb::BlobRef* f = m->fields()->Get(static_cast<flatbuffers::uoffset_t>(t));
        const Bytes fb = blob(f);
        decode_floats(codec(f), fb.data, fb.size, nf, 1, nullptr, d.fields[t].data());
      }
    };
    const std::size_t work = terms * (nv * 3 + nf);
    const std::size_t threads =
        work < (1u << 20)
            ? 1
            : std::min<std::size_t>(terms, std::max(1u, std::thread::hardware_concurrency()));
    if (threads <= 1) {
      decode_terms(0, 1);
    } else {
      std::vector<std::exception_ptr> errors(threads);
      std::vector<std::thread> pool;
      for (std::size_t i = 1; i < threads; ++i)
        pool.emplace_back([&, i] {
          try {
            decode_terms(i, threads);
          } catch (...) {
            errors[i] = std::current_exception();
          }
        });
      try {
        decode_terms(0, threads);
      } catch (...) {
        errors[0] = std::current_exception();
      }
      for (auto& th : pool) th.join();
      for (const auto& err : errors)
        if (err) std::rethrow_exception(err);
    }
  } catch (const CodecError& err) {
    throw FormatError(Status::CorruptBlob,
                      std::string("element ") + std::to_string(e) + ": " + err.what());
  }
  // Post-decode checks: values are finite (a lossless codec passes any bit pattern through).
  auto finite = [](const std::vector<float>& a) {
    for (float v : a)
      if (!std::isfinite(v)) return false;
    return true;
  };
  bool ok = finite(d.canonical);
  for (const auto& a : d.positions) ok = ok && finite(a);
  for (const auto& a : d.fields) ok = ok && finite(a);
  if (!ok)
    throw FormatError(Status::CorruptBlob, "element " + std::to_string(e) + ": non-finite values");
  return d;
}

}  // namespace cadinterp::format
