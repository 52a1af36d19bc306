// Round trips, error bounds, argument checks and hostile input for every codec (codec.h).
#include "format/codec.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>

#include "format/codec_test_data.h"

namespace cadinterp::format {
namespace {

using Kind = CodecError::Kind;
constexpr Codec kAllCodecs[] = {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt, Codec::Draco};

// One float array to code: rows x comps, with an optional reference, and the bound to use.
struct FloatCase {
  std::string name;
  const std::vector<float>* data;
  const std::vector<float>* ref;  // null: no reference
  int comps;
  double max_abs_error;
};

// A smooth 9-component per-vertex array (a symmetric tensor field written in full).
std::vector<float> tensor_field(const std::vector<float>& pos) {
  std::vector<float> t;
  for (std::size_t i = 0; i + 2 < pos.size(); i += 3) {
    const double x = pos[i], y = pos[i + 1], z = pos[i + 2];
    const double s[6] = {1e5 * std::sin(x),     2e4 * std::cos(y) * z, -3e4 * x * y,
                         5e4 * std::cos(x + z), 1e4 * std::sin(2 * y), 7e4 * z * z};
    const int map[9] = {0, 3, 4, 3, 1, 5, 4, 5, 2};
    for (int k : map) t.push_back(static_cast<float>(s[k]));
  }
  return t;
}

double max_abs(const std::vector<float>& v) {
  double m = 0.0;
  for (float x : v) m = std::max(m, std::fabs(double(x)));
  return m;
}

double value_range(const std::vector<float>& v) {
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return static_cast<double>(*hi) - static_cast<double>(*lo);
}

struct Data {
  testdata::BoxMesh mesh;
  std::vector<float> tensor;
  double diag;
  Data(int nx, int ny, int nz, testdata::Layout layout)
      : mesh(testdata::make_box_mesh(nx, ny, nz, 0.05, layout)) {
    tensor = tensor_field(mesh.canonical);
    diag = testdata::bbox_diagonal(mesh.canonical);
  }
  std::vector<FloatCase> cases() const {
    const double pe = 1e-4 * diag;
    return {
        {"positions_lossless", &mesh.canonical, nullptr, 3, 0.0},
        {"positions_lossy", &mesh.canonical, nullptr, 3, pe},
        {"sample_vs_ref_lossless", &mesh.sample, &mesh.canonical, 3, 0.0},
        {"sample_vs_ref_lossy", &mesh.sample, &mesh.canonical, 3, pe},
        {"field_lossless", &mesh.field, nullptr, 1, 0.0},
        {"field_lossy", &mesh.field, nullptr, 1, 1e-4 * value_range(mesh.field)},
        {"tensor_lossless", &tensor, nullptr, 9, 0.0},
        {"tensor_lossy", &tensor, nullptr, 9, 1e-4 * value_range(tensor)},
    };
  }
};

const Data& small_data() {
  static const Data d(6, 5, 4, testdata::Layout::Irregular);
  return d;
}
const Data& test_data() {
  static const Data d(30, 20, 10, testdata::Layout::Grid);
  return d;
}
const Data& irregular_data() {
  static const Data d(30, 20, 10, testdata::Layout::Irregular);
  return d;
}

std::size_t rows_of(const FloatCase& c) { return c.data->size() / c.comps; }

std::vector<std::uint8_t> encode(Codec codec, const FloatCase& c) {
  return encode_floats(codec, c.data->data(), rows_of(c), c.comps, c.ref ? c.ref->data() : nullptr,
                       FloatParams{c.max_abs_error});
}

template <typename F>
Kind error_kind(F&& f) {
  try {
    f();
  } catch (const CodecError& e) {
    return e.kind;
  }
  ADD_FAILURE() << "no CodecError thrown";
  return Kind::Corrupt;
}

class CodecTest : public ::testing::TestWithParam<Codec> {};

std::string codec_param_name(const ::testing::TestParamInfo<Codec>& info) {
  std::string s = codec_name(info.param);
  for (char& ch : s) ch = ch == '-' ? '_' : ch;
  return s;
}

void box_mesh_is_consistent(const testdata::BoxMesh& m) {
  EXPECT_EQ(m.vertex_count(), 31u * 21u * 11u);
  EXPECT_EQ(m.tet_count(), 30u * 20u * 10u * 6u);
  EXPECT_EQ(m.tri_count(), 2u * 2u * (30u * 20u + 20u * 10u + 30u * 10u));
  // Every tet has positive volume (the deformation keeps orientation).
  for (std::size_t t = 0; t < m.tet_count(); ++t) {
    const float* p[4];
    for (int k = 0; k < 4; ++k) p[k] = &m.canonical[3 * m.tets[4 * t + k]];
    double e[3][3];
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 3; ++c) e[a][c] = double(p[a + 1][c]) - double(p[0][c]);
    const double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                       e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                       e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
    ASSERT_GT(det, 0.0) << "tet " << t;
  }
}

TEST(CodecTestData, BoxMeshIsConsistent) {
  for (const Data* d : {&test_data(), &irregular_data()}) {
    box_mesh_is_consistent(d->mesh);
  }
}

TEST(CodecNames, AreFixed) {
  EXPECT_STREQ(codec_name(Codec::Raw), "raw");
  EXPECT_STREQ(codec_name(Codec::QuantDeltaZstd), "quant-delta-zstd");
  EXPECT_STREQ(codec_name(Codec::Meshopt), "meshopt");
  EXPECT_STREQ(codec_name(Codec::Draco), "draco");
  EXPECT_STREQ(codec_name(static_cast<Codec>(9)), "unknown");
  EXPECT_TRUE(codec_is_known(3));
  EXPECT_FALSE(codec_is_known(4));
  // The values are written to files.
  EXPECT_EQ(static_cast<int>(Codec::Raw), 0);
  EXPECT_EQ(static_cast<int>(Codec::QuantDeltaZstd), 1);
  EXPECT_EQ(static_cast<int>(Codec::Meshopt), 2);
  EXPECT_EQ(static_cast<int>(Codec::Draco), 3);
}

// --- Round trips ------------------------------------------------------------------------------

void expect_round_trip(Codec codec, const FloatCase& c) {
  SCOPED_TRACE(c.name);
  const std::size_t rows = rows_of(c), n = c.data->size();
  const std::vector<std::uint8_t> blob = encode(codec, c);
  std::vector<float> out(n);
  decode_floats(codec, blob.data(), blob.size(), rows, c.comps, c.ref ? c.ref->data() : nullptr,
                out.data());
  if (c.max_abs_error == 0.0 || codec == Codec::Raw) {
    EXPECT_EQ(0, std::memcmp(out.data(), c.data->data(), n * 4)) << "lossless must be bit-exact";
    return;
  }
  double worst = 0.0, worst_ratio = 0.0;
  // All arrays here have bounds far above float32 resolution: the strict case of FloatParams.
  ASSERT_TRUE(strict_error_bound(c.max_abs_error, max_abs(*c.data)));
  for (std::size_t i = 0; i < n; ++i) {
    const float v = (*c.data)[i];
    const double err = std::fabs(double(out[i]) - double(v));
    const double bound = c.max_abs_error;
    ASSERT_LE(err, bound) << "value " << i << " = " << v << " decoded " << out[i];
    worst = std::max(worst, err);
    worst_ratio = std::max(worst_ratio, err / c.max_abs_error);
  }
  // The bound is used, not wasted: quantization errors reach a good part of max_abs_error.
  EXPECT_GT(worst_ratio, 0.25) << "max error " << worst << " for bound " << c.max_abs_error;
  EXPECT_LT(blob.size(), n * 4 / 2) << "lossy coding should at least halve the size";
}

TEST_P(CodecTest, FloatRoundTrip) {
  for (const FloatCase& c : test_data().cases()) expect_round_trip(GetParam(), c);
}

TEST_P(CodecTest, FloatRoundTripIrregularMesh) {
  for (const FloatCase& c : irregular_data().cases()) expect_round_trip(GetParam(), c);
}

void expect_index_round_trip(Codec codec, const testdata::BoxMesh& m) {
  const auto vc = static_cast<std::uint32_t>(m.vertex_count());
  // Boundary triangles: same triangles, same order, same corner order.
  std::vector<std::uint8_t> blob = encode_indices(codec, m.tris.data(), m.tri_count(), 3, vc);
  std::vector<std::uint32_t> out(m.tris.size());
  decode_indices(codec, blob.data(), blob.size(), m.tri_count(), 3, vc, out.data());
  EXPECT_EQ(out, m.tris);
  if (codec != Codec::Raw) {
    EXPECT_LT(blob.size(), m.tris.size() * 4 / 2);
  }

  if (codec == Codec::Draco) {
    EXPECT_EQ(Kind::Unsupported,
              error_kind([&] { encode_indices(codec, m.tets.data(), m.tet_count(), 4, vc); }));
    return;
  }
  blob = encode_indices(codec, m.tets.data(), m.tet_count(), 4, vc);
  out.assign(m.tets.size(), 0);
  decode_indices(codec, blob.data(), blob.size(), m.tet_count(), 4, vc, out.data());
  EXPECT_EQ(out, m.tets);
  if (codec != Codec::Raw) {
    EXPECT_LT(blob.size(), m.tets.size() * 4 / 2);
  }
}

TEST_P(CodecTest, IndexRoundTrip) {
  expect_index_round_trip(GetParam(), test_data().mesh);
  expect_index_round_trip(GetParam(), irregular_data().mesh);
}

TEST_P(CodecTest, EmptyAndTinyArrays) {
  const Codec codec = GetParam();
  for (double e : {0.0, 1e-3}) {
    for (std::size_t rows : {0u, 1u, 2u}) {
      for (int comps : {1, 3, kMaxComps}) {
        std::vector<float> v(rows * comps), ref(rows * comps), out(rows * comps + 1, -7.f);
        for (std::size_t i = 0; i < v.size(); ++i) {
          v[i] = 0.25f * static_cast<float>(i) - 3.f;
          ref[i] = v[i] + 0.01f;
        }
        for (const float* r :
             {static_cast<const float*>(nullptr), static_cast<const float*>(ref.data())}) {
          const auto blob = encode_floats(codec, v.data(), rows, comps, r, FloatParams{e});
          decode_floats(codec, blob.data(), blob.size(), rows, comps, r, out.data());
          for (std::size_t i = 0; i < v.size(); ++i) {
            ASSERT_LE(std::fabs(out[i] - v[i]), float_error_bound(e, v[i]));
          }
          EXPECT_EQ(out[v.size()], -7.f) << "wrote past rows * comps";
        }
      }
    }
  }
  for (int per_row : {3, 4}) {
    if (codec == Codec::Draco && per_row == 4) continue;
    for (std::size_t rows : {0u, 1u}) {
      std::vector<std::uint32_t> idx(rows * per_row), out(idx.size() + 1, 77);
      for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<std::uint32_t>(i);
      const auto blob = encode_indices(codec, idx.data(), rows, per_row, 5);
      decode_indices(codec, blob.data(), blob.size(), rows, per_row, 5, out.data());
      for (std::size_t i = 0; i < idx.size(); ++i) EXPECT_EQ(out[i], idx[i]);
      EXPECT_EQ(out[idx.size()], 77u);
    }
  }
}

// Lossless mode keeps every bit pattern: NaN payloads, infinities, signed zeros, denormals.
TEST_P(CodecTest, LosslessKeepsSpecialValues) {
  const Codec codec = GetParam();
  std::vector<float> v = {0.f,
                          -0.f,
                          1.f,
                          -1.f,
                          std::numeric_limits<float>::infinity(),
                          -std::numeric_limits<float>::infinity(),
                          std::numeric_limits<float>::denorm_min(),
                          std::numeric_limits<float>::max(),
                          std::numeric_limits<float>::lowest()};
  const std::uint32_t nan_bits[] = {0x7fc00001u, 0xffa5a5a5u, 0x7f800001u};
  for (std::uint32_t b : nan_bits) {
    float f;
    std::memcpy(&f, &b, 4);
    v.push_back(f);
  }
  const std::vector<float> ref(v.rbegin(), v.rend());
  for (const float* r : {static_cast<const float*>(nullptr), ref.data()}) {
    const auto blob = encode_floats(codec, v.data(), v.size(), 1, r, FloatParams{});
    std::vector<float> out(v.size());
    decode_floats(codec, blob.data(), blob.size(), v.size(), 1, r, out.data());
    EXPECT_EQ(0, std::memcmp(out.data(), v.data(), v.size() * 4));
  }
}

// decode_floats_finite: the same values as decode_floats, and false exactly when one of them is
// inf or NaN, wherever it lies (blocked loops: block starts, ends and the tail).
TEST_P(CodecTest, DecodeFloatsFiniteFindsEveryNonFiniteValue) {
  const Codec codec = GetParam();
  const std::uint32_t specials[] = {0x7f800000u, 0xff800000u, 0x7fc00000u, 0xffa5a5a5u};
  for (std::size_t n : {std::size_t(1), std::size_t(63), std::size_t(64), std::size_t(65),
                        std::size_t(1000), std::size_t(4097)}) {
    std::vector<float> v(n), ref(n);
    for (std::size_t i = 0; i < n; ++i) {
      v[i] = std::sin(0.01f * static_cast<float>(i)) * 10.0f;
      ref[i] = v[i] * 0.5f;
    }
    for (const float* r :
         {static_cast<const float*>(nullptr), static_cast<const float*>(ref.data())}) {
      SCOPED_TRACE(std::to_string(n) + (r ? " with reference" : ""));
      std::vector<float> out(n), plain(n);
      auto blob = encode_floats(codec, v.data(), n, 1, r, FloatParams{});
      EXPECT_TRUE(decode_floats_finite(codec, blob.data(), blob.size(), n, 1, r, out.data()));
      EXPECT_EQ(0, std::memcmp(out.data(), v.data(), n * 4));
      blob = encode_floats(codec, v.data(), n, 1, r, FloatParams{1e-3});
      EXPECT_TRUE(decode_floats_finite(codec, blob.data(), blob.size(), n, 1, r, out.data()));
      for (std::size_t at : {std::size_t(0), std::size_t(63), std::size_t(64), n / 2, n - 1}) {
        if (at >= n) continue;
        for (std::uint32_t bits : specials) {
          std::vector<float> w = v;
          std::memcpy(&w[at], &bits, 4);
          blob = encode_floats(codec, w.data(), n, 1, r, FloatParams{});
          EXPECT_FALSE(decode_floats_finite(codec, blob.data(), blob.size(), n, 1, r, out.data()))
              << "at " << at;
          decode_floats(codec, blob.data(), blob.size(), n, 1, r, plain.data());
          EXPECT_EQ(0, std::memcmp(out.data(), plain.data(), n * 4));
        }
      }
    }
  }
}

// The bound holds for values across many magnitudes, far from their reference, and for small
// max_abs_error relative to the values (where float32 rounding is the larger part).
TEST_P(CodecTest, LossyBoundOnHardValues) {
  const Codec codec = GetParam();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double e : {1e-7, 1e-3, 0.5, 1e3}) {
    for (bool with_ref : {false, true}) {
      const std::size_t rows = 3000;
      std::vector<float> v(rows * 2), ref(rows * 2);
      for (std::size_t i = 0; i < v.size(); ++i) {
        // 1e-4 .. 1e4, capped so that |v - ref| / step stays below 2^31.
        const double mag = std::min(std::pow(10.0, 4.0 * u(rng)), 1e8 * e);
        v[i] = static_cast<float>(mag * u(rng));
        ref[i] = static_cast<float>(v[i] + 300.0 * e * u(rng));
      }
      const float* r = with_ref ? ref.data() : nullptr;
      std::vector<std::uint8_t> blob;
      try {
        blob = encode_floats(codec, v.data(), rows, 2, r, FloatParams{e});
      } catch (const CodecError& err) {
        // Draco quantizes with one step for the whole array: 1e4 / 1e-7 needs 37 bits.
        ASSERT_EQ(codec, Codec::Draco) << err.what();
        EXPECT_EQ(err.kind, Kind::Unsupported);
        continue;
      }
      std::vector<float> out(v.size());
      decode_floats(codec, blob.data(), blob.size(), rows, 2, r, out.data());
      const bool strict = strict_error_bound(e, max_abs(v));
      // Both cases of FloatParams are exercised: values up to 1e4 need e >= 2^-22 * 1e4.
      EXPECT_EQ(strict, e >= 0.5) << e;
      for (std::size_t i = 0; i < v.size(); ++i) {
        ASSERT_LE(std::fabs(double(out[i]) - double(v[i])), strict ? e : float_error_bound(e, v[i]))
            << "e=" << e << " v=" << v[i] << " ref=" << (r ? r[i] : 0.f);
      }
    }
  }
}

