#include <gtest/gtest.h>
#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <random>
#include <set>

#include "cadinterp_generated.h"
#include "format/asset_reader.h"
#include "format/synthetic_asset.h"

namespace cadinterp::format {
namespace {

const SyntheticAsset& small_asset() {
  static const SyntheticAsset a = [] {
    SyntheticSpec spec;
    spec.K = 2;
    spec.cells[0] = 3;
    spec.cells[1] = 2;
    spec.cells[2] = 1;
    spec.tolerance = 5e-3;
    spec.max_samples = 60;
    return make_synthetic_asset(spec);
  }();
  return a;
}

std::vector<std::uint8_t> small_file(Codec codec = Codec::QuantDeltaZstd, double err = 0.0) {
  WriteOptions o;
  o.float_codec = codec;
  o.index_codec = codec;
  o.position_max_abs_error = err;
  o.field_max_abs_error = err;
  return write_asset(small_asset().content, o);
}

// Element-wise equality of a decoded array and the written one.
template <class A, class B>
bool same(const A& a, const B& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end());
}
template <class A, class B>
bool same_terms(const std::vector<A>& a, const std::vector<B>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(),
                    [](const A& x, const B& y) { return same(x, y); });
}

// Opens and decodes everything (meshes and fields); returns the first error's status (Ok if
// none).
Status open_and_decode(const std::vector<std::uint8_t>& bytes) {
  try {
    const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
    for (int e = 0; e < r->basis().element_count(); ++e) {
      r->decode_element(e);
      r->decode_fields(e);
    }
    return Status::Ok;
  } catch (const FormatError& err) {
    return err.status;
  }
}

template <class F>
Status status_of(F&& f) {
  try {
    f();
    return Status::Ok;
  } catch (const FormatError& err) {
    return err.status;
  }
}

// Rewrites the index checksum after an in-place index edit.
void rehash(std::vector<std::uint8_t>& b) {
  std::uint64_t n = 0;
  for (int i = 7; i >= 0; --i) n = (n << 8) | b[static_cast<std::size_t>(32 + i)];
  const std::uint64_t h = XXH64(b.data() + kHeaderSize, static_cast<std::size_t>(n), 0);
  for (int i = 0; i < 8; ++i)
    b[static_cast<std::size_t>(40 + i)] = static_cast<std::uint8_t>(h >> (8 * i));
}

std::uint64_t blob_section(const std::vector<std::uint8_t>& b) {
  std::uint64_t n = 0;
  for (int i = 7; i >= 0; --i) n = (n << 8) | b[static_cast<std::size_t>(32 + i)];
  return kHeaderSize + n;
}

fb::ElementMeshes* element_of(std::vector<std::uint8_t>& b, int e) {
  return fb::GetMutableAsset(b.data() + kHeaderSize)
      ->mutable_elements()
      ->GetMutableObject(static_cast<flatbuffers::uoffset_t>(e));
}

// Feasible elements of the small asset.
std::vector<int> feasible_elements(const AssetReader& r) {
  std::vector<int> out;
  for (int e = 0; e < r.basis().element_count(); ++e)
    if (r.index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e))->vertex_count() > 0)
      out.push_back(e);
  return out;
}

Status open_status(const std::vector<std::uint8_t>& bytes) {
  try {
    AssetReader::open_memory(bytes.data(), bytes.size(), false);
    return Status::Ok;
  } catch (const FormatError& err) {
    return err.status;
  }
}

void set_le(std::vector<std::uint8_t>& b, std::size_t at, std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i)
    b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}

TEST(Asset, RoundTripsLosslessWithEveryCodec) {
  const SyntheticAsset& a = small_asset();
  for (Codec codec : {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt, Codec::Draco}) {
    SCOPED_TRACE(codec_name(codec));
    const std::vector<std::uint8_t> bytes = small_file(codec);
    const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
    const core::CompiledBasis& cb = r->basis();
    ASSERT_EQ(cb.element_count(), a.basis->element_count());
    EXPECT_EQ(cb.parts().col_value, a.basis->parts().col_value);
    EXPECT_EQ(cb.parts().node_split, a.basis->parts().node_split);
    EXPECT_EQ(r->index().parameters()->Get(1)->name()->str(), "twist");
    EXPECT_EQ(r->index().fields()->size(), 2u);
    EXPECT_EQ(r->index().provenance()->host()->str(), "synthetic box");
    for (int e = 0; e < cb.element_count(); ++e) {
      const DecodedElement d = r->decode_element(e);
      const ElementData& w = a.content.elements[static_cast<std::size_t>(e)];
      ASSERT_EQ(d.vertex_count, w.vertex_count);
      ASSERT_TRUE(d.topology);
      EXPECT_TRUE(same(d.topology->tets, w.tets));
      EXPECT_TRUE(same(d.topology->triangles, w.triangles));
      EXPECT_TRUE(same(d.topology->triangle_tags, w.triangle_tags));
      EXPECT_TRUE(same(d.canonical, w.canonical));
      EXPECT_TRUE(same_terms(d.positions, w.positions));
      EXPECT_TRUE(same_terms(r->decode_fields(e), w.fields));
    }
  }
}

