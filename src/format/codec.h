// Compression codecs for the mesh arrays stored in an asset file: per-vertex / per-tet float
// arrays (positions, fields) and index arrays (tets, boundary triangles).
//
// Every blob is self-describing only as far as needed to validate it: the caller knows the shape
// (rows, comps / per_row, vertex_count) from the file's index and passes it to the decoder, which
// checks every length, count and header field of the byte stream against it. Decoders never read
// or write outside [bytes, bytes + size) and [out, out + rows * comps); malformed input throws
// CodecError. A flipped bit that keeps the stream well formed can go unnoticed (there is no
// checksum here: integrity of the bytes on disk is the container's job); it then yields wrong
// values but never an index >= vertex_count.
//
// Thread-safety: every function is reentrant and may be called concurrently from any number of
// threads. zstd contexts and decode scratch buffers are per thread; a thread's scratch keeps the
// size of the largest array it decoded (about 2 x rows x comps x 4 bytes) until the thread ends.
//
// Byte order: blobs are little-endian; the codecs are built for little-endian hosts only.
#pragma once

#include <algorithm>
#include <cfloat>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace cadinterp::format {

/// Codec of one blob. The values are written to files: never renumber, only append.
enum class Codec : std::uint8_t {
  /// Little-endian copy; `size` must be exactly rows * comps * 4 bytes. Always lossless; the
  /// reference is not used.
  Raw = 0,
  /// Floats: the residual to the reference (or the value) as float bits (lossless) or quantized
  /// to int32 (lossy), delta to the previous row per component, zigzag, byte-plane shuffle, zstd
  /// level 3. Indices: all rows * per_row indices as one sequence, delta to the previous index,
  /// same back end.
  QuantDeltaZstd = 1,
  /// meshoptimizer 0.18 vertex codec (vertex = one row, comps * 4 bytes) on the same integers as
  /// QuantDeltaZstd before its delta; index codec for triangles (plus the corner rotations it
  /// applies, so the triangles come back exactly), index-sequence codec for tets.
  Meshopt = 2,
  /// Draco 1.5.5: floats as a sequential (order-preserving) point cloud with one generic
  /// attribute, quantized by Draco in lossy mode; lossless floats are stored unquantized, which
  /// Draco does not compress (ratio 1.0). Triangles as a sequentially encoded mesh with
  /// compressed connectivity (same triangles, same order, same corner order) over the used
  /// vertices only. Tets: CodecError::Unsupported.
  Draco = 3,
};

/// Largest `comps` accepted by the float codecs (meshoptimizer's vertex size limit is 256 bytes).
inline constexpr int kMaxComps = 64;

/// Fixed English name of a codec ("raw", "quant-delta-zstd", "meshopt", "draco"), or "unknown".
const char* codec_name(Codec c);

/// True iff `value` is the value of a Codec enumerator (for validating a codec byte from a file).
bool codec_is_known(std::uint8_t value);

/// Thrown for every malformed or unsupported input and every invalid argument.
struct CodecError : std::runtime_error {
  enum class Kind {
    Corrupt,          ///< the byte stream is malformed or disagrees with the given shape
    Unsupported,      ///< valid request the codec cannot do (Draco tets, Draco lossy > 24 bits)
    InvalidArgument,  ///< bad shape, codec value, NaN/inf in lossy mode, index >= vertex_count
  };
  CodecError(Kind k, const std::string& what);
  Kind kind;
};

/// Fixed English name of an error kind ("corrupt", "unsupported", "invalid argument").
const char* codec_error_kind_name(CodecError::Kind k);

/// Options of the float encoders.
///
/// max_abs_error == 0: lossless; the decoded bits equal the input bits (NaN payloads included).
/// max_abs_error > 0: lossy. It must lie in [FLT_MIN, 2^126], and every value of data and
/// reference must be finite with magnitude <= 2^126. With M the largest |v| of the array, every
/// decoded value d of an input value v satisfies
///     |d - v| <= max_abs_error      if max_abs_error >= 2^-22 (M + max_abs_error)
///                                   (strict_error_bound(); any bound above ~4 float32 ulps of M)
///     |d - v| <= max_abs_error + 2^-23 (|v| + max_abs_error)     otherwise (float_error_bound()).
/// In the first case the quantization step is shrunk by 2^-23 (M + max_abs_error) to leave room
/// for the final rounding to float32 and for the double-precision intermediates; in the second
/// the float32 grid is too coarse for that and the bound grows by one float32 epsilon of the
/// magnitude. Raw is always lossless. The Draco encoder checks the same bound on its own decoded
/// output and raises its quantization bits until it holds.
struct FloatParams {
  double max_abs_error = 0.0;
};

/// True iff the lossy bound is strict (|d - v| <= max_abs_error) for an array whose largest
/// magnitude is max_abs_value: max_abs_error >= 2^-22 (max_abs_value + max_abs_error).
bool strict_error_bound(double max_abs_error, double max_abs_value);