TEST_P(CodecTest, ReferenceRequiredIffCodedAgainstOne) {
  const Codec codec = GetParam();
  const auto& d = small_data();
  for (double e : {0.0, 1e-4}) {
    const FloatCase c{"sample", &d.mesh.sample, &d.mesh.canonical, 3, e};
    const auto blob = encode(codec, c);
    std::vector<float> out(c.data->size());
    const bool uses_ref = codec != Codec::Raw && !(codec == Codec::Draco && e == 0.0);
    if (uses_ref) {
      EXPECT_EQ(Kind::InvalidArgument, error_kind([&] {
                  decode_floats(codec, blob.data(), blob.size(), rows_of(c), 3, nullptr,
                                out.data());
                }));
    }
    // A blob coded without a reference ignores one given to the decoder.
    const FloatCase plain{"plain", &d.mesh.sample, nullptr, 3, e};
    const auto pb = encode(codec, plain);
    std::vector<float> with_ref(out.size()), without(out.size());
    decode_floats(codec, pb.data(), pb.size(), rows_of(plain), 3, d.mesh.canonical.data(),
                  with_ref.data());
    decode_floats(codec, pb.data(), pb.size(), rows_of(plain), 3, nullptr, without.data());
    EXPECT_EQ(0, std::memcmp(with_ref.data(), without.data(), out.size() * 4));
  }
}