TEST(Asset, LossyCodecsStayWithinTheirBound) {
  const double bound = 1e-4;
  for (Codec codec : {Codec::QuantDeltaZstd, Codec::Meshopt, Codec::Draco}) {
    SCOPED_TRACE(codec_name(codec));
    const std::vector<std::uint8_t> bytes = small_file(codec, bound);
    const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
    double worst = 0.0;
    for (int e = 0; e < r->basis().element_count(); ++e) {
      const DecodedElement d = r->decode_element(e);
      const ElementData& w = small_asset().content.elements[static_cast<std::size_t>(e)];
      for (std::size_t t = 0; t < d.positions.size(); ++t)
        for (std::size_t i = 0; i < d.positions[t].size(); ++i)
          worst = std::max(worst, std::abs(double(d.positions[t][i]) - w.positions[t][i]));
    }
    EXPECT_LE(worst, bound * (1 + 1e-6) + 1e-6);
    EXPECT_EQ(r->index().position_max_abs_error(), static_cast<float>(bound));
  }
}

TEST(Asset, OpensFromAFileByMappingIt) {
  const std::vector<std::uint8_t> bytes = small_file();
  const std::string path = ::testing::TempDir() + "/format_test.cadi";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_TRUE(f);
  std::fwrite(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
  const auto r = AssetReader::open_file(path);
  EXPECT_EQ(r->file_size(), bytes.size());
  EXPECT_TRUE(
      same_terms(r->decode_element(0).positions, small_asset().content.elements[0].positions));
  try {
    AssetReader::open_file(path + ".missing");
    FAIL() << "opened a missing file";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.status, Status::Io);
  }
  std::remove(path.c_str());
}

TEST(Asset, MisalignedCallerBufferIsHandled) {
  const std::vector<std::uint8_t> bytes = small_file();
  std::vector<std::uint8_t> shifted(bytes.size() + 1);
  std::memcpy(shifted.data() + 1, bytes.data(), bytes.size());
  const auto r = AssetReader::open_memory(shifted.data() + 1, bytes.size(), false);
  EXPECT_EQ(r->basis().element_count(), small_asset().basis->element_count());
}

TEST(Asset, EachInvalidFileHasItsNamedStatus) {
  const std::vector<std::uint8_t> good = small_file();
  ASSERT_EQ(open_and_decode(good), Status::Ok);
  const std::uint64_t index_size =
      good[32] | (std::uint64_t(good[33]) << 8) | (std::uint64_t(good[34]) << 16);
  struct Case {
    const char* name;
    Status expected;
    void (*mutate)(std::vector<std::uint8_t>&, std::uint64_t);
  };
  const Case cases[] = {
      {"empty", Status::BadMagic, [](auto& b, auto) { b.clear(); }},
      {"bad magic", Status::BadMagic, [](auto& b, auto) { b[1] = 'X'; }},
      {"newer major", Status::UnsupportedVersion, [](auto& b, auto) { set_le(b, 8, 2, 2); }},
      // A newer minor is read, but must repeat its minor in the index (format_minor).
      {"newer minor, not in the index", Status::CorruptIndex,
       [](auto& b, auto) { set_le(b, 10, kFormatMinor + 1u, 2); }},
      {"header only", Status::Truncated, [](auto& b, auto) { b.resize(20); }},
      {"truncated", Status::Truncated, [](auto& b, auto) { b.pop_back(); }},
      {"trailing byte", Status::CorruptIndex, [](auto& b, auto) { b.push_back(0); }},
      {"header size", Status::CorruptIndex, [](auto& b, auto) { set_le(b, 12, 64, 4); }},
      {"index outside", Status::OutOfRange, [](auto& b, auto) { set_le(b, 32, b.size(), 8); }},
      {"index checksum", Status::ChecksumMismatch, [](auto& b, auto) { b[60] ^= 1; }},
      {"blob checksum", Status::ChecksumMismatch, [](auto& b, auto) { b[b.size() - 3] ^= 4; }},
      {"index flip re-hashed", Status::CorruptIndex,
       [](auto& b, auto n) {  // a valid checksum over a broken FlatBuffer: the verifier catches it
         b[48] ^= 0x40;
         set_le(b, 40, XXH64(b.data() + 48, static_cast<std::size_t>(n), 0), 8);
       }},
  };
  for (const Case& c : cases) {
    std::vector<std::uint8_t> b = good;
    c.mutate(b, index_size);
    EXPECT_EQ(open_and_decode(b), c.expected) << c.name << ": " << status_name(open_and_decode(b));
  }
}

