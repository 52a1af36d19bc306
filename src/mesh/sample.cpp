#include "mesh/sample.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <stdexcept>

#include "format/codec.h"

namespace cadinterp::mesh {

using format::detail::get_f64;
using format::detail::get_u32;
using format::detail::get_u64;
using format::detail::put_f64;
using format::detail::put_u32;
using format::detail::put_u64;

double Sample::bbox_diagonal() const { return mesh::bbox_diagonal(vertices); }

double bbox_diagonal(const std::vector<double>& vertices) {
  if (vertices.size() < 3) return 0.0;
  double lo[3], hi[3];
  for (int c = 0; c < 3; ++c) lo[c] = hi[c] = vertices[static_cast<std::size_t>(c)];
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const int c = static_cast<int>(i % 3);
    lo[c] = std::min(lo[c], vertices[i]);
    hi[c] = std::max(hi[c], vertices[i]);
  }
  return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                   (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

std::string validate(const Sample& s) {
  const std::size_t nv = s.vertex_count(), nt = s.tet_count(), nf = s.triangle_count();
  if (nv == 0 || nt == 0) return "empty mesh (no vertices or no tets)";
  if (s.vertices.size() != nv * 3 || s.tets.size() != nt * 4 || s.triangles.size() != nf * 3)
    return "array sizes are not multiples of 3 / 4 / 3";
  if (s.triangle_tags.size() != nf) return "triangle tag count differs from the triangle count";
  for (double v : s.vertices)
    if (!std::isfinite(v)) return "non-finite vertex coordinate";
  for (std::uint32_t i : s.tets)
    if (i >= nv) return "tet vertex index out of range";
  for (std::uint32_t i : s.triangles)
    if (i >= nv) return "triangle vertex index out of range";
  const double diag = s.bbox_diagonal();
  // 6 V = det[b - a, c - a, d - a]; below this a tet is degenerate at double precision of the
  // model's scale (and would give the interpolant nothing to interpolate).
  const double min_six_volume = 1e-12 * diag * diag * diag;
  for (std::size_t t = 0; t < nt; ++t) {
    const double* p[4];
    for (int k = 0; k < 4; ++k) p[k] = &s.vertices[3 * s.tets[4 * t + static_cast<std::size_t>(k)]];
    double e[3][3];
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) e[k][c] = p[k + 1][c] - p[0][c];
    const double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                       e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                       e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
    if (!(det > min_six_volume))
      return "tet " + std::to_string(t) + (det < 0 ? " is inverted" : " is degenerate");
  }
  std::set<std::vector<std::int64_t>> ids;
  for (const ControlPoint& p : s.points) {
    if (p.id.empty()) return "control point with an empty ID";
    for (double v : p.position)
      if (!std::isfinite(v)) return "non-finite control point";
    if (!ids.insert(p.id).second) return "control point ID given twice";
  }
  for (const Path& p : s.paths)
    for (double v : p.polyline)
      if (!std::isfinite(v)) return "non-finite path point";
  for (const Field& f : s.fields) {
    const std::size_t rows = f.location == 0 ? nv : nt;
    if (f.values.size() != rows * static_cast<std::size_t>(f.components))
      return "field '" + f.name + "' has " + std::to_string(f.values.size()) +
             " values, expected " + std::to_string(rows * static_cast<std::size_t>(f.components));
    for (double v : f.values)
      if (!std::isfinite(v)) return "field '" + f.name + "' has non-finite values";
  }
  std::set<std::string> output_names;
  for (const Output& o : s.outputs) {
    if (o.name.empty()) return "output with an empty name";
    if (!output_names.insert(o.name).second) return "output '" + o.name + "' given twice";
    if (!std::isfinite(o.value)) return "output '" + o.name + "' is not finite";
  }
  return "";
}

namespace {

constexpr std::uint32_t kMagic = 0x53494443;  // "CDIS"
// 2 appended the field units after the fields, 3 the scalar outputs after the units; version 1
// and 2 bytes (stores written by earlier builds) still read, without units or outputs.
constexpr std::uint32_t kVersion = 3;

void put_str(std::vector<std::uint8_t>& out, const std::string& s) {
  put_u64(out, s.size());
  out.insert(out.end(), s.begin(), s.end());
}
template <class T>
void put_pod(std::vector<std::uint8_t>& out, const std::vector<T>& v) {
  static_assert(std::is_trivially_copyable<T>::value, "pod");
  put_u64(out, v.size());
  const std::size_t at = out.size();
  out.resize(at + v.size() * sizeof(T));
  if (!v.empty()) std::memcpy(out.data() + at, v.data(), v.size() * sizeof(T));
}

class Reader {
 public:
  Reader(const std::uint8_t* b, std::size_t n) : b_(b), n_(n) {}
  std::uint32_t u32() { return get_u32(b_, n_, pos_); }
  std::uint64_t u64() { return get_u64(b_, n_, pos_); }
  double f64() { return get_f64(b_, n_, pos_); }
  std::size_t count(std::size_t elem) {
    const std::uint64_t c = u64();
    if (c > (n_ - pos_) / elem) throw std::runtime_error("sample bytes: count exceeds the data");
    return static_cast<std::size_t>(c);
  }
  std::string str() {
    const std::size_t c = count(1);
    std::string s(reinterpret_cast<const char*>(b_ + pos_), c);
    pos_ += c;
    return s;
  }
  template <class T>
  std::vector<T> pod() {
    const std::size_t c = count(sizeof(T));
    std::vector<T> v(c);
    if (c) std::memcpy(v.data(), b_ + pos_, c * sizeof(T));
    pos_ += c * sizeof(T);
    return v;
  }
  bool done() const { return pos_ == n_; }