/// The bound of the second case of FloatParams for an original value v:
/// max_abs_error + 2^-23 (|v| + max_abs_error); 0 if max_abs_error is 0. It always holds.
double float_error_bound(double max_abs_error, float v);

/// Encodes a rows x comps float32 array.
/// @param[in] c          codec
/// @param[in] data       rows x comps, row-major; may be null iff rows == 0
/// @param[in] rows       number of rows (vertices or tets)
/// @param[in] comps      components per row, 1..kMaxComps (positions 3)
/// @param[in] reference  nullable rows x comps: the element's canonical array. Lossy codecs
///                       quantize data - reference; lossless ones code the bit difference. The
///                       decoder must be given the same array.
/// @param[in] params     error bound (see FloatParams)
/// @return the blob. Throws CodecError (InvalidArgument, Unsupported), std::bad_alloc, or
/// std::runtime_error if zstd, meshoptimizer or Draco fails internally (not expected).
std::vector<std::uint8_t> encode_floats(Codec c, const float* data, std::size_t rows, int comps,
                                        const float* reference, const FloatParams& params);

/// Decodes a blob made by encode_floats with the same c, rows and comps.
/// @param[in]  bytes, size  the blob (bytes may be null iff size == 0)
/// @param[in]  reference    the array given to the encoder; may be null if the encoder had none
///                          (it is ignored then). A blob coded against a reference and decoded
///                          without one throws InvalidArgument.
/// @param[out] out          rows x comps; on error its content is unspecified
/// Throws CodecError (Corrupt for malformed bytes) or std::bad_alloc.
void decode_floats(Codec c, const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                   int comps, const float* reference, float* out);

/// As decode_floats, and returns true iff every value written to out is finite. The answer costs
/// no second pass over out where it can be avoided: lossless raw, quant-delta-zstd and meshopt
/// test the bits in their output loop; their lossy modes are finite by construction (a checked
/// finite step, the value clamped to the float range before the conversion); Draco, whose output
/// comes from the Draco library, is scanned after decoding.
/// @param[in] reference  as for decode_floats; if used it must hold finite values only (the
///                       lossy result is then finite; with a non-finite reference the return
///                       value is unspecified). Asset readers pass the canonical array, which
///                       they decode and check first.
[[nodiscard]] bool decode_floats_finite(Codec c, const std::uint8_t* bytes, std::size_t size,
                                        std::size_t rows, int comps, const float* reference,
                                        float* out);

/// Encodes a rows x per_row index array (tets per_row = 4, triangles per_row = 3).
/// @param[in] idx           rows x per_row, every entry < vertex_count; may be null iff rows == 0
/// @param[in] vertex_count  number of vertices the indices refer to
/// Throws CodecError: InvalidArgument (per_row not 3/4, an index >= vertex_count),
/// Unsupported (Draco with per_row 4); like encode_floats for other failures.
std::vector<std::uint8_t> encode_indices(Codec c, const std::uint32_t* idx, std::size_t rows,
                                         int per_row, std::uint32_t vertex_count);

/// Decodes a blob made by encode_indices with the same c, rows, per_row and vertex_count into
/// out (rows x per_row). Every decoded index is checked < vertex_count (Corrupt otherwise).
void decode_indices(Codec c, const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                    int per_row, std::uint32_t vertex_count, std::uint32_t* out);

// ------------------------------------------------------------------------------------------
// Internal: shared by codec*.cpp and their tests. Not part of the interface above.
namespace detail {

[[noreturn]] void fail(CodecError::Kind k, const std::string& what);
[[noreturn]] void corrupt(const std::string& what);

/// Blob header of every codec except Raw (16 bytes, then 8 more for a lossy step):
///   u8 version (1), u8 mode, u8 flags, u8 comps or per_row, u64 rows, u32 vertex_count or 0.
struct BlobHeader {
  static constexpr std::uint8_t kVersion = 1;
  static constexpr std::size_t kSize = 16;
  std::uint8_t mode = 0;   ///< codec-specific (float: 0 lossless, 1 lossy; indices: 2)
  std::uint8_t flags = 0;  ///< codec-specific bits
  std::uint8_t width = 0;  ///< comps or per_row
  std::uint64_t rows = 0;
  std::uint32_t vertex_count = 0;
};
inline constexpr std::uint8_t kModeLossless = 0;
inline constexpr std::uint8_t kModeLossy = 1;
inline constexpr std::uint8_t kModeIndices = 2;
inline constexpr std::uint8_t kFlagReference = 1;  ///< float blob coded against a reference

void write_header(std::vector<std::uint8_t>& out, const BlobHeader& h);
/// Parses and checks version, width, rows and vertex_count against the expectation; the caller
/// checks mode and flags. Returns the header; `pos` is advanced past it.
BlobHeader read_header(const std::uint8_t* bytes, std::size_t size, std::size_t& pos,
                       std::uint8_t width, std::size_t rows, std::uint32_t vertex_count);
/// Little-endian scalars; the getters throw Corrupt when fewer bytes remain than they read.
void put_f64(std::vector<std::uint8_t>& out, double v);
double get_f64(const std::uint8_t* bytes, std::size_t size, std::size_t& pos);
void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v);
std::uint32_t get_u32(const std::uint8_t* bytes, std::size_t size, std::size_t& pos);
void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v);
std::uint64_t get_u64(const std::uint8_t* bytes, std::size_t size, std::size_t& pos);