TEST(Asset, LimitsAreCheckedBeforeAllocating) {
  const std::vector<std::uint8_t> bytes = small_file();
  ReadLimits tight;
  tight.max_vertices = 10;
  try {
    AssetReader::open_memory(bytes.data(), bytes.size(), false, tight);
    FAIL() << "limit not enforced";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.status, Status::LimitExceeded);
  }
}

// Every prefix of a valid asset fails with a named status (never a crash: run under ASan).
TEST(Asset, EveryPrefixIsRejected) {
  const std::vector<std::uint8_t> good = small_file();
  for (std::size_t n = 0; n < good.size(); ++n) {
    const std::vector<std::uint8_t> prefix(good.begin(),
                                           good.begin() + static_cast<std::ptrdiff_t>(n));
    const Status s = open_status(prefix);
    ASSERT_NE(s, Status::Ok) << "prefix of " << n << " bytes opened";
    ASSERT_TRUE(s == Status::BadMagic || s == Status::Truncated) << n << ": " << status_name(s);
  }
}

// Every byte is covered by a header check, the index checksum or a blob checksum: each of
// 10,000 random single-bit flips is reported by open or by decoding the elements.
TEST(Asset, EveryBitFlipIsReported) {
  const std::vector<std::uint8_t> good = small_file();
  std::mt19937_64 rng(2024);
  std::map<Status, int> seen;
  for (int i = 0; i < 10000; ++i) {
    std::vector<std::uint8_t> b = good;
    const std::size_t bit = std::uniform_int_distribution<std::size_t>(0, b.size() * 8 - 1)(rng);
    b[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    const Status s = open_and_decode(b);
    ASSERT_NE(s, Status::Ok) << "flip of bit " << bit << " went unnoticed";
    ++seen[s];
  }
  for (const auto& [s, n] : seen)
    std::printf("[ figures ] bit flips -> %s: %d\n", status_name(s), n);
}

// The synthetic mesh never changes combinatorics: every element's topology blobs are the same
// blobs, stored once, and decoded elements alive at the same time share one Topology.
TEST(Asset, SharedTopologyRoundTripsWithEveryCodec) {
  const SyntheticAsset& a = small_asset();
  for (Codec codec : {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt, Codec::Draco}) {
    SCOPED_TRACE(codec_name(codec));
    const std::vector<std::uint8_t> bytes = small_file(codec);
    const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
    const std::vector<int> elems = feasible_elements(*r);
    ASSERT_GE(elems.size(), 2u);
    const fb::ElementMeshes* first = r->index().elements()->Get(0);
    for (int e : elems) {
      const fb::ElementMeshes* m =
          r->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
      for (auto [x, y] : {std::pair{m->tets(), first->tets()},
                          {m->triangles(), first->triangles()},
                          {m->triangle_tags(), first->triangle_tags()}}) {
        EXPECT_EQ(x->offset(), y->offset());
        EXPECT_EQ(x->size(), y->size());
        EXPECT_EQ(x->checksum(), y->checksum());
        EXPECT_EQ(x->codec(), y->codec());
      }
    }
    std::vector<DecodedElement> alive;
    for (int e : elems) {
      alive.push_back(r->decode_element(e));
      const ElementData& w = a.content.elements[static_cast<std::size_t>(e)];
      EXPECT_EQ(alive.back().topology, alive.front().topology) << "element " << e;
      EXPECT_TRUE(same(alive.back().topology->tets, w.tets));
      EXPECT_TRUE(same(alive.back().topology->triangles, w.triangles));
      EXPECT_TRUE(same(alive.back().topology->triangle_tags, w.triangle_tags));
      EXPECT_TRUE(same_terms(alive.back().positions, w.positions));
    }
    EXPECT_EQ(r->decode_topology(elems.back()), alive.front().topology);
    // Once released, the topology is decoded anew (the reader does not own it), with equal values.
    const Topology* old = alive.front().topology.get();
    const std::vector<std::uint32_t> tets(old->tets.begin(), old->tets.end());
    alive.clear();
    const DecodedElement again = r->decode_element(elems.front());
    EXPECT_TRUE(same(again.topology->tets, tets));
  }
}

// Stored once: the file is smaller than the sum of its references by the shared copies.
TEST(Asset, WriterStoresIdenticalBlobsOnce) {
  const std::vector<std::uint8_t> bytes = small_file();
  const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
  std::set<std::uint64_t> offsets;
  std::uint64_t referenced = 0, distinct = 0;
  for (int e : feasible_elements(*r)) {
    const fb::ElementMeshes* m = r->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
    std::vector<const fb::BlobRef*> refs = {m->tets(), m->triangles(), m->triangle_tags(),
                                            m->canonical_positions()};
    refs.insert(refs.end(), m->positions()->begin(), m->positions()->end());
    refs.insert(refs.end(), m->fields()->begin(), m->fields()->end());
    for (const fb::BlobRef* x : refs) {
      referenced += x->size();
      if (offsets.insert(x->offset()).second) distinct += x->size();
    }
  }
  EXPECT_EQ(distinct, bytes.size() - blob_section(bytes));
  const fb::ElementMeshes* m0 = r->index().elements()->Get(0);
  const std::size_t elements = feasible_elements(*r).size();
  EXPECT_GE(referenced - distinct, (elements - 1) * (m0->tets()->size() + m0->triangles()->size()));
  std::printf("[ figures ] %zu elements: %llu blob bytes referenced, %llu stored\n", elements,
              static_cast<unsigned long long>(referenced),
              static_cast<unsigned long long>(distinct));
}

// Identical references share a blob; any other overlap and any orphaned byte stay corruption.
TEST(Asset, OnlyIdenticalReferencesMayOverlap) {
  const std::vector<std::uint8_t> good = small_file();
  ASSERT_EQ(open_and_decode(good), Status::Ok);
  const auto r = AssetReader::open_memory(good.data(), good.size(), false);
  const std::vector<int> elems = feasible_elements(*r);
  const int e1 = elems[1];
  struct Case {
    const char* name;
    std::function<void(std::vector<std::uint8_t>&)> mutate;
  };
  const Case cases[] = {
      {"same range, other checksum",
       [&](auto& b) {
         auto* t = element_of(b, e1)->mutable_tets();
         t->mutate_checksum(t->checksum() ^ 1);
       }},
      {"same range, other codec",
       [&](auto& b) { element_of(b, e1)->mutable_tets()->mutate_codec(fb::Codec::Raw); }},
      {"same offset, shorter",
       [&](auto& b) {
         auto* t = element_of(b, e1)->mutable_tets();
         t->mutate_size(t->size() - 1);
       }},
      {"shared copy of a blob, its own bytes orphaned",
       [&](auto& b) {
         const fb::BlobRef* c0 = element_of(b, elems[0])->canonical_positions();
         const fb::BlobRef copy = *c0;
         *element_of(b, e1)->mutable_canonical_positions() = copy;
       }},
  };
  for (const Case& c : cases) {
    std::vector<std::uint8_t> b = good;
    c.mutate(b);
    rehash(b);
    EXPECT_EQ(open_status(b), Status::CorruptIndex) << c.name;
  }
}

// A flipped byte of a blob every element shares is reported by every one of them, never served
// from a topology decoded before.
TEST(Asset, CorruptSharedBlobIsReportedByEveryElementUsingIt) {
  for (Codec codec : {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt}) {
    SCOPED_TRACE(codec_name(codec));
    std::vector<std::uint8_t> b = small_file(codec);
    const auto good = AssetReader::open_memory(b.data(), b.size(), true);
    const std::vector<int> elems = feasible_elements(*good);
    for (auto which : {&fb::ElementMeshes::tets, &fb::ElementMeshes::triangles,
                       &fb::ElementMeshes::triangle_tags}) {
      std::vector<std::uint8_t> bad = b;
      const fb::BlobRef* ref = (good->index().elements()->Get(0)->*which)();
      bad[blob_section(bad) + ref->offset() + ref->size() / 2] ^= 0x20;
      const auto r = AssetReader::open_memory(bad.data(), bad.size(), false);
      for (int e : elems) {
        EXPECT_EQ(status_of([&] { r->decode_element(e); }), Status::ChecksumMismatch) << e;
        EXPECT_EQ(status_of([&] { r->decode_topology(e); }), Status::ChecksumMismatch) << e;
      }
    }
  }
}

// Fields are decoded apart from the meshes: a corrupt field blob fails decode_fields only.
TEST(Asset, FieldsDecodeSeparately) {
  std::vector<std::uint8_t> b = small_file();
  const auto good = AssetReader::open_memory(b.data(), b.size(), true);
  const fb::BlobRef* f = good->index().elements()->Get(0)->fields()->Get(1);
  b[blob_section(b) + f->offset() + f->size() / 2] ^= 0x01;
  const auto r = AssetReader::open_memory(b.data(), b.size(), false);
  EXPECT_EQ(status_of([&] { r->decode_element(0); }), Status::Ok);
  EXPECT_EQ(status_of([&] { r->decode_fields(0); }), Status::ChecksumMismatch);
  EXPECT_EQ(status_of([&] { r->decode_fields(0); }), Status::ChecksumMismatch) << "not cached";
}

// Non-finite values are caught by every codec's decode (in its output loop for lossless data).
TEST(Asset, NonFiniteValuesAreCorruptWithEveryCodec) {
  const float bad_values[] = {std::numeric_limits<float>::quiet_NaN(),
                              std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity()};
  for (Codec codec : {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt, Codec::Draco}) {
    SCOPED_TRACE(codec_name(codec));
    for (float v : bad_values) {
      for (int where = 0; where < 3; ++where) {  // canonical, a position array, a field array
        AssetContent c = small_asset().content;
        ElementData& ed = c.elements[0];
        const std::size_t i = 3 * (ed.vertex_count / 2) + 1;
        if (where == 0) ed.canonical[i] = v;
        if (where == 1) ed.positions[1][i] = v;
        if (where == 2) ed.fields[1][ed.fields[1].size() - 2] = v;
        WriteOptions o;
        o.float_codec = o.index_codec = codec;
        const std::vector<std::uint8_t> bytes = write_asset(c, o);
        const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
        EXPECT_EQ(status_of([&] { r->decode_element(0); }),
                  where < 2 ? Status::CorruptBlob : Status::Ok)
            << where;
        EXPECT_EQ(status_of([&] { r->decode_fields(0); }),
                  where == 2 ? Status::CorruptBlob : Status::Ok)
            << where;
      }
    }
  }
}

// Lossy positions are finite by construction (checked step, clamped values, finite canonical):
// the largest magnitudes the encoder accepts decode to finite values, within the bound.
TEST(Asset, LossyExtremesDecodeFinite) {
  for (Codec codec : {Codec::QuantDeltaZstd, Codec::Meshopt}) {
    SCOPED_TRACE(codec_name(codec));
    AssetContent c = small_asset().content;
    ElementData& ed = c.elements[0];
    ed.positions[0][0] = 0x1p126f;
    ed.positions[0][1] = -0x1p126f;
    ed.fields[0][0] = 0x1p126f;
    WriteOptions o;
    o.float_codec = o.index_codec = codec;
    o.position_max_abs_error = o.field_max_abs_error = 0x1p100;
    const std::vector<std::uint8_t> bytes = write_asset(c, o);
    const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
    const DecodedElement d = r->decode_element(0);
    EXPECT_TRUE(std::isfinite(d.positions[0][0]));
    EXPECT_NEAR(d.positions[0][0], 0x1p126, 0x1p101);
    EXPECT_TRUE(std::isfinite(r->decode_fields(0)[0][0]));
  }
}

// Elements large enough to be decoded by several threads (tets, positions and fields as tasks of
// one pool): the same values as the written content, and a corrupt blob anywhere gives the status
// a serial decode gives.
TEST(Asset, ParallelDecodeOfALargeElement) {
  SyntheticSpec spec;
  spec.K = 3;
  spec.cells[0] = 40;
  spec.cells[1] = 20;
  spec.cells[2] = 16;
  spec.max_samples = 27;
  spec.tolerance = 1e9;
  spec.check_face_centres = false;
  const SyntheticAsset a = make_synthetic_asset(spec);
  const ElementData& w = a.content.elements[0];
  ASSERT_GE(w.positions.size() * w.vertex_count * 3, std::size_t(1) << 18) << "not parallel";
  for (Codec codec : {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt}) {
    SCOPED_TRACE(codec_name(codec));
    WriteOptions o;
    o.float_codec = o.index_codec = codec;
    const std::vector<std::uint8_t> bytes = write_asset(a.content, o);
    const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
    const DecodedElement d = r->decode_element(0);
    EXPECT_TRUE(same(d.topology->tets, w.tets));
    EXPECT_TRUE(same(d.topology->triangles, w.triangles));
    EXPECT_TRUE(same(d.topology->triangle_tags, w.triangle_tags));
    EXPECT_TRUE(same_terms(d.positions, w.positions));
    EXPECT_TRUE(same_terms(r->decode_fields(0), w.fields));
    // One corrupt blob at a time: tets, the last term's positions, a field blob.
    const fb::ElementMeshes* m = r->index().elements()->Get(0);
    for (const fb::BlobRef* ref :
         {m->tets(), m->positions()->Get(m->positions()->size() - 1), m->fields()->Get(3)}) {
      std::vector<std::uint8_t> bad = bytes;
      bad[blob_section(bad) + ref->offset() + ref->size() / 3] ^= 0x40;
      const auto rb = AssetReader::open_memory(bad.data(), bad.size(), false);
      const Status s = ref == m->fields()->Get(3) ? status_of([&] { rb->decode_fields(0); })
                                                  : status_of([&] { rb->decode_element(0); });
      EXPECT_EQ(s, Status::ChecksumMismatch);
    }
  }
}

// Format 1.1: field units round-trip; a file stamps minor 1 only when it holds a unit, so an
// asset without units keeps the bytes (and the 1.0 stamp) a 1.0 writer gave it.
TEST(Asset, FieldUnitsRoundTripAndSetTheMinor) {
  const std::vector<std::uint8_t> plain = small_file();
  EXPECT_EQ(plain[10] | plain[11] << 8, 0);
  AssetContent c = small_asset().content;
  ASSERT_EQ(c.fields.size(), 2u);
  for (FieldInfo& f : c.fields) f.unit = "";
  EXPECT_EQ(write_asset(c, {}), write_asset(small_asset().content, {}));  // "" == absent
  c.fields[1].unit = "MPa";
  const std::vector<std::uint8_t> with = write_asset(c, {});
  EXPECT_EQ(with[10] | with[11] << 8, 1);
  const auto r = AssetReader::open_memory(with.data(), with.size(), false);
  EXPECT_EQ(r->format_minor(), 1);
  const auto* fields = r->index().fields();
  ASSERT_TRUE(fields && fields->size() == 2);
  EXPECT_EQ(fields->Get(0)->unit(), nullptr);
  ASSERT_NE(fields->Get(1)->unit(), nullptr);
  EXPECT_EQ(fields->Get(1)->unit()->str(), "MPa");
  EXPECT_EQ(open_and_decode(with), Status::Ok);
  // A NUL inside a unit (the C ABI hands it out NUL-terminated) is refused by both sides.
  c.fields[1].unit = std::string("M\0Pa", 4);
  EXPECT_THROW(write_asset(c, {}), FormatError);
  std::vector<std::uint8_t> b = with;
  const std::string needle = "MPa";
  auto at = std::search(b.begin() + kHeaderSize, b.end(), needle.begin(), needle.end());
  ASSERT_NE(at, b.end());
  at[1] = 0;
  rehash(b);
  EXPECT_EQ(open_and_decode(b), Status::CorruptIndex);
}

TEST(Asset, WriterRejectsInconsistentContent) {
  AssetContent c = small_asset().content;
  c.parameters.pop_back();
  EXPECT_THROW(write_asset(c, {}), FormatError);
  c = small_asset().content;
  c.elements[0].positions.pop_back();
  EXPECT_THROW(write_asset(c, {}), FormatError);
  c = small_asset().content;
  c.parameters[0].upper = 2.0;
  EXPECT_THROW(write_asset(c, {}), FormatError);
}

// Elements encoded ahead of writing (encode_element_meshes, as the builder holds them) give the
// asset their arrays give, byte for byte, with every codec and lossy or not; write_asset refuses
// them under other options than they were encoded with, or with a term missing, and
// encode_element_meshes refuses inconsistent arrays.
TEST(Asset, ElementsEncodedAheadWriteTheSameBytes) {
  for (Codec codec : {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt, Codec::Draco}) {
    SCOPED_TRACE(codec_name(codec));
    WriteOptions o;
    o.float_codec = codec;
    o.index_codec = codec;
    o.position_max_abs_error = codec == Codec::Raw ? 0.0 : 1e-4;
    o.field_max_abs_error = o.position_max_abs_error;
    AssetContent c = small_asset().content;
    std::size_t raw = 0, held = 0;
    for (ElementData& ed : c.elements) {
      if (ed.vertex_count == 0) continue;
      raw += element_array_bytes(ed);
      ed.encoded = std::make_shared<const EncodedMeshes>(encode_element_meshes(ed, o));
      held += ed.encoded->bytes();
      ed.positions.clear();
      ed.fields.clear();
      ed.canonical.clear();
      ed.tets.clear();
    }
    EXPECT_EQ(write_asset(c, o), write_asset(small_asset().content, o));
    if (codec != Codec::Raw) {
      EXPECT_LT(held, raw);
    }
    WriteOptions other = o;
    other.position_max_abs_error = 2e-4;
    try {
      write_asset(c, other);
      ADD_FAILURE() << "other options accepted";
    } catch (const FormatError& e) {
      EXPECT_NE(std::string(e.what()).find("encoded with other write options"), std::string::npos)
          << e.what();
    }
    std::size_t e = 0;
    while (c.elements[e].vertex_count == 0) ++e;
    auto fewer = std::make_shared<EncodedMeshes>(*c.elements[e].encoded);
    fewer->positions.pop_back();
    c.elements[e].encoded = fewer;
    EXPECT_THROW(write_asset(c, o), FormatError);
  }
  const ElementData& good = small_asset().content.elements[0];
  ASSERT_GT(good.vertex_count, 0u);
  ASSERT_FALSE(good.fields.empty());
  EXPECT_NO_THROW(encode_element_meshes(good, {}));
  ElementData ed = good;
  ed.positions[0].pop_back();
  EXPECT_THROW(encode_element_meshes(ed, {}), FormatError);
  ed = good;
  ed.fields.pop_back();
  EXPECT_THROW(encode_element_meshes(ed, {}), FormatError);
  ed = good;
  ed.encoded = std::make_shared<const EncodedMeshes>(encode_element_meshes(ed, {}));
  EXPECT_THROW(encode_element_meshes(ed, {}), FormatError) << "encoded twice";
}

// The geometry floor (format 1.3, error_model.h): written with an error model, read back, and a
// floor that is negative, NaN or without a model is refused by the writer and, edited into a
// file, by the reader.
TEST(Asset, GeometryFloorRoundTripsAndBadOnesAreRefused) {
  AssetContent c = small_asset().content;
  const std::size_t W = static_cast<std::size_t>(c.basis->dim() + 1) * (1 + c.fields.size());
  for (ElementData& ed : c.elements)
    if (ed.vertex_count > 0) {
      ed.error_model.assign(W, 0.01);
      ed.geometry_floor = 0.25;
    }
  std::vector<std::uint8_t> good = write_asset(c, {});
  const auto r = AssetReader::open_memory(good.data(), good.size(), true);
  const int e = feasible_elements(*r).at(0);
  EXPECT_EQ(r->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e))->geometry_floor(),
            0.25);
  for (double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    AssetContent d = c;
    d.elements[static_cast<std::size_t>(e)].geometry_floor = bad;
    EXPECT_THROW(write_asset(d, {}), FormatError) << bad;
    std::vector<std::uint8_t> b = good;
    ASSERT_TRUE(element_of(b, e)->mutate_geometry_floor(bad));
    rehash(b);
    EXPECT_EQ(open_status(b), Status::CorruptIndex) << bad;
  }
  AssetContent d = c;
  d.elements[static_cast<std::size_t>(e)].error_model.clear();
  EXPECT_THROW(write_asset(d, {}), FormatError) << "a floor without a model";
}