TEST_P(CodecTest, ShapeMismatchIsCorrupt) {
  const Codec codec = GetParam();
  const auto& d = small_data();
  const FloatCase c{"positions", &d.mesh.canonical, nullptr, 3, 1e-4};
  const auto blob = encode(codec, c);
  const std::size_t rows = rows_of(c);
  std::vector<float> out(c.data->size() * 2);
  EXPECT_EQ(Kind::Corrupt, error_kind([&] {
              decode_floats(codec, blob.data(), blob.size(), rows - 1, 3, nullptr, out.data());
            }));
  EXPECT_EQ(Kind::Corrupt, error_kind([&] {
              decode_floats(codec, blob.data(), blob.size(), rows, 2, nullptr, out.data());
            }));
  const auto& m = d.mesh;
  const auto vc = static_cast<std::uint32_t>(m.vertex_count());
  const auto ib = encode_indices(codec, m.tris.data(), m.tri_count(), 3, vc);
  std::vector<std::uint32_t> iout(m.tris.size() + 3);
  EXPECT_EQ(Kind::Corrupt, error_kind([&] {
              decode_indices(codec, ib.data(), ib.size(), m.tri_count() + 1, 3, vc, iout.data());
            }));
  if (codec != Codec::Raw) {  // raw has no header: a smaller vertex_count is caught by the check
    EXPECT_EQ(Kind::Corrupt, error_kind([&] {
                decode_indices(codec, ib.data(), ib.size(), m.tri_count(), 3, vc + 1, iout.data());
              }));
  }
  // Every index is checked against vertex_count (raw has nothing else to catch a smaller one).
  const auto rb = encode_indices(Codec::Raw, m.tris.data(), m.tri_count(), 3, vc);
  EXPECT_EQ(Kind::Corrupt, error_kind([&] {
              decode_indices(Codec::Raw, rb.data(), rb.size(), m.tri_count(), 3, vc - 1,
                             iout.data());
            }));
}