/// Largest |v| of n finite values.
double max_abs_value(const float* v, std::size_t n);
/// Quantization shared by the lossy float codecs: q = round((v - ref) / step), decoded value
/// float(ref + q * step) computed in double. step = 2 m (1 - 2^-18), where m = max_abs_error
/// minus 2^-23 (max_abs + max_abs_error) if strict_error_bound(), else max_abs_error
/// (FloatParams; the proof is at the definition).
double quant_step(double max_abs_error, double max_abs);
/// q: rows x comps row-major. Throws InvalidArgument if some |q| would exceed 2^31 - 1.
void quantize(const float* data, const float* ref, std::size_t n, double step, std::int32_t* q);
void dequantize(const std::int32_t* q, const float* ref, std::size_t n, double step, float* out);
/// One value of dequantize(): float(ref + q * step), the sum in double. The clamp to the float
/// range only matters for corrupt streams (legit ones stay below 2^127); it keeps the double to
/// float conversion defined.
inline float dequantize_one(std::int32_t q, double ref, double step) {
  constexpr double kMax = FLT_MAX;
  const double v = ref + static_cast<double>(q) * step;
  // std::max then std::min (maxsd, minsd); a NaN reference passes through as NaN.
  return static_cast<float>(std::min(std::max(v, -kMax), kMax));
}
/// Lossless residual: float bits minus reference bits (mod 2^32), or the bits without reference.
void bits_residual(const float* data, const float* ref, std::size_t n, std::uint32_t* r);
/// Returns true iff every value written is finite (tested in the same loop).
bool bits_unresidual(const std::uint32_t* r, const float* ref, std::size_t n, float* out);
/// Copies n little-endian floats from bytes to out; true iff all of them are finite.
bool copy_floats_finite(const std::uint8_t* bytes, std::size_t n, float* out);
/// True iff all n values are finite (one pass).
bool all_finite(const float* v, std::size_t n);
/// The exponent bits of a float32: all ones exactly for infinities and NaNs.
inline constexpr std::uint32_t kFloatExponentMask = 0x7f800000u;

/// Argument checks shared by all codecs (throw InvalidArgument).
void check_float_args(const float* data, std::size_t rows, int comps, const float* reference,
                      const FloatParams& params);
void check_index_args(const std::uint32_t* idx, std::size_t rows, int per_row,
                      std::uint32_t vertex_count);
/// Throws Corrupt if some index >= vertex_count.
void check_decoded_indices(const std::uint32_t* idx, std::size_t n, std::uint32_t vertex_count);

// Per-codec entry points, arguments already checked by the dispatchers in codec.cpp. The float
// decoders return what decode_floats_finite() returns.
std::vector<std::uint8_t> qdz_encode_floats(const float* data, std::size_t rows, int comps,
                                            const float* reference, double max_abs_error);
bool qdz_decode_floats(const std::uint8_t* bytes, std::size_t size, std::size_t rows, int comps,
                       const float* reference, float* out);
std::vector<std::uint8_t> qdz_encode_indices(const std::uint32_t* idx, std::size_t rows,
                                             int per_row, std::uint32_t vertex_count);
void qdz_decode_indices(const std::uint8_t* bytes, std::size_t size, std::size_t rows, int per_row,
                        std::uint32_t vertex_count, std::uint32_t* out);

std::vector<std::uint8_t> meshopt_encode_floats(const float* data, std::size_t rows, int comps,
                                                const float* reference, double max_abs_error);
bool meshopt_decode_floats(const std::uint8_t* bytes, std::size_t size, std::size_t rows, int comps,
                           const float* reference, float* out);
std::vector<std::uint8_t> meshopt_encode_indices(const std::uint32_t* idx, std::size_t rows,
                                                 int per_row, std::uint32_t vertex_count);
void meshopt_decode_indices(const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                            int per_row, std::uint32_t vertex_count, std::uint32_t* out);

std::vector<std::uint8_t> draco_encode_floats(const float* data, std::size_t rows, int comps,
                                              const float* reference, double max_abs_error);
bool draco_decode_floats(const std::uint8_t* bytes, std::size_t size, std::size_t rows, int comps,
                         const float* reference, float* out);
std::vector<std::uint8_t> draco_encode_indices(const std::uint32_t* idx, std::size_t rows,
                                               int per_row, std::uint32_t vertex_count);
void draco_decode_indices(const std::uint8_t* bytes, std::size_t size, std::size_t rows,
                          int per_row, std::uint32_t vertex_count, std::uint32_t* out);

}  // namespace detail
}  // namespace cadinterp::format