// The field floors (format 1.3, error_model.h): one per field, written with an error model and
// read back; a floor that is negative, NaN or infinite, a count other than the fields', or
// floors without a model are refused by the writer, and bad values edited into a file by the
// reader.
TEST(Asset, FieldFloorsRoundTripAndBadOnesAreRefused) {
  AssetContent c = small_asset().content;
  ASSERT_FALSE(c.fields.empty());
  const std::size_t W = static_cast<std::size_t>(c.basis->dim() + 1) * (1 + c.fields.size());
  for (ElementData& ed : c.elements)
    if (ed.vertex_count > 0) {
      ed.error_model.assign(W, 0.01);
      for (std::size_t f = 0; f < c.fields.size(); ++f)
        ed.field_floors.push_back(0.125 * static_cast<double>(f + 1));
    }
  std::vector<std::uint8_t> good = write_asset(c, {});
  const auto r = AssetReader::open_memory(good.data(), good.size(), true);
  const int e = feasible_elements(*r).at(0);
  const auto* m = r->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
  ASSERT_NE(m->field_floors(), nullptr);
  ASSERT_EQ(m->field_floors()->size(), c.fields.size());
  EXPECT_EQ(element_error_floor(*m, 0), 0.0) << "the geometry's floor is its own";
  for (std::size_t f = 0; f < c.fields.size(); ++f)
    EXPECT_EQ(element_error_floor(*m, static_cast<int>(f + 1)), 0.125 * static_cast<double>(f + 1));
  for (double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    AssetContent d = c;
    d.elements[static_cast<std::size_t>(e)].field_floors.back() = bad;
    EXPECT_THROW(write_asset(d, {}), FormatError) << bad;
    std::vector<std::uint8_t> b = good;
    auto* floors = element_of(b, e)->mutable_field_floors();
    floors->Mutate(floors->size() - 1, bad);
    rehash(b);
    EXPECT_EQ(open_status(b), Status::CorruptIndex) << bad;
  }
  AssetContent d = c;
  d.elements[static_cast<std::size_t>(e)].field_floors.push_back(0.5);
  EXPECT_THROW(write_asset(d, {}), FormatError) << "one floor more than fields";
  d = c;
  d.elements[static_cast<std::size_t>(e)].error_model.clear();
  EXPECT_THROW(write_asset(d, {}), FormatError) << "floors without a model";
}

}  // namespace
}  // namespace cadinterp::format