// --- Bad arguments ----------------------------------------------------------------------------

TEST_P(CodecTest, BadArgumentsAreInvalidArgument) {
  const Codec codec = GetParam();
  const std::vector<float> v = {1.f, 2.f, 3.f, 4.f, 5.f, 6.f};
  std::vector<float> out(v.size() * 70);
  auto enc = [&](const float* data, std::size_t rows, int comps, const float* ref, double e) {
    return error_kind([&] { encode_floats(codec, data, rows, comps, ref, FloatParams{e}); });
  };
  EXPECT_EQ(Kind::InvalidArgument, enc(v.data(), 2, 0, nullptr, 0.0));
  EXPECT_EQ(Kind::InvalidArgument, enc(v.data(), 2, -3, nullptr, 0.0));
  EXPECT_EQ(Kind::InvalidArgument, enc(v.data(), 1, 65, nullptr, 0.0));
  EXPECT_EQ(Kind::InvalidArgument, enc(nullptr, 2, 3, nullptr, 0.0));
  const std::uint8_t byte = 0;
  EXPECT_EQ(Kind::InvalidArgument,
            error_kind([&] { decode_floats(codec, &byte, 1, 1, 0, nullptr, out.data()); }));
  EXPECT_EQ(Kind::InvalidArgument,
            error_kind([&] { decode_floats(codec, &byte, 1, 1, 65, nullptr, out.data()); }));
  EXPECT_EQ(Kind::InvalidArgument,
            error_kind([&] { decode_floats(codec, nullptr, 5, 1, 1, nullptr, out.data()); }));
  // max_abs_error must be 0 or a normal positive float-range value.
  for (double e : {-1e-3, std::nan(""), std::numeric_limits<double>::infinity(), 1e-40, 1e300}) {
    EXPECT_EQ(Kind::InvalidArgument, enc(v.data(), 2, 3, nullptr, e)) << e;
  }
  // NaN / inf in lossy mode, in the data or in the reference.
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                    -std::numeric_limits<float>::infinity()}) {
    std::vector<float> w = v;
    w[4] = bad;
    EXPECT_EQ(Kind::InvalidArgument, enc(w.data(), 2, 3, nullptr, 1e-3)) << bad;
    EXPECT_EQ(Kind::InvalidArgument, enc(v.data(), 2, 3, w.data(), 1e-3)) << bad;
  }
  // Values whose quantized residual would overflow int32.
  std::vector<float> big = v;
  big[0] = 1e30f;
  if (codec != Codec::Raw) {
    const Kind k = enc(big.data(), 2, 3, nullptr, 1e-6);
    // Draco has no int32 limit of its own but runs out of quantization bits.
    EXPECT_EQ(codec == Codec::Draco ? Kind::Unsupported : Kind::InvalidArgument, k);
  }
  // Indices: per_row, out-of-range index, null.
  const std::vector<std::uint32_t> idx = {0, 1, 2, 3, 1, 2, 3, 0};
  std::vector<std::uint32_t> iout(64);
  for (int per_row : {0, 1, 2, 5, -4}) {
    EXPECT_EQ(Kind::InvalidArgument,
              error_kind([&] { encode_indices(codec, idx.data(), 1, per_row, 4); }));
    EXPECT_EQ(Kind::InvalidArgument,
              error_kind([&] { decode_indices(codec, &byte, 1, 1, per_row, 4, iout.data()); }));
  }
  EXPECT_EQ(Kind::InvalidArgument,
            error_kind([&] { encode_indices(codec, idx.data(), 2, 4, 3); }));  // 3 >= 3
  EXPECT_EQ(Kind::InvalidArgument, error_kind([&] { encode_indices(codec, idx.data(), 1, 3, 0); }));
  EXPECT_EQ(Kind::InvalidArgument, error_kind([&] { encode_indices(codec, nullptr, 1, 3, 4); }));
}

