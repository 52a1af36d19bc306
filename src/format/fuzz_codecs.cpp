// libFuzzer target: every codec of format/codec.h, below the asset reader. fuzz_open_eval and
// fuzz_api reach the decoders only through blobs whose shape the index fixes and whose checksum
// has to be repaired; here the fuzzer picks the shape, the codec and the reference directly, so
// it spends its time in the byte-level parsers.
//
// Input: an 8-byte control header, then the payload.
//   byte 0    bits 0-1 codec, bits 2-3 operation, bit 4 reference, bits 5-7 reference pattern
//   bytes 1-2 rows (u16 LE, capped)
//   byte 3    comps (floats) or per_row (indices); >= 128 passes byte - 128 unchecked, so the
//             decoders' argument checks are fuzzed too
//   bytes 4-7 vertex_count (u32 LE) for indices; error bound selector for lossy encoding
// Operations: 0 decode_floats and decode_floats_finite (payload), which must agree with each
// other; 1 decode_indices (payload). A lossless decode is re-encoded and must decode to the same
// bits. 2 and 3 go the other way: the payload is the array, encode then decode must reproduce it
// (floats: within the FloatParams bound).
//
// Decoders must return or throw CodecError; any other exception, sanitizer report or violated
// invariant aborts. Blob, reference and output each live in an allocation of exactly their size,
// so ASan sees a read or write one element past any of them.
//
// Seeds: with CADINTERP_FUZZ_WRITE_SEEDS=DIR the target writes encoder output for every codec
// and shape class to DIR and exits (scripts/fuzz.sh does this before fuzzing). Generating them
// keeps the corpus in step with the encoders, where blobs cut out of the conformance assets
// would go stale whenever a codec changes.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "format/codec.h"

namespace {

using cadinterp::format::Codec;
using cadinterp::format::CodecError;
namespace codec = cadinterp::format;

// 1024 rows x 64 comps is 256 KiB of floats: past every codec's block sizes (meshopt decodes
// 256-vertex blocks, zstd 128 KiB blocks). The output is allocated before the blob's header is
// read, so a larger cap mostly buys slower rejections (measured: 4096 rows, ~3 ms per input).
constexpr std::size_t kMaxDecodeRows = 1024;
// Encode round trips need no large arrays; Draco's encoder, by far the slowest (a point cloud
// and an encoder built per quantization attempt), gets fewer rows still.
constexpr std::size_t kMaxEncodeRows = 512;
constexpr std::size_t kMaxDracoEncodeRows = 64;
constexpr std::size_t kHeader = 8;

enum Op { kDecodeFloats = 0, kDecodeIndices = 1, kEncodeFloats = 2, kEncodeIndices = 3 };

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "fuzz_codecs invariant violated: %s\n", what.c_str());
  std::abort();
}

struct Control {
  Codec codec = Codec::Raw;
  Op op = kDecodeFloats;
  bool reference = false;
  int pattern = 0;
  std::size_t rows = 0;
  int width = 0;
  std::uint32_t word = 0;  // vertex_count or error selector
};

std::uint8_t control_byte0(Codec c, Op op, bool reference, int pattern) {
  return static_cast<std::uint8_t>(static_cast<int>(c) | (op << 2) | (reference ? 16 : 0) |
                                   (pattern << 5));
}