 private:
  const std::uint8_t* b_;
  std::size_t n_, pos_ = 0;
};

}  // namespace

std::vector<std::uint8_t> serialize(const Sample& s) {
  // Host-endian memcpy of arrays: the store never leaves the machine that built it in a form
  // another architecture reads (the asset is the portable artefact), and every supported target
  // is little-endian, as the put_* scalars are.
  std::vector<std::uint8_t> out;
  put_u32(out, kMagic);
  put_u32(out, kVersion);
  put_u32(out, s.feasible ? 1 : 0);
  put_str(out, s.message);
  put_pod(out, s.vertices);
  put_pod(out, s.tets);
  put_pod(out, s.triangles);
  put_pod(out, s.triangle_tags);
  put_u64(out, s.points.size());
  for (const ControlPoint& p : s.points) {
    put_pod(out, p.id);
    for (double v : p.position) put_f64(out, v);
  }
  put_u64(out, s.paths.size());
  for (const Path& p : s.paths) {
    put_pod(out, p.a);
    put_pod(out, p.b);
    put_pod(out, p.polyline);
  }
  put_u64(out, s.regions.size());
  for (const Region& r : s.regions) {
    put_str(out, r.name);
    put_str(out, r.kind);
    put_pod(out, r.face_tags);
  }
  put_u64(out, s.fields.size());
  for (const Field& f : s.fields) {
    put_str(out, f.name);
    put_u32(out, f.location);
    put_u32(out, static_cast<std::uint32_t>(f.components));
    put_pod(out, f.values);
  }
  for (const Field& f : s.fields) put_str(out, f.unit);  // version 2
  put_u64(out, s.outputs.size());                        // version 3
  for (const Output& o : s.outputs) {
    put_str(out, o.name);
    put_f64(out, o.value);
    put_str(out, o.unit);
  }
  return out;
}

Sample deserialize(const std::uint8_t* bytes, std::size_t size) {
  try {
    Reader r(bytes, size);
    if (r.u32() != kMagic) throw std::runtime_error("sample bytes: bad magic");
    const std::uint32_t version = r.u32();
    if (version < 1 || version > kVersion)
      throw std::runtime_error("sample bytes: unknown version");
    Sample s;
    s.feasible = r.u32() != 0;
    s.message = r.str();
    s.vertices = r.pod<double>();
    s.tets = r.pod<std::uint32_t>();
    s.triangles = r.pod<std::uint32_t>();
    s.triangle_tags = r.pod<std::int32_t>();
    s.points.resize(r.count(16));
    for (ControlPoint& p : s.points) {
      p.id = r.pod<std::int64_t>();
      for (double& v : p.position) v = r.f64();
    }
    s.paths.resize(r.count(24));
    for (Path& p : s.paths) {
      p.a = r.pod<std::int64_t>();
      p.b = r.pod<std::int64_t>();
      p.polyline = r.pod<double>();
    }
    s.regions.resize(r.count(24));
    for (Region& g : s.regions) {
      g.name = r.str();
      g.kind = r.str();
      g.face_tags = r.pod<std::int32_t>();
    }
    s.fields.resize(r.count(24));
    for (Field& f : s.fields) {
      f.name = r.str();
      f.location = static_cast<std::uint8_t>(r.u32());
      f.components = static_cast<int>(r.u32());
      f.values = r.pod<double>();
    }
    if (version >= 2)
      for (Field& f : s.fields) f.unit = r.str();
    if (version >= 3) {
      s.outputs.resize(r.count(24));
      for (Output& o : s.outputs) {
        o.name = r.str();
        o.value = r.f64();
        o.unit = r.str();
      }
    }
    if (!r.done()) throw std::runtime_error("sample bytes: trailing data");
    return s;
  } catch (const format::CodecError&) {
    throw std::runtime_error("sample bytes: truncated");
  }
}

bool same_combinatorics(const Sample& a, const Sample& b) {
  return a.vertex_count() == b.vertex_count() && a.tets == b.tets && a.triangles == b.triangles &&
         a.triangle_tags == b.triangle_tags;
}

}  // namespace cadinterp::mesh
