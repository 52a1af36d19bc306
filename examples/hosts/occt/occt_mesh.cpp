// Tessellation (BRepMesh) and tetrahedralization (TetGen) of a named B-rep (occt_mesh.h).
#include "occt_mesh.h"

#include <BRepBndLib.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <Poly_Triangulation.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>

#define TETLIBRARY
#include <tetgen.h>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <unordered_map>

#include "occt_models.h"

namespace cadinterp::occt {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Welds coincident nodes of neighbouring face triangulations: BRepMesh discretizes a shared
// edge once, so both faces' nodes agree to round-off; a grid of cell `eps` finds them.
class Welder {
 public:
  explicit Welder(double eps) : eps_(eps) {}
  std::uint32_t add(const gp_Pnt& p) {
    const std::array<long long, 3> c = cell(p);
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          auto it = grid_.find(hash({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == grid_.end()) continue;
          for (std::uint32_t i : it->second)
            if (std::abs(points_[3 * i] - p.X()) <= eps_ &&
                std::abs(points_[3 * i + 1] - p.Y()) <= eps_ &&
                std::abs(points_[3 * i + 2] - p.Z()) <= eps_)
              return i;
        }
    const auto i = static_cast<std::uint32_t>(points_.size() / 3);
    points_.insert(points_.end(), {p.X(), p.Y(), p.Z()});
    grid_[hash(c)].push_back(i);
    return i;
  }
  const std::vector<double>& points() const { return points_; }

 private:
  std::array<long long, 3> cell(const gp_Pnt& p) const {
    return {std::llround(p.X() / eps_), std::llround(p.Y() / eps_), std::llround(p.Z() / eps_)};
  }
  static std::uint64_t hash(const std::array<long long, 3>& c) {
    std::uint64_t h = 1469598103934665603ull;
    for (long long v : c) {
      h ^= static_cast<std::uint64_t>(v);
      h *= 1099511628211ull;
    }
    return h;
  }
  double eps_;
  std::vector<double> points_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid_;
};

double orient(const double* v, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  double e[3][3];
  for (int k = 0; k < 3; ++k) {
    e[0][k] = v[3 * b + k] - v[3 * a + k];
    e[1][k] = v[3 * c + k] - v[3 * a + k];
    e[2][k] = v[3 * d + k] - v[3 * a + k];
  }
  return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
         e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
         e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
}

double dist(const std::vector<double>& p, std::uint32_t a, std::uint32_t b) {
  const double dx = p[3 * a] - p[3 * b], dy = p[3 * a + 1] - p[3 * b + 1],
               dz = p[3 * a + 2] - p[3 * b + 2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// Splits surface triangles until no edge is longer than h, by longest-edge bisection (Rivara):
// a triangle is only ever cut through the midpoint of its longest edge, which keeps its angles
// bounded away from 0 (skinny input triangles make TetGen fail under -Y). Every split edge's
// midpoint is shared by both its triangles, so the surface stays closed; the midpoints lie on
// the triangles, so the polyhedron and its volume are unchanged. BRepMesh alone leaves planar
// faces as a few long triangles, and TetGen -Y adds no boundary points: without this,
// mesh_size would not reach the boundary.
void refine_surface(std::vector<double>& pts, std::vector<std::uint32_t>& tris,
                    std::vector<int>& tri_face, double h) {
  using Edge = std::pair<std::uint32_t, std::uint32_t>;
  auto longest = [&](const std::uint32_t* v) {
    int best = 0;
    double len = -1;
    for (int k = 0; k < 3; ++k) {
      const double l = dist(pts, v[k], v[(k + 1) % 3]);
      // Ties broken by the vertex indices, so both neighbours of an edge agree.
      if (l > len * (1 + 1e-12) ||
          (l >= len * (1 - 1e-12) &&
           std::minmax(v[k], v[(k + 1) % 3]) < std::minmax(v[best], v[(best + 1) % 3]))) {
        best = k;
        len = l;
      }
    }
    return best;
  };
  for (int pass = 0; pass < 40; ++pass) {
    std::map<Edge, std::uint32_t> mid;
    for (std::size_t t = 0; t < tris.size(); t += 3) {
      const int k = longest(&tris[t]);
      const std::uint32_t a = tris[t + static_cast<std::size_t>(k)],
                          b = tris[t + static_cast<std::size_t>((k + 1) % 3)];
      if (dist(pts, a, b) > h) mid.emplace(std::minmax(a, b), 0u);
    }
    if (mid.empty()) return;
    // Closure: a triangle with any split edge splits its longest edge too.
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t t = 0; t < tris.size(); t += 3) {
        const std::uint32_t* v = &tris[t];
        bool any = false;
        for (int k = 0; k < 3; ++k) any = any || mid.count(std::minmax(v[k], v[(k + 1) % 3]));
        const int k = longest(v);
        if (any && mid.emplace(std::minmax(v[k], v[(k + 1) % 3]), 0u).second) changed = true;
      }
    }
    for (auto& m : mid) {
      m.second = static_cast<std::uint32_t>(pts.size() / 3);
      for (std::size_t c = 0; c < 3; ++c)
        pts.push_back(0.5 * (pts[3 * m.first.first + c] + pts[3 * m.first.second + c]));
    }
    std::vector<std::uint32_t> out;
    std::vector<int> out_face;
    auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, int f) {
      out.insert(out.end(), {a, b, c});
      out_face.push_back(f);
    };
    auto split_at = [&](std::uint32_t a, std::uint32_t b) {
      auto it = mid.find(std::minmax(a, b));
      return it == mid.end() ? UINT32_MAX : it->second;
    };
    for (std::size_t t = 0; t < tris.size(); t += 3) {
      const int f = tri_face[t / 3];
      const int k = longest(&tris[t]);
      // (a, b) the longest edge, c opposite; counter-clockwise as the input.
      const std::uint32_t a = tris[t + static_cast<std::size_t>(k)],
                          b = tris[t + static_cast<std::size_t>((k + 1) % 3)],
                          c = tris[t + static_cast<std::size_t>((k + 2) % 3)];
      const std::uint32_t p = split_at(a, b);
      if (p == UINT32_MAX) {
        emit(a, b, c, f);
        continue;
      }
      const std::uint32_t q = split_at(b, c), r = split_at(c, a);
      if (q == UINT32_MAX) {
        emit(p, b, c, f);
      } else {
        emit(p, b, q, f);
        emit(p, q, c, f);
      }
      if (r == UINT32_MAX) {
        emit(a, p, c, f);
      } else {
        emit(a, p, r, f);
        emit(p, c, r, f);
      }
    }
    tris.swap(out);
    tri_face.swap(out_face);
  }
}

// TetGen keeps global state in its exact predicates' initialisation; one call at a time.
std::mutex g_tetgen_lock;

// What a TetGen run returns (copied out of its tetgenio).
struct TetGenOutput {
  std::vector<double> points;
  std::vector<int> tets, trifaces, markers;
};

bool write_all(int fd, const void* data, std::size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

template <class T>
bool write_vec(int fd, const T* data, std::size_t n) {
  const std::uint64_t count = n;
  return write_all(fd, &count, sizeof count) && (n == 0 || write_all(fd, data, n * sizeof(T)));
}

template <class T>
bool read_vec(const std::vector<char>& buf, std::size_t& at, std::vector<T>& out) {
  std::uint64_t count = 0;
  if (buf.size() - at < sizeof count) return false;
  std::memcpy(&count, buf.data() + at, sizeof count);
  at += sizeof count;
  if (count > (buf.size() - at) / sizeof(T)) return false;
  out.resize(static_cast<std::size_t>(count));
  if (count) std::memcpy(out.data(), buf.data() + at, static_cast<std::size_t>(count) * sizeof(T));
  at += static_cast<std::size_t>(count) * sizeof(T);
  return true;
}

// Sanitizer runtimes (GCC 12) do not make their allocators safe across fork(): a child forked
// while another thread holds the allocator's lock deadlocks. There TetGen runs in-process.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define OCCT_HOST_FORK_TETGEN 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define OCCT_HOST_FORK_TETGEN 0
#endif
#endif
#ifndef OCCT_HOST_FORK_TETGEN
#define OCCT_HOST_FORK_TETGEN 1
#endif

void copy_output(const tetgenio& out, TetGenOutput& result) {
  result.points.assign(out.pointlist, out.pointlist + 3 * out.numberofpoints);
  result.tets.assign(out.tetrahedronlist,
                     out.tetrahedronlist + out.numberofcorners * out.numberoftetrahedra);
  result.trifaces.assign(out.trifacelist, out.trifacelist + 3 * out.numberoftrifaces);
  if (out.trifacemarkerlist)
    result.markers.assign(out.trifacemarkerlist, out.trifacemarkerlist + out.numberoftrifaces);
}

// Runs TetGen in a child process: TetGen 1.5 stops on some inputs with assert(0) (segment
// recovery under -Y), which would abort the whole build; in a child it only loses that point.
// The child inherits the input, runs TetGen, writes the output to a pipe and _exits.
bool run_tetgen(tetgenio& in, const char* switches, TetGenOutput& result, std::string& why) {
  if (!OCCT_HOST_FORK_TETGEN) {
    try {
      tetgenio out;
      tetrahedralize(const_cast<char*>(switches), &in, &out);
      copy_output(out, result);
      return true;
    } catch (...) {
      why = "TetGen failed on the tessellated surface (self-intersecting or degenerate facets)";
      return false;
    }
  }
  int fds[2];
  if (::pipe(fds) != 0) {
    why = "TetGen: cannot create a pipe";
    return false;
  }
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    why = "TetGen: cannot fork";
    return false;
  }
  if (pid == 0) {
    ::close(fds[0]);
    // TetGen's assertion messages would only repeat what the parent reports.
    const int devnull = ::open("/dev/null", O_WRONLY);
    if (devnull >= 0) ::dup2(devnull, 2);
    int code = 0;
    try {
      tetgenio out;
      tetrahedralize(const_cast<char*>(switches), &in, &out);
      const bool ok =
          write_vec(fds[1], out.pointlist, 3 * static_cast<std::size_t>(out.numberofpoints)) &&
          write_vec(fds[1], out.tetrahedronlist,
                    static_cast<std::size_t>(out.numberofcorners) *
                        static_cast<std::size_t>(out.numberoftetrahedra)) &&
          write_vec(fds[1], out.trifacelist, 3 * static_cast<std::size_t>(out.numberoftrifaces)) &&
          write_vec(fds[1], out.trifacemarkerlist,
                    out.trifacemarkerlist ? static_cast<std::size_t>(out.numberoftrifaces) : 0);
      code = ok ? 0 : 3;
    } catch (...) {
      code = 2;  // TetGen reports errors by throwing an int code (TETLIBRARY)
    }
    ::close(fds[1]);
    ::_exit(code);
  }
  ::close(fds[1]);
  std::vector<char> buf;
  char chunk[1 << 16];
  for (;;) {
    const ssize_t r = ::read(fds[0], chunk, sizeof chunk);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    buf.insert(buf.end(), chunk, chunk + r);
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    why = "TetGen crashed (signal " + std::to_string(WTERMSIG(status)) +
          ", an internal assertion) on the tessellated surface";
    return false;
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    why = "TetGen failed on the tessellated surface (self-intersecting or degenerate facets)";
    return false;
  }
  std::size_t at = 0;
  if (!read_vec(buf, at, result.points) || !read_vec(buf, at, result.tets) ||
      !read_vec(buf, at, result.trifaces) || !read_vec(buf, at, result.markers)) {
    why = "TetGen: truncated output from the child process";
    return false;
  }
  return true;
}

// TetGen on the closed tagged surface; false with `why` when it fails or leaves a sliver.
bool tetrahedralize_surface(const std::vector<double>& pts, const std::vector<std::uint32_t>& tris,
                            const std::vector<int>& tri_face, const std::vector<std::int32_t>& tags,
                            const MeshSettings& settings, double h, double diag, TetMeshData& m,
                            std::string& why) {
  tetgenio in;
  in.firstnumber = 0;
  in.numberofpoints = static_cast<int>(pts.size() / 3);
  in.pointlist = new REAL[pts.size()];
  std::copy(pts.begin(), pts.end(), in.pointlist);
  const int nf = static_cast<int>(tris.size() / 3);
  in.numberoffacets = nf;
  in.facetlist = new tetgenio::facet[static_cast<std::size_t>(nf)];
  in.facetmarkerlist = new int[static_cast<std::size_t>(nf)];
  for (int i = 0; i < nf; ++i) {
    const std::size_t fi = static_cast<std::size_t>(i);
    tetgenio::facet& fc = in.facetlist[i];
    tetgenio::init(&fc);
    fc.numberofpolygons = 1;
    fc.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&fc.polygonlist[0]);
    fc.polygonlist[0].numberofvertices = 3;
    fc.polygonlist[0].vertexlist = new int[3];
    for (std::size_t k = 0; k < 3; ++k)
      fc.polygonlist[0].vertexlist[k] = static_cast<int>(tris[3 * fi + k]);
    // Markers are 1-based face indices: TetGen uses 0 for "no marker".
    in.facetmarkerlist[i] = tri_face[fi] + 1;
  }
  // p: a piecewise linear complex; q: radius-edge ratio / smallest dihedral angle (10 degrees,
  // without which TetGen leaves slivers the builder rejects as degenerate); a: the volume of a
  // regular tet of edge h; z: zero-based; Q: quiet; Y: no Steiner points on the boundary.
  char switches[128];
  std::snprintf(switches, sizeof switches, "pq%.4g/10a%.6gzQ%s", settings.quality,
                h * h * h / (6 * std::sqrt(2.0)), settings.keep_surface ? "Y" : "");
  TetGenOutput out;
  {
    std::lock_guard<std::mutex> lock(g_tetgen_lock);
    if (!run_tetgen(in, switches, out, why)) return false;
  }
  if (out.tets.empty() || out.tets.size() % 4 != 0 || out.points.empty()) {
    why = "TetGen produced no tets";
    return false;
  }
  const std::size_t nv = out.points.size() / 3;
  for (int idx : out.tets)
    if (idx < 0 || static_cast<std::size_t>(idx) >= nv) {
      why = "TetGen produced an out-of-range vertex index";
      return false;
    }