TEST(CodecArgs, UnknownCodecIsUnsupported) {
  const float v[3] = {1, 2, 3};
  const std::uint32_t idx[3] = {0, 1, 2};
  float out[3];
  std::uint32_t iout[3];
  const std::uint8_t b = 0;
  const auto bad = static_cast<Codec>(200);
  EXPECT_EQ(Kind::Unsupported, error_kind([&] { encode_floats(bad, v, 1, 3, nullptr, {}); }));
  EXPECT_EQ(Kind::Unsupported, error_kind([&] { decode_floats(bad, &b, 1, 1, 3, nullptr, out); }));
  EXPECT_EQ(Kind::Unsupported, error_kind([&] { encode_indices(bad, idx, 1, 3, 3); }));
  EXPECT_EQ(Kind::Unsupported, error_kind([&] { decode_indices(bad, &b, 1, 1, 3, 3, iout); }));
}

TEST(CodecArgs, DracoTetsAreUnsupported) {
  const std::uint32_t idx[4] = {0, 1, 2, 3};
  std::uint32_t out[4];
  const std::uint8_t b[32] = {};
  EXPECT_EQ(Kind::Unsupported, error_kind([&] { encode_indices(Codec::Draco, idx, 1, 4, 4); }));
  EXPECT_EQ(Kind::Unsupported,
            error_kind([&] { decode_indices(Codec::Draco, b, sizeof b, 1, 4, 4, out); }));
}