// Reference arrays the decoder is handed. Patterns 0-6 are finite (what an asset's canonical
// positions look like, plus large magnitudes); 7 mixes in NaN, inf and subnormals, which only
// the lossless bit arithmetic is defined for.
std::vector<float> generate_reference(int pattern, std::size_t n) {
  std::vector<float> r(n);
  std::uint32_t s = 0x9e3779b9u * static_cast<std::uint32_t>(pattern + 1);
  for (std::size_t i = 0; i < n; ++i) {
    s = s * 1664525u + 1013904223u;
    const float u = static_cast<float>(s >> 8) * 0x1p-24f * 2.f - 1.f;  // [-1, 1)
    switch (pattern) {
      case 0:
        r[i] = 0.f;
        break;
      case 1:
        r[i] = 0.25f * static_cast<float>(i % 97);
        break;
      case 5:
        r[i] = u * 1e30f;
        break;
      case 6:
        r[i] = u * 1e-30f;
        break;
      case 7: {
        const float special[] = {NAN, INFINITY, -INFINITY, 1e-45f, -0.f, 3.4e38f};
        r[i] = (s >> 29) < 6 ? special[s >> 29] : u;
        break;
      }
      default:
        r[i] = u * static_cast<float>(pattern * 10);
    }
  }
  return r;
}

// Each pattern is a prefix-stable sequence: generated once at the largest size, then copied into
// an allocation of exactly n floats (so ASan still sees a decoder reading past the reference).
std::vector<float> make_reference(int pattern, std::size_t n) {
  static std::vector<float> memo[8];
  std::vector<float>& m = memo[pattern & 7];
  if (m.size() < n) m = generate_reference(pattern, std::max(n, kMaxDecodeRows * codec::kMaxComps));
  return std::vector<float>(m.begin(), m.begin() + static_cast<std::ptrdiff_t>(n));
}