  m.vertices = std::move(out.points);
  const double* v = m.vertices.data();
  m.tets.reserve(out.tets.size());
  // Boundary faces of the tets, outward (the face opposite vertex k, seen from outside).
  std::map<std::array<std::uint32_t, 3>, std::array<std::uint32_t, 3>> boundary;
  const int faces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  for (std::size_t t = 0; t < out.tets.size(); t += 4) {
    std::uint32_t q[4];
    for (std::size_t k = 0; k < 4; ++k) q[k] = static_cast<std::uint32_t>(out.tets[t + k]);
    const double det = orient(v, q[0], q[1], q[2], q[3]);
    // 1.5 times the builder's threshold (sample.h: volume above 1e-12 of the bbox diagonal
    // cubed, whose bbox is the mesh's, at most ours), so that what passes here passes there.
    if (std::abs(det) / 6 <= 1.5e-12 * diag * diag * diag) {
      char b[160];
      std::snprintf(b, sizeof b,
                    "TetGen produced a degenerate (sliver) tet: volume %.3g of the bounding "
                    "box diagonal cubed",
                    std::abs(det) / 6 / (diag * diag * diag));
      why = b;
      return false;
    }
    if (det < 0) std::swap(q[2], q[3]);
    m.tets.insert(m.tets.end(), q, q + 4);
    for (const auto& f : faces) {
      std::array<std::uint32_t, 3> tri{q[f[0]], q[f[1]], q[f[2]]};
      std::array<std::uint32_t, 3> key = tri;
      std::sort(key.begin(), key.end());
      auto it = boundary.find(key);
      if (it == boundary.end())
        boundary.emplace(key, tri);
      else
        boundary.erase(it);
    }
  }
  // TetGen's boundary faces carry the marker of the input facet they lie on.
  const std::size_t ntri = out.trifaces.size() / 3;
  for (std::size_t i = 0; i < ntri; ++i) {
    std::array<std::uint32_t, 3> key;
    for (std::size_t k = 0; k < 3; ++k)
      key[k] = static_cast<std::uint32_t>(out.trifaces[3 * i + k]);
    std::sort(key.begin(), key.end());
    auto it = boundary.find(key);
    if (it == boundary.end()) continue;  // an interior face (none expected for one solid)
    const int marker = i < out.markers.size() ? out.markers[i] : 0;
    if (marker < 1 || marker > static_cast<int>(tags.size())) {
      why = "TetGen lost the face marker of a boundary triangle";
      return false;
    }
    m.triangles.insert(m.triangles.end(), it->second.begin(), it->second.end());
    m.triangle_tags.push_back(tags[static_cast<std::size_t>(marker - 1)]);
    boundary.erase(it);
  }
  if (!boundary.empty()) {
    why =
        "TetGen's boundary has " + std::to_string(boundary.size()) + " faces without a B-rep face";
    return false;
  }
  return true;
}

}  // namespace