// --- Hostile input ----------------------------------------------------------------------------

// A blob and how to decode it; `decode` reads exactly [p, p + n).
struct Target {
  std::string name;
  std::vector<std::uint8_t> blob;
  bool is_index;
  bool lossless_float;
  std::function<void(const std::uint8_t*, std::size_t)> decode;
};

struct Outcome {
  std::size_t rejected = 0;  // CodecError thrown
  std::size_t accepted = 0;  // decoded (indices are checked < vertex_count)
};

std::vector<Target> targets(Codec codec, const Data& d) {
  std::vector<Target> ts;
  for (const FloatCase& c : d.cases()) {
    Target t;
    t.name = c.name;
    t.blob = encode(codec, c);
    t.is_index = false;
    t.lossless_float = c.max_abs_error == 0.0 || codec == Codec::Raw;
    const std::size_t rows = rows_of(c);
    const int comps = c.comps;
    const float* ref = c.ref ? c.ref->data() : nullptr;
    t.decode = [rows, comps, ref, codec](const std::uint8_t* p, std::size_t n) {
      std::vector<float> out(rows * comps);  // exactly sized: ASan sees any overflow
      decode_floats(codec, p, n, rows, comps, ref, out.data());
    };
    ts.push_back(std::move(t));
  }
  const auto& m = d.mesh;
  const auto vc = static_cast<std::uint32_t>(m.vertex_count());
  for (int per_row : {3, 4}) {
    if (codec == Codec::Draco && per_row == 4) continue;
    const auto& idx = per_row == 3 ? m.tris : m.tets;
    const std::size_t rows = idx.size() / per_row;
    Target t;
    t.name = per_row == 3 ? "triangles" : "tets";
    t.blob = encode_indices(codec, idx.data(), rows, per_row, vc);
    t.is_index = true;
    t.lossless_float = false;
    t.decode = [rows, per_row, vc, codec](const std::uint8_t* p, std::size_t n) {
      std::vector<std::uint32_t> out(rows * per_row);
      decode_indices(codec, p, n, rows, per_row, vc, out.data());
      for (std::uint32_t i : out) {
        if (i >= vc) {
          ADD_FAILURE() << "decoder returned index " << i << " >= " << vc;
          return;
        }
      }
    };
    ts.push_back(std::move(t));
  }
  return ts;
}

