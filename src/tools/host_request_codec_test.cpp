// The request bytes both transports carry (host_request_codec.h): a request survives the round
// trip exactly, and every malformed message is refused by name without reading past its end.
#include "host_request_codec.h"

#include <gtest/gtest.h>

#include <cstring>
#include <stdexcept>
#include <vector>

namespace cadinterp::tools::request_codec {
namespace {

// One tet with its four faces.
const double kVertices[] = {0, 0, 0, 10, 0, 0, 0, 10, 0, 0, 0, 10};
const std::uint32_t kTets[] = {0, 1, 2, 3};
const std::uint32_t kTriangles[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
const std::int32_t kTags[] = {1, 2, 3, -4};
const cadinterp_host_mesh kMesh{4, kVertices, 1, kTets, 4, kTriangles, kTags};
const std::vector<double> kX{1.5, -2.25, 1e300};

std::vector<std::uint8_t> simulate_bytes() {
  return encode(CADINTERP_REQUEST_SIMULATE, kX.data(), kX.size(), &kMesh);
}

DecodeError decode_bytes(const std::vector<std::uint8_t>& bytes, std::size_t k = 3) {
  Request r;
  return decode(bytes.data(), bytes.size(), k, &r);
}

// Overwrites the uint64 header word `index` (0 kind, 1 K, 2-4 the mesh counts).
std::vector<std::uint8_t> with_word(std::vector<std::uint8_t> bytes, int index,
                                    std::uint64_t value) {
  std::memcpy(bytes.data() + 8 * index, &value, 8);
  return bytes;
}

TEST(RequestCodec, SampleRoundTrip) {
  const std::vector<std::uint8_t> bytes =
      encode(CADINTERP_REQUEST_SAMPLE, kX.data(), kX.size(), nullptr);
  EXPECT_EQ(bytes.size(), 16 + 3 * sizeof(double));
  Request r;
  ASSERT_EQ(decode(bytes.data(), bytes.size(), 3, &r), DecodeError::kNone);
  EXPECT_EQ(r.kind, CADINTERP_REQUEST_SAMPLE);
  EXPECT_EQ(r.x, kX);
  EXPECT_TRUE(r.vertices.empty() && r.tets.empty() && r.triangles.empty() && r.tags.empty());
}

TEST(RequestCodec, SimulateRoundTrip) {
  const std::vector<std::uint8_t> bytes = simulate_bytes();
  Request r;
  ASSERT_EQ(decode(bytes.data(), bytes.size(), 3, &r), DecodeError::kNone);
  EXPECT_EQ(r.kind, CADINTERP_REQUEST_SIMULATE);
  EXPECT_EQ(r.x, kX);
  const cadinterp_host_mesh m = r.mesh();
  ASSERT_EQ(m.vertex_count, 4u);
  ASSERT_EQ(m.tet_count, 1u);
  ASSERT_EQ(m.triangle_count, 4u);
  EXPECT_EQ(std::memcmp(m.vertices, kVertices, sizeof kVertices), 0);
  EXPECT_EQ(std::memcmp(m.tets, kTets, sizeof kTets), 0);
  EXPECT_EQ(std::memcmp(m.triangles, kTriangles, sizeof kTriangles), 0);
  EXPECT_EQ(std::memcmp(m.triangle_tags, kTags, sizeof kTags), 0);
  // Re-encoding the decoded request gives the same bytes.
  EXPECT_EQ(encode(r.kind, r.x.data(), r.x.size(), &m), bytes);
}

TEST(RequestCodec, EmptyMeshAndNoParameters) {
  const cadinterp_host_mesh empty{0, nullptr, 0, nullptr, 0, nullptr, nullptr};
  const std::vector<std::uint8_t> bytes = encode(CADINTERP_REQUEST_SIMULATE, nullptr, 0, &empty);
  Request r;
  ASSERT_EQ(decode(bytes.data(), bytes.size(), 0, &r), DecodeError::kNone);
  EXPECT_EQ(r.mesh().vertex_count, 0u);
  EXPECT_TRUE(r.x.empty());
}

TEST(RequestCodec, EveryTruncationIsRefused) {
  const std::vector<std::uint8_t> bytes = simulate_bytes();
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    // A copy of exactly n bytes, so that a read past the end is an error under ASan.
    const std::vector<std::uint8_t> prefix(bytes.begin(), bytes.begin() + n);
    Request r;
    EXPECT_EQ(decode(prefix.data(), prefix.size(), 3, &r), DecodeError::kTruncated) << n;
  }
}

TEST(RequestCodec, MalformedHeadersAreNamed) {
  const std::vector<std::uint8_t> bytes = simulate_bytes();
  EXPECT_EQ(decode_bytes(with_word(bytes, 0, 0)), DecodeError::kWrongKind);
  EXPECT_EQ(decode_bytes(with_word(bytes, 0, 3)), DecodeError::kWrongKind);
  EXPECT_EQ(decode_bytes(bytes, 2), DecodeError::kWrongParameterCount);
  EXPECT_EQ(decode_bytes(with_word(bytes, 1, ~std::uint64_t{0})),
            DecodeError::kWrongParameterCount);
  // Counts that no message could carry, including ones whose byte sizes would overflow.
  for (int word = 2; word <= 4; ++word) {
    EXPECT_EQ(decode_bytes(with_word(bytes, word, ~std::uint64_t{0})), DecodeError::kOversizeCount)
        << word;
    EXPECT_EQ(decode_bytes(with_word(bytes, word, std::uint64_t{1} << 62)),
              DecodeError::kOversizeCount)
        << word;
    // Larger than the arrays that follow, but not than the message: the arrays run short.
    EXPECT_EQ(decode_bytes(with_word(bytes, word, bytes.size() / 2)), DecodeError::kTruncated)
        << word;
  }
  // A sample's bytes read as a simulate request: the "counts" are x's doubles, the arrays short.
  std::vector<std::uint8_t> sample = encode(CADINTERP_REQUEST_SAMPLE, kX.data(), 3, nullptr);
  const DecodeError as_simulate = decode_bytes(with_word(sample, 0, CADINTERP_REQUEST_SIMULATE));
  EXPECT_TRUE(as_simulate == DecodeError::kOversizeCount || as_simulate == DecodeError::kTruncated);
  sample.push_back(0);
  EXPECT_EQ(decode_bytes(sample), DecodeError::kTrailingBytes);
  EXPECT_STREQ(describe(DecodeError::kOversizeCount),
               "a count in the request is larger than the request itself");
}

TEST(RequestCodec, EncodeRefusesAMismatchedMesh) {
  EXPECT_THROW(encode(CADINTERP_REQUEST_SAMPLE, kX.data(), 3, &kMesh), std::invalid_argument);
  EXPECT_THROW(encode(CADINTERP_REQUEST_SIMULATE, kX.data(), 3, nullptr), std::invalid_argument);
  EXPECT_THROW(encode(7, kX.data(), 3, nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace cadinterp::tools::request_codec
