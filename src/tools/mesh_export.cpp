#include "mesh_export.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>

#include "json_writer.h"

namespace cadinterp::cli {

namespace {

// Little-endian byte buffer, written value by value so the files are the same on any host.
class LeBytes {
 public:
  void u8(std::uint8_t v) { b_.push_back(static_cast<char>(v)); }
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) u8(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void u64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) u8(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void f32(float v) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, 4);
    u32(bits);
  }
  void pad_to(std::size_t multiple, char with) {
    while (b_.size() % multiple != 0) b_.push_back(with);
  }
  std::size_t size() const { return b_.size(); }
  const std::string& str() const { return b_; }
  std::string& str() { return b_; }

 private:
  std::string b_;
};

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) throw std::runtime_error("cannot open " + path + " for writing");
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  f.close();
  if (!f) throw std::runtime_error("cannot write " + path);
}

std::string float_text(float v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(v));  // 9 digits round-trip a float
  return buf;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  for (std::size_t i = 0; i < suffix.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + i])) != suffix[i])
      return false;
  return true;
}

std::string xml_attribute(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        // XML 1.0 forbids most control characters even escaped.
        out += static_cast<unsigned char>(c) < 0x20 ? '_' : c;
    }
  }
  return out;
}

void check_mesh(const ExportMesh& m) {
  if (m.vertex_count > 0 && !m.positions) throw std::invalid_argument("mesh without positions");
  if (m.tet_count > 0 && !m.tets) throw std::invalid_argument("mesh without tets");
  if (m.triangle_count > 0 && !m.triangles) throw std::invalid_argument("mesh without triangles");
  const std::uint64_t n4 = 4ull * m.tet_count, n3 = 3ull * m.triangle_count;
  for (std::uint64_t i = 0; i < n4; ++i)
    if (m.tets[i] >= m.vertex_count) throw std::invalid_argument("tet index out of range");
  for (std::uint64_t i = 0; i < n3; ++i)
    if (m.triangles[i] >= m.vertex_count)
      throw std::invalid_argument("triangle index out of range");
}

// The vertices the boundary triangles use, in ascending original order, and the triangles
// renumbered onto them: surface formats need not carry the interior vertices of the tet mesh.
struct Surface {
  std::vector<std::uint32_t> vertices;   // original index of each surface vertex
  std::vector<std::uint32_t> triangles;  // #F by 3, surface numbering
};

Surface boundary_surface(const ExportMesh& m) {
  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> map(m.vertex_count, kUnused);
  const std::size_t n3 = 3 * static_cast<std::size_t>(m.triangle_count);
  for (std::size_t i = 0; i < n3; ++i) map[m.triangles[i]] = 0;
  Surface s;
  for (std::uint32_t v = 0; v < m.vertex_count; ++v) {
    if (map[v] == kUnused) continue;
    map[v] = static_cast<std::uint32_t>(s.vertices.size());
    s.vertices.push_back(v);
  }
  s.triangles.resize(n3);
  for (std::size_t i = 0; i < n3; ++i) s.triangles[i] = map[m.triangles[i]];
  return s;
}

// One VTU DataArray element; `fill` appends the values as ASCII text or little-endian bytes.
template <typename Fill>
void vtu_array(std::string& out, const char* type, const std::string& name, int components,
               VtuEncoding enc, const Fill& fill) {
  out += "        <DataArray type=\"";
  out += type;
  out += '"';
  if (!name.empty()) out += " Name=\"" + xml_attribute(name) + '"';
  if (components > 0) out += " NumberOfComponents=\"" + std::to_string(components) + '"';
  out += enc == VtuEncoding::Ascii ? " format=\"ascii\">\n" : " format=\"binary\">\n";
  if (enc == VtuEncoding::Ascii) {
    std::string text;
    fill(&text, nullptr);
    out += text;
  } else {
    // VTK's uncompressed inline binary: one base64 stream of the byte count (header_type
    // UInt64) followed by the data.
    LeBytes data;
    fill(nullptr, &data);
    LeBytes all;
    all.u64(data.size());
    all.str() += data.str();
    out += "          " + base64_encode(all.str().data(), all.size());
  }
  out += "\n        </DataArray>\n";
}