// Decodes a copy of `bytes` held in a buffer of exactly that size. Any exception other than
// CodecError fails the test.
bool decodes(const Target& t, const std::vector<std::uint8_t>& bytes) {
  const auto copy = std::make_unique<std::uint8_t[]>(bytes.size());
  if (!bytes.empty()) std::memcpy(copy.get(), bytes.data(), bytes.size());
  try {
    t.decode(bytes.empty() ? nullptr : copy.get(), bytes.size());
    return true;
  } catch (const CodecError&) {
    return false;
  } catch (const std::exception& e) {
    ADD_FAILURE() << t.name << ": non-CodecError exception: " << e.what();
    return false;
  }
}

void every_prefix(Codec codec, const Data& d, std::size_t max_tries) {
  for (const Target& t : targets(codec, d)) {
    SCOPED_TRACE(t.name);
    const std::size_t n = t.blob.size();
    const std::size_t stride = std::max<std::size_t>(1, n / max_tries);
    std::size_t tried = 0;
    for (std::size_t len = 0; len < n; len += (len < 64 ? 1 : stride), ++tried) {
      const std::vector<std::uint8_t> prefix(t.blob.begin(), t.blob.begin() + len);
      EXPECT_FALSE(decodes(t, prefix)) << "prefix of " << len << " / " << n << " bytes decoded";
    }
    // The full blob decodes.
    EXPECT_TRUE(decodes(t, t.blob));
    // A blob with one byte too many is rejected too.
    std::vector<std::uint8_t> longer = t.blob;
    longer.push_back(0);
    EXPECT_FALSE(decodes(t, longer)) << "trailing byte accepted";
    EXPECT_GT(tried, std::min<std::size_t>(n, 64));
  }
}

