#include "host_request_codec.h"

#include <cstring>
#include <stdexcept>

namespace cadinterp::tools::request_codec {

namespace {

void append(std::vector<std::uint8_t>& out, const void* p, std::size_t n) {
  if (n == 0) return;
  const auto* b = static_cast<const std::uint8_t*>(p);
  out.insert(out.end(), b, b + n);
}

// Reads the bytes it is given, front to back, never past their end.
class Reader {
 public:
  Reader(const void* data, std::size_t size)
      : p_(static_cast<const std::uint8_t*>(data)), left_(size) {}

  bool word(std::uint64_t* v) {
    if (left_ < sizeof *v) return false;
    std::memcpy(v, p_, sizeof *v);
    advance(sizeof *v);
    return true;
  }
  // `count` values of T into *out; false when they would run past the end. The caller bounds
  // count by the message size first, so count * sizeof(T) cannot overflow.
  template <typename T>
  bool take(std::uint64_t count, std::vector<T>* out) {
    if (count > left_ / sizeof(T)) return false;
    out->resize(static_cast<std::size_t>(count));
    const std::size_t n = static_cast<std::size_t>(count) * sizeof(T);
    if (n > 0) std::memcpy(out->data(), p_, n);
    advance(n);
    return true;
  }
  std::size_t left() const { return left_; }

 private:
  void advance(std::size_t n) {
    p_ += n;
    left_ -= n;
  }
  const std::uint8_t* p_;
  std::size_t left_;
};

}  // namespace

std::vector<std::uint8_t> encode(int kind, const double* x, std::size_t k,
                                 const cadinterp_host_mesh* mesh) {
  if (kind != CADINTERP_REQUEST_SAMPLE && kind != CADINTERP_REQUEST_SIMULATE)
    throw std::invalid_argument("request_codec::encode: unknown request kind " +
                                std::to_string(kind));
  if ((kind == CADINTERP_REQUEST_SIMULATE) != (mesh != nullptr))
    throw std::invalid_argument(
        "request_codec::encode: a SIMULATE request needs a mesh, a SAMPLE request has none");
  std::vector<std::uint8_t> out;
  const std::uint64_t head[2] = {static_cast<std::uint64_t>(kind), k};
  append(out, head, sizeof head);
  if (mesh) {
    const std::uint64_t counts[3] = {mesh->vertex_count, mesh->tet_count, mesh->triangle_count};
    append(out, counts, sizeof counts);
  }
  append(out, x, k * sizeof(double));
  if (mesh) {
    append(out, mesh->vertices, 3 * mesh->vertex_count * sizeof(double));
    append(out, mesh->tets, 4 * mesh->tet_count * sizeof(std::uint32_t));
    append(out, mesh->triangles, 3 * mesh->triangle_count * sizeof(std::uint32_t));
    append(out, mesh->triangle_tags, mesh->triangle_count * sizeof(std::int32_t));
  }
  return out;
}

const char* describe(DecodeError e) {
  switch (e) {
    case DecodeError::kNone:
      return "a well-formed request";
    case DecodeError::kTruncated:
      return "the request ends before the arrays its counts announce";
    case DecodeError::kWrongKind:
      return "the request is of an unknown kind";
    case DecodeError::kWrongParameterCount:
      return "the request's parameter count is not the host's";
    case DecodeError::kOversizeCount:
      return "a count in the request is larger than the request itself";
    case DecodeError::kTrailingBytes:
      return "the request has bytes after its last array";
  }
  return "an unknown decode error";
}

cadinterp_host_mesh Request::mesh() const {
  return cadinterp_host_mesh{vertices.size() / 3, vertices.data(),  tets.size() / 4, tets.data(),
                             tags.size(),         triangles.data(), tags.data()};
}

DecodeError decode(const void* data, std::size_t size, std::size_t parameter_count, Request* out) {
  Reader in(data, size);
  std::uint64_t kind = 0, k = 0;
  if (!in.word(&kind) || !in.word(&k)) return DecodeError::kTruncated;
  if (kind != CADINTERP_REQUEST_SAMPLE && kind != CADINTERP_REQUEST_SIMULATE)
    return DecodeError::kWrongKind;
  if (k != parameter_count) return DecodeError::kWrongParameterCount;
  out->kind = static_cast<int>(kind);
  std::uint64_t counts[3] = {0, 0, 0};
  if (kind == CADINTERP_REQUEST_SIMULATE) {
    for (std::uint64_t& c : counts) {
      if (!in.word(&c)) return DecodeError::kTruncated;
      // Bounded before any product is formed: no count can exceed the bytes that carry it.
      if (c > size) return DecodeError::kOversizeCount;
    }
  }
  if (!in.take(k, &out->x) || !in.take(3 * counts[0], &out->vertices) ||
      !in.take(4 * counts[1], &out->tets) || !in.take(3 * counts[2], &out->triangles) ||
      !in.take(counts[2], &out->tags))
    return DecodeError::kTruncated;
  return in.left() == 0 ? DecodeError::kNone : DecodeError::kTrailingBytes;
}

cadinterp_status answer(const cadinterp_host& host, const Request& request, void** bytes,
                        std::size_t* size) {
  if (request.kind == CADINTERP_REQUEST_SAMPLE)
    return cadinterp_host_evaluate_serialized(&host, request.x.data(), bytes, size);
  const cadinterp_host_mesh mesh = request.mesh();
  return cadinterp_host_simulate_serialized(&host, request.x.data(), &mesh, bytes, size);
}

}  // namespace cadinterp::tools::request_codec