bool all_finite(const std::vector<float>& a) {
  for (float v : a)
    if (!std::isfinite(v)) return false;
  return true;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  // memcmp's pointers must not be null, even for 0 bytes, and empty vectors may hold null.
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

std::string describe(const Control& c) {
  return std::string(codec::codec_name(c.codec)) + " rows " + std::to_string(c.rows) + " width " +
         std::to_string(c.width) + " word " + std::to_string(c.word) +
         (c.reference ? " with reference " + std::to_string(c.pattern) : " without reference");
}

// The decoders' contract (codec.h): malformed bytes throw Corrupt or Unsupported; InvalidArgument
// means the caller erred, which with a valid shape can only be a blob that needs a reference
// when none was given.
void check_decode_error(const CodecError& e, const Control& c, bool shape_ok, bool have_ref) {
  if (e.kind == CodecError::Kind::InvalidArgument && shape_ok && have_ref)
    fail("decoder blamed its arguments for bad bytes (" + describe(c) + "): " + e.what());
}

void decode_floats(const Control& c, const std::uint8_t* data, std::size_t size) {
  const bool shape_ok = c.width >= 1 && c.width <= codec::kMaxComps;
  const std::size_t n = shape_ok ? c.rows * static_cast<std::size_t>(c.width) : 0;
  const std::vector<std::uint8_t> blob(data, data + size);
  const std::vector<float> ref = c.reference ? make_reference(c.pattern, n) : std::vector<float>();
  // An empty vector's data() may be null, which would read as "no reference" for 0 rows.
  static const float kNoValues[1] = {0.f};
  const float* ref_ptr = c.reference ? (n ? ref.data() : kNoValues) : nullptr;
  // decode_floats_finite must behave exactly as decode_floats (same bits, same failures) and
  // report finiteness truthfully: the asset reader relies on it instead of scanning the output.
  std::vector<float> out(n), out2(n);
  bool threw = false, threw2 = false, finite = false;
  CodecError::Kind kind{}, kind2{};
  try {
    codec::decode_floats(c.codec, blob.data(), blob.size(), c.rows, c.width, ref_ptr, out.data());
  } catch (const CodecError& e) {
    check_decode_error(e, c, shape_ok, c.reference);
    threw = true;
    kind = e.kind;
  }
  try {
    finite = codec::decode_floats_finite(c.codec, blob.data(), blob.size(), c.rows, c.width,
                                         ref_ptr, out2.data());
  } catch (const CodecError& e) {
    check_decode_error(e, c, shape_ok, c.reference);
    threw2 = true;
    kind2 = e.kind;
  }
  if (threw != threw2 || kind != kind2)
    fail("decode_floats and decode_floats_finite disagree on failure (" + describe(c) + ")");
  if (threw) return;
  if (!shape_ok) fail("decode_floats accepted an invalid comps (" + describe(c) + ")");
  if (!same_bits(out, out2))
    fail("decode_floats and decode_floats_finite decode differently (" + describe(c) + ")");
  // Its contract holds for a finite reference (or none); pattern 7 holds NaN and inf.
  if ((!c.reference || c.pattern != 7) && finite != all_finite(out))
    fail(std::string("decode_floats_finite returned ") + (finite ? "true" : "false") +
         " for an output that is " + (all_finite(out) ? "finite" : "not finite") + " (" +
         describe(c) + ")");

  // A header of at least 16 bytes was parsed for every codec but Raw.
  const bool lossless = c.codec == Codec::Raw || blob[1] == codec::detail::kModeLossless;
  if (!lossless) {
    // Dequantization clamps to the float range, so a finite reference gives finite values
    // whatever the stream holds. Draco dequantizes by its own arithmetic: no such promise.
    const bool clamped = c.codec == Codec::QuantDeltaZstd || c.codec == Codec::Meshopt;
    if (clamped && (!c.reference || c.pattern != 7) && !all_finite(out))
      fail("lossy decode produced a non-finite value (" + describe(c) + ")");
    return;
  }
  std::vector<std::uint8_t> again;
  try {
    again = codec::encode_floats(c.codec, out.data(), c.rows, c.width, ref_ptr, {});
  } catch (const std::exception& e) {
    fail("lossless re-encode of decoded floats failed (" + describe(c) + "): " + e.what());
  }
  std::vector<float> back(n);
  try {
    codec::decode_floats(c.codec, again.data(), again.size(), c.rows, c.width, ref_ptr,
                         back.data());
  } catch (const std::exception& e) {
    fail("re-encoded floats do not decode (" + describe(c) + "): " + e.what());
  }
  if (!same_bits(out, back)) fail("lossless float round trip changed bits (" + describe(c) + ")");
}

void check_indices(const std::vector<std::uint32_t>& idx, std::uint32_t vertex_count,
                   const Control& c) {
  for (std::uint32_t v : idx)
    if (v >= vertex_count) fail("decoded index >= vertex_count (" + describe(c) + ")");
}

void decode_indices(const Control& c, const std::uint8_t* data, std::size_t size) {
  const bool shape_ok = c.width == 3 || c.width == 4;
  const std::size_t n = shape_ok ? c.rows * static_cast<std::size_t>(c.width) : 0;
  const std::vector<std::uint8_t> blob(data, data + size);
  std::vector<std::uint32_t> out(n);
  try {
    codec::decode_indices(c.codec, blob.data(), blob.size(), c.rows, c.width, c.word, out.data());
  } catch (const CodecError& e) {
    check_decode_error(e, c, shape_ok, true);
    return;
  }
  if (!shape_ok) fail("decode_indices accepted an invalid per_row (" + describe(c) + ")");
  if (c.codec == Codec::Draco && c.width == 4) fail("draco decoded tets, which it cannot encode");
  check_indices(out, c.word, c);

  std::vector<std::uint8_t> again;
  try {
    again = codec::encode_indices(c.codec, out.data(), c.rows, c.width, c.word);
  } catch (const std::exception& e) {
    fail("re-encode of decoded indices failed (" + describe(c) + "): " + e.what());
  }
  std::vector<std::uint32_t> back(n);
  try {
    codec::decode_indices(c.codec, again.data(), again.size(), c.rows, c.width, c.word,
                          back.data());
  } catch (const std::exception& e) {
    fail("re-encoded indices do not decode (" + describe(c) + "): " + e.what());
  }
  if (back != out) fail("index round trip changed indices (" + describe(c) + ")");
}

// The payload's bytes as rows x width words, repeated when it is short (an empty payload gives
// zeros), so every row count is reachable from a small input.
template <typename T>
std::vector<T> words_from(const std::uint8_t* data, std::size_t size, std::size_t n) {
  std::vector<T> w(n);
  if (size < sizeof(T)) return w;
  const std::size_t avail = size / sizeof(T);
  for (std::size_t i = 0; i < n; ++i) std::memcpy(&w[i], data + (i % avail) * sizeof(T), sizeof(T));
  return w;
}

// The largest per-component extent of the residual the Draco encoder quantizes. Draco keeps a
// histogram of 2^bits words per quantization attempt, so a bound that needs 22-24 bits costs
// about a second under ASan (64 MiB per attempt); round trips needing more than 16 bits are
// skipped, as they run the same code at ~100x the cost of the rest of the target.
double draco_extent(const std::vector<float>& values, const float* ref, std::size_t rows,
                    int comps) {
  double extent = 0.0;
  for (int k = 0; k < comps; ++k) {
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t i = 0; i < rows; ++i) {
      const std::size_t j = i * static_cast<std::size_t>(comps) + static_cast<std::size_t>(k);
      const double w = static_cast<double>(ref ? values[j] - ref[j] : values[j]);
      if (!std::isfinite(w)) return 0.0;  // refused by the encoder's argument check at once
      lo = std::min(lo, w);
      hi = std::max(hi, w);
    }
    if (rows) extent = std::max(extent, hi - lo);
  }
  return extent;
}