TEST_P(CodecTest, EveryPrefixIsRejectedSmallMesh) {
  every_prefix(GetParam(), small_data(), 1u << 30);
}
TEST_P(CodecTest, PrefixesAreRejectedLargeMesh) { every_prefix(GetParam(), test_data(), 300); }

TEST_P(CodecTest, BitFlipsNeverCrash) {
  const Codec codec = GetParam();
  constexpr int kFlips = 2500;
  std::mt19937_64 rng(0xC0DEC + static_cast<unsigned>(codec));
  for (const Target& t : targets(codec, small_data())) {
    SCOPED_TRACE(t.name);
    Outcome o;
    for (int trial = 0; trial < kFlips; ++trial) {
      std::vector<std::uint8_t> b = t.blob;
      // Mostly single-bit flips; some bursts of 2-8 flips and some random bytes.
      const int flips = trial % 5 == 0 ? 2 + static_cast<int>(rng() % 7) : 1;
      for (int f = 0; f < flips; ++f) {
        const std::size_t bit = rng() % (b.size() * 8);
        if (trial % 11 == 0) {
          b[bit / 8] = static_cast<std::uint8_t>(rng());
        } else {
          b[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
        }
      }
      if (b == t.blob) continue;
      if (decodes(t, b)) {
        ++o.accepted;
      } else {
        ++o.rejected;
      }
    }
    // Not an assertion (no checksum: an accepted flip in a lossless stream yields wrong values),
    // but worth seeing how often corruption is noticed.
    std::printf("[ flips    ] %-15s %-24s rejected %5zu accepted %5zu\n", codec_name(codec),
                t.name.c_str(), o.rejected, o.accepted);
    EXPECT_GT(o.rejected + o.accepted, static_cast<std::size_t>(kFlips * 9 / 10));
  }
}

INSTANTIATE_TEST_SUITE_P(AllCodecs, CodecTest, ::testing::ValuesIn(kAllCodecs), codec_param_name);

}  // namespace
}  // namespace cadinterp::format