// ASCII rows of `per_row` values, a fixed number of rows per line to keep lines readable.
template <typename T, typename ToText>
void ascii_values(std::string* text, const T* v, std::size_t n, std::size_t per_line,
                  const ToText& to_text) {
  for (std::size_t i = 0; i < n; ++i) {
    if (i % per_line == 0)
      *text += i == 0 ? "          " : "\n          ";
    else
      *text += ' ';
    *text += to_text(v[i]);
  }
}

}  // namespace

std::string base64_encode(const void* data, std::size_t size) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const std::uint8_t*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 3 <= size; i += 3) {
    const std::uint32_t v = (std::uint32_t(p[i]) << 16) | (std::uint32_t(p[i + 1]) << 8) | p[i + 2];
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < size) {
    std::uint32_t v = std::uint32_t(p[i]) << 16;
    if (i + 1 < size) v |= std::uint32_t(p[i + 1]) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < size ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

ExportSummary write_vtu(const std::string& path, const ExportMesh& m, VtuEncoding enc) {
  check_mesh(m);
  const std::size_t V = m.vertex_count, T = m.tet_count;
  std::string out;
  out += "<?xml version=\"1.0\"?>\n";
  out += "<!-- " + xml_attribute(m.generator) + " -->\n";
  out +=
      "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
      "header_type=\"UInt64\">\n";
  out += "  <UnstructuredGrid>\n";
  out += "    <Piece NumberOfPoints=\"" + std::to_string(V) + "\" NumberOfCells=\"" +
         std::to_string(T) + "\">\n";

  auto field_arrays = [&](bool per_tet) {
    for (const ExportMesh::Field& f : m.fields) {
      if (f.per_tet != per_tet) continue;
      const std::size_t n = (per_tet ? T : V) * static_cast<std::size_t>(f.components);
      vtu_array(out, "Float32", f.name, f.components, enc, [&](std::string* text, LeBytes* bytes) {
        if (text) {
          ascii_values(text, f.values, n, static_cast<std::size_t>(std::max(f.components, 6)),
                       float_text);
        } else {
          for (std::size_t i = 0; i < n; ++i) bytes->f32(f.values[i]);
        }
      });
    }
  };
  out += "      <PointData>\n";
  field_arrays(false);
  out += "      </PointData>\n";
  out += "      <CellData>\n";
  field_arrays(true);
  out += "      </CellData>\n";

  out += "      <Points>\n";
  vtu_array(out, "Float32", "Points", 3, enc, [&](std::string* text, LeBytes* bytes) {
    if (text) {
      ascii_values(text, m.positions, 3 * V, 3, float_text);
    } else {
      for (std::size_t i = 0; i < 3 * V; ++i) bytes->f32(m.positions[i]);
    }
  });
  out += "      </Points>\n";

  // Int64 connectivity and offsets: what VTK itself writes, and no limit on the mesh size.
  out += "      <Cells>\n";
  vtu_array(out, "Int64", "connectivity", 0, enc, [&](std::string* text, LeBytes* bytes) {
    if (text) {
      ascii_values(text, m.tets, 4 * T, 4, [](std::uint32_t v) { return std::to_string(v); });
    } else {
      for (std::size_t i = 0; i < 4 * T; ++i) bytes->u64(m.tets[i]);
    }
  });
  vtu_array(out, "Int64", "offsets", 0, enc, [&](std::string* text, LeBytes* bytes) {
    for (std::size_t c = 0; c < T; ++c) {
      const std::uint64_t end = 4 * (c + 1);
      if (text) {
        *text += c % 8 == 0 ? (c == 0 ? "          " : "\n          ") : " ";
        *text += std::to_string(end);
      } else {
        bytes->u64(end);
      }
    }
  });
  vtu_array(out, "UInt8", "types", 0, enc, [&](std::string* text, LeBytes* bytes) {
    constexpr std::uint8_t kVtkTetra = 10;
    for (std::size_t c = 0; c < T; ++c) {
      if (text) {
        *text += c % 16 == 0 ? (c == 0 ? "          " : "\n          ") : " ";
        *text += std::to_string(kVtkTetra);
      } else {
        bytes->u8(kVtkTetra);
      }
    }
  });
  out += "      </Cells>\n";
  out += "    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
  write_file(path, out);
  return {V, T, out.size()};
}

ExportSummary write_obj(const std::string& path, const ExportMesh& m) {
  check_mesh(m);
  const Surface s = boundary_surface(m);
  std::string out;
  out += "# " + m.generator + ": boundary surface, " + std::to_string(s.vertices.size()) +
         " vertices, " + std::to_string(m.triangle_count) + " triangles\n";
  out += "o cadinterp\n";
  for (const std::uint32_t v : s.vertices) {
    const float* p = m.positions + 3 * static_cast<std::size_t>(v);
    out += "v " + float_text(p[0]) + ' ' + float_text(p[1]) + ' ' + float_text(p[2]) + '\n';
  }
  for (std::size_t f = 0; f < m.triangle_count; ++f) {
    // OBJ indices are 1-based; counter-clockwise from outside, as the runtime gives them.
    out += "f " + std::to_string(s.triangles[3 * f] + 1) + ' ' +
           std::to_string(s.triangles[3 * f + 1] + 1) + ' ' +
           std::to_string(s.triangles[3 * f + 2] + 1) + '\n';
  }
  write_file(path, out);
  return {s.vertices.size(), m.triangle_count, out.size()};
}

namespace {

constexpr int kGltfFloat = 5126, kGltfUnsignedInt = 5125;
constexpr int kGltfArrayBuffer = 34962, kGltfElementArrayBuffer = 34963;
constexpr int kGltfTriangles = 4;

// One glTF application attribute: an exported per-vertex field and its value range.
struct GltfAttribute {
  std::string semantic, source;
  int components;
  std::vector<float> lo, hi;
};

// The binary buffer of a glTF export and what its accessors say about it. Layout: positions,
// indices, then one array per exported field; every part is a multiple of 4 bytes long, so every
// accessor is aligned to its component size.
struct GltfBuffer {
  struct View {
    std::size_t offset, length;
    int target;
  };
  LeBytes bin;
  std::vector<View> views;
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};                                // position range
  std::uint32_t imin = std::numeric_limits<std::uint32_t>::max(), imax = 0;  // index range
  std::vector<GltfAttribute> attrs;
};

// Appends the surface's positions and triangle indices, with their ranges.
void gltf_geometry(const ExportMesh& m, const Surface& s, GltfBuffer& b) {
  const std::size_t Vs = s.vertices.size();
  std::size_t start = b.bin.size();
  for (std::size_t i = 0; i < Vs; ++i) {
    const float* p = m.positions + 3 * static_cast<std::size_t>(s.vertices[i]);
    for (int c = 0; c < 3; ++c) {
      b.lo[c] = i == 0 ? p[c] : std::min(b.lo[c], p[c]);
      b.hi[c] = i == 0 ? p[c] : std::max(b.hi[c], p[c]);
      b.bin.f32(p[c]);
    }
  }
  b.views.push_back({start, b.bin.size() - start, kGltfArrayBuffer});
  start = b.bin.size();
  for (const std::uint32_t i : s.triangles) {
    b.imin = std::min(b.imin, i);
    b.imax = std::max(b.imax, i);
    b.bin.u32(i);
  }
  b.views.push_back({start, b.bin.size() - start, kGltfElementArrayBuffer});
}

// Appends one application attribute per exportable field: glTF allows per-vertex float data of
// 1-4 components only. The semantic is the field's name upper-cased with other characters as
// '_', made unique by a suffix.
void gltf_attributes(const ExportMesh& m, const Surface& s, GltfBuffer& b) {
  const std::size_t Vs = s.vertices.size();
  for (const ExportMesh::Field& f : m.fields) {
    if (f.per_tet || f.components < 1 || f.components > 4) continue;
    std::string sem = "_";
    for (const char c : f.name)
      sem += std::isalnum(static_cast<unsigned char>(c))
                 ? static_cast<char>(std::toupper(static_cast<unsigned char>(c)))
                 : '_';
    for (const GltfAttribute& a : b.attrs)
      if (a.semantic == sem) sem += "_" + std::to_string(b.attrs.size());
    GltfAttribute a{sem, f.name, f.components, std::vector<float>(f.components),
                    std::vector<float>(f.components)};
    const std::size_t start = b.bin.size();
    for (std::size_t i = 0; i < Vs; ++i) {
      const float* v = f.values + static_cast<std::size_t>(f.components) * s.vertices[i];
      for (int c = 0; c < f.components; ++c) {
        const auto cc = static_cast<std::size_t>(c);
        a.lo[cc] = i == 0 ? v[c] : std::min(a.lo[cc], v[c]);
        a.hi[cc] = i == 0 ? v[c] : std::max(a.hi[cc], v[c]);
        b.bin.f32(v[c]);
      }
    }
    b.views.push_back({start, b.bin.size() - start, kGltfArrayBuffer});
    b.attrs.push_back(std::move(a));
  }
}

// The asset, scene, node and mesh objects: one mesh of one triangle primitive.
void gltf_scene(JsonWriter& w, const ExportMesh& m, const std::vector<GltfAttribute>& attrs) {
  w.key("asset")
      .begin_object()
      .field("version", "2.0")
      .field("generator", m.generator)
      .end_object();
  w.field("scene", 0);
  w.key("scenes").begin_array().begin_object().key("nodes").begin_array().value(0).end_array();
  w.end_object().end_array();
  w.key("nodes").begin_array().begin_object().field("mesh", 0).field("name", "cadinterp");
  w.end_object().end_array();

  w.key("meshes").begin_array().begin_object().field("name", "boundary");
  w.key("primitives").begin_array().begin_object();
  w.key("attributes").begin_object().field("POSITION", 0);
  for (std::size_t a = 0; a < attrs.size(); ++a)
    w.field(attrs[a].semantic, static_cast<int>(a + 2));
  w.end_object();
  w.field("indices", 1).field("mode", kGltfTriangles);
  w.end_object().end_array();
  if (!attrs.empty()) {
    // Which field each application attribute holds, since the semantic is mangled.
    w.key("extras").begin_object().key("fields").begin_object();
    for (const GltfAttribute& a : attrs) w.field(a.semantic, a.source);
    w.end_object().end_object();
  }
  w.end_object().end_array();
}

// The accessors (positions, indices, attributes: one per buffer view, with the min and max
// glTF requires of positions) and the buffer views.
void gltf_accessors(JsonWriter& w, const Surface& s, const GltfBuffer& b) {
  const std::size_t Vs = s.vertices.size();
  auto vec_type = [](int n) {
    return n == 1 ? "SCALAR" : n == 2 ? "VEC2" : n == 3 ? "VEC3" : "VEC4";
  };
  w.key("accessors").begin_array();
  w.begin_object().field("bufferView", 0).field("componentType", kGltfFloat);
  w.field("count", static_cast<std::uint64_t>(Vs)).field("type", "VEC3");
  w.key("min").begin_array();
  for (const float v : b.lo) w.value_float(v);
  w.end_array().key("max").begin_array();
  for (const float v : b.hi) w.value_float(v);
  w.end_array().end_object();
  w.begin_object().field("bufferView", 1).field("componentType", kGltfUnsignedInt);
  w.field("count", static_cast<std::uint64_t>(s.triangles.size())).field("type", "SCALAR");
  w.key("min").begin_array().value(b.imin).end_array();
  w.key("max").begin_array().value(b.imax).end_array().end_object();
  for (std::size_t a = 0; a < b.attrs.size(); ++a) {
    w.begin_object()
        .field("bufferView", static_cast<int>(a + 2))
        .field("componentType", kGltfFloat);
    w.field("count", static_cast<std::uint64_t>(Vs)).field("type", vec_type(b.attrs[a].components));
    w.key("min").begin_array();
    for (const float v : b.attrs[a].lo) w.value_float(v);
    w.end_array().key("max").begin_array();
    for (const float v : b.attrs[a].hi) w.value_float(v);
    w.end_array().end_object();
  }
  w.end_array();

  w.key("bufferViews").begin_array();
  for (const GltfBuffer::View& v : b.views) {
    w.begin_object().field("buffer", 0).field("byteOffset", static_cast<std::uint64_t>(v.offset));
    w.field("byteLength", static_cast<std::uint64_t>(v.length)).field("target", v.target);
    w.end_object();
  }
  w.end_array();
}

// GLB: 12-byte header, a JSON chunk padded with spaces and a BIN chunk padded with zeros, both
// to 4 bytes (glTF 2.0, "Binary glTF Layout"). Throws std::runtime_error past 4 GiB.
std::string glb_file(std::string json, LeBytes& bin) {
  while (json.size() % 4 != 0) json += ' ';
  bin.pad_to(4, '\0');
  const std::uint64_t total = 12 + 8 + json.size() + 8 + bin.size();
  if (total > std::numeric_limits<std::uint32_t>::max())
    throw std::runtime_error("the mesh is too large for a .glb (4 GiB); write a .gltf");
  LeBytes file;
  file.u32(0x46546C67);  // "glTF"
  file.u32(2);
  file.u32(static_cast<std::uint32_t>(total));
  file.u32(static_cast<std::uint32_t>(json.size()));
  file.u32(0x4E4F534A);  // "JSON"
  file.str() += json;
  file.u32(static_cast<std::uint32_t>(bin.size()));
  file.u32(0x004E4942);  // "BIN\0"
  file.str() += bin.str();
  return std::move(file.str());
}

}  // namespace