void encode_floats(const Control& c, const std::uint8_t* data, std::size_t size) {
  const std::size_t n = c.rows * static_cast<std::size_t>(c.width);
  const std::vector<float> values = words_from<float>(data, size, n);
  const std::vector<float> ref = make_reference(c.pattern, n);
  const float* ref_ptr = c.reference ? ref.data() : nullptr;
  // Selector: bit 31 lossless, else bound (1 + m / 256) 2^(e - 100), e = bits 0-6, m = bits 8-15:
  // from below FLT_MIN-scale steps up to 2^28, around every magnitude the data can have.
  codec::FloatParams params;
  if (!(c.word & 0x80000000u)) {
    params.max_abs_error = std::ldexp(1.0 + static_cast<double>((c.word >> 8) & 0xff) / 256.0,
                                      static_cast<int>(c.word & 0x7f) - 100);
  }
  if (c.codec == Codec::Draco && params.max_abs_error > 0 &&
      draco_extent(values, ref_ptr, c.rows, c.width) > 2.0 * params.max_abs_error * 65535.0)
    return;
  std::vector<std::uint8_t> blob;
  try {
    blob = codec::encode_floats(c.codec, values.data(), c.rows, c.width, ref_ptr, params);
  } catch (const CodecError& e) {
    // Non-finite or too large values in lossy mode, int32 overflow of the quanta, Draco's
    // 24-bit limit: documented refusals. A Corrupt here means the encoder's own output failed
    // its self-check (Draco decodes what it wrote).
    if (e.kind == CodecError::Kind::Corrupt)
      fail("encoder produced a blob it cannot decode (" + describe(c) + "): " + e.what());
    if (params.max_abs_error == 0.0)
      fail("lossless encode refused valid input (" + describe(c) + "): " + e.what());
    return;
  }
  std::vector<float> out(n);
  try {
    codec::decode_floats(c.codec, blob.data(), blob.size(), c.rows, c.width, ref_ptr, out.data());
  } catch (const std::exception& e) {
    fail("encoded floats do not decode (" + describe(c) + "): " + e.what());
  }
  if (params.max_abs_error == 0.0) {
    if (!same_bits(values, out)) fail("lossless encode/decode changed bits (" + describe(c) + ")");
    return;
  }
  const double e = params.max_abs_error;
  const bool strict =
      codec::strict_error_bound(e, codec::detail::max_abs_value(values.data(), values.size()));
  for (std::size_t i = 0; i < n; ++i) {
    const double bound = strict ? e : codec::float_error_bound(e, values[i]);
    const double err = std::fabs(static_cast<double>(out[i]) - static_cast<double>(values[i]));
    if (!(err <= bound)) {
      char msg[200];
      std::snprintf(msg, sizeof msg, "value %zu: %.9g decoded as %.9g, error %.3g > bound %.3g", i,
                    static_cast<double>(values[i]), static_cast<double>(out[i]), err, bound);
      fail("lossy bound broken (" + describe(c) + "): " + msg);
    }
  }
}