namespace cadinterp::format {
namespace {

// 10,000 random single-bit flips of each valid conformance asset: every one is reported, by
// open (header, index) or by decoding the element that owns the flipped blob byte. The one
// exception is by design: in an asset of a newer minor, a blob only unknown fields reference
// (k1_newer_minor's preview) is skipped by this reader (SPEC.md, "Versions and features").
TEST(Asset, EveryBitFlipOfEveryConformanceAssetIsReported) {
  int assets = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(CADINTERP_CONFORMANCE_DIR "/valid")) {
    std::ifstream in(entry.path() / "asset.cadi", std::ios::binary);
    const std::vector<std::uint8_t> good((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
    ASSERT_GT(good.size(), kHeaderSize) << entry.path();
    ++assets;
    // Owner element of every blob byte, from the intact file.
    const auto reader = AssetReader::open_memory(good.data(), good.size(), false);
    std::uint64_t index_size = 0;
    for (int i = 7; i >= 0; --i)
      index_size = (index_size << 8) | good[static_cast<std::size_t>(32 + i)];
    const std::uint64_t section = kHeaderSize + index_size;
    std::vector<int> owner(good.size() - section, -1);
    for (int e = 0; e < reader->basis().element_count(); ++e) {
      const fb::ElementMeshes* m =
          reader->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
      auto mark = [&](const fb::BlobRef* r) {
        if (r) std::fill_n(owner.begin() + static_cast<std::ptrdiff_t>(r->offset()), r->size(), e);
      };
      if (m->vertex_count() == 0) continue;
      mark(m->tets());
      mark(m->triangles());
      mark(m->triangle_tags());
      mark(m->canonical_positions());
      for (const fb::BlobRef* r : *m->positions()) mark(r);
      if (m->fields())
        for (const fb::BlobRef* r : *m->fields()) mark(r);
    }
    const bool newer = reader->format_minor() > kFormatMinor;
    if (!newer) {
      ASSERT_EQ(std::count(owner.begin(), owner.end(), -1), 0) << entry.path() << ": gaps";
    }
    std::mt19937_64 rng(7 + static_cast<unsigned>(assets));
    std::vector<std::uint8_t> b = good;
    for (int i = 0; i < 10000; ++i) {
      const std::size_t bit = std::uniform_int_distribution<std::size_t>(0, b.size() * 8 - 1)(rng);
      b[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
      Status s = Status::Ok;
      try {
        const auto r = AssetReader::open_memory(b.data(), b.size(), false);
        const std::size_t byte = bit / 8;
        ASSERT_GE(byte, section) << "a header or index flip passed open";
        if (newer && owner[byte - section] < 0) {  // a blob this reader does not know
          b[byte] = good[byte];
          continue;
        }
        r->decode_element(owner[byte - section]);
        r->decode_fields(owner[byte - section]);
      } catch (const FormatError& err) {
        s = err.status;
      }
      ASSERT_NE(s, Status::Ok) << entry.path() << ": flip of bit " << bit << " went unnoticed";
      b[bit / 8] = good[bit / 8];
    }
  }
  EXPECT_GE(assets, 6);
}

}  // namespace
}  // namespace cadinterp::format