ExportSummary write_gltf(const std::string& path, const ExportMesh& m) {
  check_mesh(m);
  // Accessors must have count >= 1 (glTF 2.0, accessor.count), so an empty surface has no
  // valid glTF form.
  if (m.triangle_count == 0) throw std::runtime_error("the mesh has no boundary triangles");
  const Surface s = boundary_surface(m);
  const bool glb = ends_with(path, ".glb");

  GltfBuffer b;
  gltf_geometry(m, s, b);
  gltf_attributes(m, s, b);

  std::string json;
  JsonWriter w(json, glb ? 0 : 1);
  w.begin_object();
  gltf_scene(w, m, b.attrs);
  gltf_accessors(w, s, b);
  w.key("buffers").begin_array().begin_object();
  w.field("byteLength", static_cast<std::uint64_t>(b.bin.size()));
  if (!glb)
    w.field("uri", "data:application/octet-stream;base64," +
                       base64_encode(b.bin.str().data(), b.bin.size()));
  w.end_object().end_array();
  w.end_object();

  const std::string out = glb ? glb_file(std::move(json), b.bin) : std::move(json);
  write_file(path, out);
  return {s.vertices.size(), m.triangle_count, out.size()};
}

ExportMesh export_mesh_of(const cadinterp_asset* asset, const cadinterp_mesh& mesh,
                          const int* fields, int field_count) {
  ExportMesh em;
  em.vertex_count = mesh.vertex_count;
  em.tet_count = mesh.tet_count;
  em.triangle_count = mesh.triangle_count;
  em.positions = mesh.positions;
  em.tets = mesh.tets;
  em.triangles = mesh.triangles;
  em.triangle_tags = mesh.triangle_tags;
  for (int k = 0; k < field_count; ++k) {
    cadinterp_field_info info{};
    cadinterp_field(asset, fields[k], &info);
    em.fields.push_back(
        {info.name, info.location == CADINTERP_PER_TET, info.components, mesh.fields[k]});
  }
  return em;
}

}  // namespace cadinterp::cli