TetMeshData mesh_shape(const NamedShape& s, const MeshSettings& settings, MeshTimes& times) {
  if (!(settings.mesh_size > 0)) throw Infeasible("mesh size must be positive");
  auto t0 = Clock::now();
  Bnd_Box bb;
  BRepBndLib::Add(s.shape, bb);
  const double diag = std::sqrt(bb.SquareExtent());
  // Sag 1/10 of the element size and at most ~17 degrees per segment on curved faces (a
  // 21-gon keeps 98.5% of a circle's area).
  BRepMesh_IncrementalMesh mesher(s.shape, 0.1 * settings.mesh_size, false, settings.angle, false);
  if (!mesher.IsDone()) throw Infeasible("tessellation (BRepMesh) failed");

  Welder weld(1e-7 * diag);
  std::vector<std::uint32_t> tris;
  std::vector<int> tri_face;  // index into `tags`
  std::vector<std::int32_t> tags;
  std::map<std::int32_t, std::string> tag_owner;
  for (TopExp_Explorer ex(s.shape, TopAbs_FACE); ex.More(); ex.Next()) {
    const TopoDS_Face& f = TopoDS::Face(ex.Current());
    const FaceName* name = s.faces.Seek(f);
    if (!name) throw Infeasible("a face has no name (naming failed)");
    const std::int32_t tag = face_tag(name->label);
    auto owner = tag_owner.emplace(tag, name->label);
    if (!owner.first->second.empty() && owner.first->second != name->label)
      throw Infeasible("face tags of '" + name->label + "' and '" + owner.first->second +
                       "' collide");
    TopLoc_Location loc;
    const Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(f, loc);
    if (tri.IsNull() || tri->NbTriangles() == 0)
      throw Infeasible("tessellation left face '" + name->label + "' empty");
    const gp_Trsf trsf = loc.Transformation();
    std::vector<std::uint32_t> node(static_cast<std::size_t>(tri->NbNodes()) + 1);
    for (int i = 1; i <= tri->NbNodes(); ++i)
      node[static_cast<std::size_t>(i)] = weld.add(tri->Node(i).Transformed(trsf));
    const bool reversed = f.Orientation() == TopAbs_REVERSED;
    tags.push_back(tag);
    for (int i = 1; i <= tri->NbTriangles(); ++i) {
      int n1, n2, n3;
      tri->Triangle(i).Get(n1, n2, n3);
      if (reversed) std::swap(n2, n3);
      const std::uint32_t a = node[static_cast<std::size_t>(n1)],
                          b = node[static_cast<std::size_t>(n2)],
                          c = node[static_cast<std::size_t>(n3)];
      if (a == b || b == c || a == c) continue;  // collapsed by the weld (a degenerate sliver)
      tris.insert(tris.end(), {a, b, c});
      tri_face.push_back(static_cast<int>(tags.size()) - 1);
    }
  }
  // A closed, consistently oriented surface has every directed edge exactly once.
  {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
    for (std::size_t t = 0; t < tris.size(); t += 3)
      for (int k = 0; k < 3; ++k)
        ++directed[{tris[t + static_cast<std::size_t>(k)],
                    tris[t + static_cast<std::size_t>((k + 1) % 3)]}];
    for (const auto& e : directed)
      if (e.second != 1 || !directed.count({e.first.second, e.first.first}))
        throw Infeasible("the tessellation is not a closed oriented surface");
  }
  times.tessellate = since(t0);

  // TetGen can fail on a surface (segment recovery with -Y, slivers without it); a slightly
  // smaller element size gives it another surface to work with. The sequence is fixed, so the
  // result stays a deterministic function of x.
  std::string why;
  for (double scale : {1.0, 0.9, 0.8}) {
    t0 = Clock::now();
    std::vector<double> pts = weld.points();
    std::vector<std::uint32_t> t = tris;
    std::vector<int> tf = tri_face;
    if (settings.keep_surface) refine_surface(pts, t, tf, scale * settings.mesh_size);
    times.tessellate += since(t0);
    t0 = Clock::now();
    TetMeshData m;
    const bool ok = tetrahedralize_surface(pts, t, tf, tags, settings, scale * settings.mesh_size,
                                           diag, m, why);
    times.tetgen += since(t0);
    if (ok) return m;
  }
  throw Infeasible(why);
}

double mesh_volume(const TetMeshData& m) {
  double vol = 0;
  for (std::size_t t = 0; t < m.tets.size(); t += 4)
    vol += orient(m.vertices.data(), m.tets[t], m.tets[t + 1], m.tets[t + 2], m.tets[t + 3]) / 6;
  return vol;
}

}  // namespace cadinterp::occt
