// cadinterp_open_options: the struct_size rule (too small, older, newer with a zero or nonzero
// tail), unknown flag bits, CADINTERP_OPEN_VERIFY_BLOBS and the cache budget, through the C ABI
// and the C++ wrapper.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp.hpp"
#include "cadinterp_generated.h"
#include "format/asset_reader.h"
#include "format/synthetic_asset.h"

namespace {

std::vector<std::uint8_t> synthetic_bytes() {
  cadinterp::format::SyntheticSpec s;
  s.K = 2;
  s.degree = cadinterp::core::Degree::Linear;
  s.tolerance = 2e-3;
  s.max_samples = 200;
  return cadinterp::format::write_asset(cadinterp::format::make_synthetic_asset(s).content, {});
}

// Opens `b` (not copied) with `o`; returns the status and leaves the asset in *a.
cadinterp_status open(const std::vector<std::uint8_t>& b, const cadinterp_open_options* o,
                      cadinterp_asset** a) {
  return cadinterp_open_memory_with_options(b.data(), b.size(), 0, o, a);
}

// Options from cadinterp_open_options_init with the budget and flags set.
cadinterp_open_options options(std::size_t budget, std::uint64_t flags) {
  cadinterp_open_options o;
  cadinterp_open_options_init(&o);
  o.cache_budget_bytes = budget;
  o.flags = flags;
  return o;
}

// Byte offset in the file of element e's canonical-positions blob (a blob no other element
// shares: the canonical mesh is the host at the element's centre).
std::size_t canonical_blob_byte(const std::vector<std::uint8_t>& b, int e) {
  const auto reader = cadinterp::format::AssetReader::open_memory(b.data(), b.size(), true);
  const auto* r = reader->index().elements()->Get(static_cast<unsigned>(e))->canonical_positions();
  std::uint64_t index_size = 0;
  std::memcpy(&index_size, b.data() + 32, 8);  // little-endian host (as the format)
  return static_cast<std::size_t>(48 + index_size + r->offset() + r->size() / 2);
}

TEST(OpenOptions, InitAndNullAreTheDefaults) {
  cadinterp_open_options o;
  std::memset(&o, 0xab, sizeof o);
  cadinterp_open_options_init(&o);
  EXPECT_EQ(o.struct_size, sizeof o);
  EXPECT_EQ(o.cache_budget_bytes, 0u);
  EXPECT_EQ(o.flags, 0u);
  EXPECT_EQ(sizeof o, CADINTERP_OPEN_OPTIONS_SIZE_1_0);  // no padding in the 1.0 struct
  cadinterp_open_options_init(nullptr);                  // no-op
  const auto b = synthetic_bytes();
  for (const cadinterp_open_options* opt : {&o, static_cast<cadinterp_open_options*>(nullptr)}) {
    cadinterp_asset* a = nullptr;
    ASSERT_EQ(open(b, opt, &a), CADINTERP_OK) << cadinterp_open_error();
    EXPECT_STREQ(cadinterp_open_error(), "");
    cadinterp_close(a);
  }
}

TEST(OpenOptions, StructSizeBelowTheFirstStructIsRefused) {
  const auto b = synthetic_bytes();
  cadinterp_open_options o;
  cadinterp_open_options_init(&o);
  for (const std::size_t n : {std::size_t(0), sizeof(std::size_t), sizeof o - 1}) {
    o.struct_size = n;
    cadinterp_asset* a = reinterpret_cast<cadinterp_asset*>(&o);  // must stay untouched
    EXPECT_EQ(open(b, &o, &a), CADINTERP_E_INVALID_ARGUMENT);
    EXPECT_EQ(a, reinterpret_cast<cadinterp_asset*>(&o));
    EXPECT_NE(std::string(cadinterp_open_error()).find("struct_size " + std::to_string(n)),
              std::string::npos)
        << cadinterp_open_error();
  }
}

// A newer caller's struct: larger, its unknown members zero (accepted) or set (refused, the
// message naming the first set byte).
TEST(OpenOptions, LargerStructNeedsAZeroTail) {
  const auto b = synthetic_bytes();
  struct Newer {
    cadinterp_open_options v1;
    std::uint64_t future_member;
  } n{};
  cadinterp_open_options_init(&n.v1);
  n.v1.struct_size = sizeof n;
  n.v1.cache_budget_bytes = 1 << 20;
  cadinterp_asset* a = nullptr;
  ASSERT_EQ(open(b, &n.v1, &a), CADINTERP_OK) << cadinterp_open_error();
  cadinterp_close(a);
  a = nullptr;
  reinterpret_cast<unsigned char*>(&n.future_member)[3] = 1;
  EXPECT_EQ(open(b, &n.v1, &a), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(a, nullptr);
  EXPECT_NE(std::string(cadinterp_open_error())
                .find("options byte " + std::to_string(sizeof(cadinterp_open_options) + 3)),
            std::string::npos)
      << cadinterp_open_error();
}

TEST(OpenOptions, UnknownFlagBitsAreRefusedByName) {
  const auto b = synthetic_bytes();
  const cadinterp_open_options o =
      options(0, CADINTERP_OPEN_VERIFY_BLOBS | (std::uint64_t(1) << 40) | 4);
  cadinterp_asset* a = nullptr;
  EXPECT_EQ(open(b, &o, &a), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(a, nullptr);
  EXPECT_STREQ(cadinterp_open_error(), "unknown option flag bits 0x10000000004");
  // The file variant applies the same rules.
  EXPECT_EQ(cadinterp_open_with_options("/nonexistent.cadi", &o, &a), CADINTERP_E_INVALID_ARGUMENT);
}

// A corrupt blob opens by default (found when an evaluation decodes it) and fails the open with
// CADINTERP_OPEN_VERIFY_BLOBS.
TEST(OpenOptions, VerifyBlobsFindsACorruptBlobAtOpen) {
  auto b = synthetic_bytes();
  const cadinterp_open_options o = options(0, CADINTERP_OPEN_VERIFY_BLOBS);
  cadinterp_asset* a = nullptr;
  ASSERT_EQ(open(b, &o, &a), CADINTERP_OK) << cadinterp_open_error();
  cadinterp_close(a);
  a = nullptr;
  b[canonical_blob_byte(b, 0)] ^= 0x10;
  ASSERT_EQ(open(b, nullptr, &a), CADINTERP_OK);
  cadinterp_close(a);
  a = nullptr;
  EXPECT_EQ(open(b, &o, &a), CADINTERP_E_CHECKSUM);
  EXPECT_EQ(a, nullptr);
  EXPECT_NE(std::string(cadinterp_open_error()).find("checksum"), std::string::npos);
}

// The budget given at open is the cache's: element A is evaluated, then B, then A's bytes are
// changed under the (uncopied) asset. With the default budget A is still cached and evaluates;
// with a budget of 1 byte only B stayed, so A is decoded again and its checksum fails. (Changing
// the bytes breaks open_memory's contract on purpose: it makes a decode observable.)
TEST(OpenOptions, CacheBudgetIsHonoured) {
  const double xa[2] = {0.1, 0.1}, xb[2] = {0.9, 0.8};
  for (const std::size_t budget : {std::size_t(0), std::size_t(1)}) {
    auto b = synthetic_bytes();
    const cadinterp_open_options o = options(budget, 0);
    cadinterp_asset* a = nullptr;
    ASSERT_EQ(open(b, &o, &a), CADINTERP_OK) << cadinterp_open_error();
    cadinterp_workspace* ws = nullptr;
    ASSERT_EQ(cadinterp_workspace_create(a, &ws), CADINTERP_OK);
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(ws, xa, nullptr, 0, &m), CADINTERP_OK);
    const int element_a = m.element;
    ASSERT_EQ(cadinterp_eval(ws, xb, nullptr, 0, &m), CADINTERP_OK);
    ASSERT_NE(m.element, element_a);
    b[canonical_blob_byte(b, element_a)] ^= 0x10;
    EXPECT_EQ(cadinterp_eval(ws, xa, nullptr, 0, &m),
              budget == 0 ? CADINTERP_OK : CADINTERP_E_CHECKSUM)
        << "budget " << budget;
    cadinterp_workspace_destroy(ws);
    cadinterp_close(a);
  }
}

TEST(OpenOptions, CppWrapperPassesOptions) {
  const auto b = synthetic_bytes();
  const cadinterp::Asset a = cadinterp::Asset::open_memory(
      b.data(), b.size(), true, cadinterp::Asset::options(1 << 20, CADINTERP_OPEN_VERIFY_BLOBS));
  EXPECT_EQ(a.parameter_count(), 2);
  try {
    cadinterp::Asset::open_memory(b.data(), b.size(), true, cadinterp::Asset::options(0, 2));
    FAIL() << "unknown flag accepted";
  } catch (const cadinterp::Error& e) {
    EXPECT_EQ(e.status(), CADINTERP_E_INVALID_ARGUMENT);
    EXPECT_NE(std::string(e.what()).find("0x2"), std::string::npos);
  }
}

}  // namespace
