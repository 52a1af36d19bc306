#include <gtest/gtest.h>
#include <xxhash.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>

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

// Opens and decodes everything; returns the first error's status (Ok if none).
Status open_and_decode(const std::vector<std::uint8_t>& bytes) {
  try {
    const auto r = AssetReader::open_memory(bytes.data(), bytes.size(), false);
    for (int e = 0; e < r->basis().element_count(); ++e) r->decode_element(e);
    return Status::Ok;
  } catch (const FormatError& err) {
    return err.status;
  }
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
      EXPECT_EQ(d.tets, w.tets);
      EXPECT_EQ(d.triangles, w.triangles);
      EXPECT_EQ(d.triangle_tags, w.triangle_tags);
      EXPECT_EQ(d.canonical, w.canonical);
      EXPECT_EQ(d.positions, w.positions);
      EXPECT_EQ(d.fields, w.fields);
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
  EXPECT_EQ(r->decode_element(0).positions, small_asset().content.elements[0].positions);
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
      {"newer minor", Status::UnsupportedVersion, [](auto& b, auto) { set_le(b, 10, 1, 2); }},
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

}  // namespace
}  // namespace cadinterp::format

namespace cadinterp::format {
namespace {

// 10,000 random single-bit flips of each valid conformance asset: every one is reported, by
// open (header, index) or by decoding the element that owns the flipped blob byte.
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
        r->decode_element(owner[byte - section]);
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