void encode_indices(const Control& c, const std::uint8_t* data, std::size_t size) {
  const std::uint32_t vertex_count = 1 + c.word % 65536;
  const std::size_t n = c.rows * static_cast<std::size_t>(c.width);
  std::vector<std::uint32_t> idx = words_from<std::uint32_t>(data, size, n);
  for (auto& v : idx) v %= vertex_count;
  std::vector<std::uint8_t> blob;
  try {
    blob = codec::encode_indices(c.codec, idx.data(), c.rows, c.width, vertex_count);
  } catch (const CodecError& e) {
    if (c.codec == Codec::Draco && c.width == 4 && e.kind == CodecError::Kind::Unsupported) return;
    fail("encode_indices refused valid input (" + describe(c) + "): " + e.what());
  }
  std::vector<std::uint32_t> out(n);
  try {
    codec::decode_indices(c.codec, blob.data(), blob.size(), c.rows, c.width, vertex_count,
                          out.data());
  } catch (const std::exception& e) {
    fail("encoded indices do not decode (" + describe(c) + "): " + e.what());
  }
  if (out != idx) fail("index encode/decode changed indices (" + describe(c) + ")");
}

Control parse(const std::uint8_t* data) {
  Control c;
  c.codec = static_cast<Codec>(data[0] & 3);
  c.op = static_cast<Op>((data[0] >> 2) & 3);
  c.reference = (data[0] & 16) != 0;
  c.pattern = data[0] >> 5;
  const std::size_t rows = data[1] | (static_cast<std::size_t>(data[2]) << 8);
  const bool encode = c.op == kEncodeFloats || c.op == kEncodeIndices;
  const std::size_t max_rows = !encode                   ? kMaxDecodeRows
                               : c.codec == Codec::Draco ? kMaxDracoEncodeRows
                                                         : kMaxEncodeRows;
  c.rows = rows % (max_rows + 1);
  const bool floats = c.op == kDecodeFloats || c.op == kEncodeFloats;
  if (data[3] < 128 || encode)
    c.width = floats ? 1 + (data[3] & 127) % codec::kMaxComps : 3 + (data[3] & 1);
  else
    c.width = data[3] - 128;
  c.word = static_cast<std::uint32_t>(data[4]) | static_cast<std::uint32_t>(data[5]) << 8 |
           static_cast<std::uint32_t>(data[6]) << 16 | static_cast<std::uint32_t>(data[7]) << 24;
  return c;
}

// ---- Seed corpus ---------------------------------------------------------------------------

void write_seed(const std::string& dir, int& count, const std::uint8_t head[kHeader],
                const std::vector<std::uint8_t>& payload) {
  const std::string path = dir + "/codec_seed_" + std::to_string(count++);
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) fail("cannot write " + path);
  std::fwrite(head, 1, kHeader, f);
  if (!payload.empty()) std::fwrite(payload.data(), 1, payload.size(), f);
  std::fclose(f);
}

void header(std::uint8_t* h, Codec c, Op op, bool reference, int pattern, std::size_t rows,
            int width, std::uint32_t word) {
  h[0] = control_byte0(c, op, reference, pattern);
  h[1] = static_cast<std::uint8_t>(rows);
  h[2] = static_cast<std::uint8_t>(rows >> 8);
  h[3] = static_cast<std::uint8_t>(width);
  for (int i = 0; i < 4; ++i) h[4 + i] = static_cast<std::uint8_t>(word >> (8 * i));
}

// Small smooth arrays close to the reference, as a sample's positions are to the canonical mesh;
// and triangle / tet strips over a row of vertices, as a boundary and a tet mesh index them.
void write_seeds(const std::string& dir) {
  int count = 0;
  std::uint8_t h[kHeader];
  const Codec codecs[] = {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt, Codec::Draco};
  for (Codec c : codecs) {
    for (std::size_t rows : {std::size_t(0), std::size_t(1), std::size_t(7), std::size_t(300)}) {
      for (int comps : {1, 3, 5}) {
        for (int pattern : {0, 2}) {
          for (bool with_ref : {false, true}) {
            for (double err : {0.0, 1e-3}) {
              const std::size_t n = rows * static_cast<std::size_t>(comps);
              const std::vector<float> ref = make_reference(pattern, n);
              std::vector<float> v(n);
              for (std::size_t i = 0; i < n; ++i)
                v[i] = ref[i] + 0.01f * std::sin(0.1f * static_cast<float>(i));
              codec::FloatParams p;
              p.max_abs_error = err;
              std::vector<std::uint8_t> blob;
              try {
                blob = codec::encode_floats(c, v.data(), rows, comps,
                                            with_ref ? ref.data() : nullptr, p);
              } catch (const CodecError&) {
                continue;
              }
              header(h, c, kDecodeFloats, with_ref, pattern, rows, comps, 0);
              write_seed(dir, count, h, blob);
            }
          }
        }
      }
    }
    for (int per_row : {3, 4}) {
      for (std::size_t rows : {std::size_t(0), std::size_t(1), std::size_t(40), std::size_t(500)}) {
        const std::uint32_t vertex_count = static_cast<std::uint32_t>(rows + 3);
        std::vector<std::uint32_t> idx(rows * static_cast<std::size_t>(per_row));
        for (std::size_t t = 0; t < rows; ++t)
          for (int k = 0; k < per_row; ++k)
            idx[t * per_row + k] = static_cast<std::uint32_t>(
                (t + static_cast<std::size_t>(k) + (t & 1) * 2 * k) % vertex_count);
        // Draco's mesh encoder needs distinct corners; the strip above has them.
        std::vector<std::uint8_t> blob;
        try {
          blob = codec::encode_indices(c, idx.data(), rows, per_row, vertex_count);
        } catch (const CodecError&) {
          continue;
        }
        header(h, c, kDecodeIndices, false, 0, rows, per_row, vertex_count);
        write_seed(dir, count, h, blob);
      }
    }
    // Encode round trips: a few rows of random-looking words, lossless and lossy.
    std::vector<std::uint8_t> payload(64);
    for (std::size_t i = 0; i < payload.size(); ++i)
      payload[i] = static_cast<std::uint8_t>(i * 37 + 11);
    header(h, c, kEncodeFloats, true, 2, 16, 3, 0x80000000u);
    write_seed(dir, count, h, payload);
    header(h, c, kEncodeFloats, false, 0, 16, 3, 0x00000050u);
    write_seed(dir, count, h, payload);
    header(h, c, kEncodeIndices, false, 0, 16, 3, 40);
    write_seed(dir, count, h, payload);
  }
  std::fprintf(stderr, "fuzz_codecs: wrote %d seeds to %s\n", count, dir.c_str());
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* dir = std::getenv("CADINTERP_FUZZ_WRITE_SEEDS")) {
    write_seeds(dir);
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < kHeader) return 0;
  const Control c = parse(data);
  const std::uint8_t* payload = data + kHeader;
  const std::size_t n = size - kHeader;
  switch (c.op) {
    case kDecodeFloats:
      decode_floats(c, payload, n);
      break;
    case kDecodeIndices:
      decode_indices(c, payload, n);
      break;
    case kEncodeFloats:
      encode_floats(c, payload, n);
      break;
    case kEncodeIndices:
      encode_indices(c, payload, n);
      break;
  }
  return 0;
}
