// TetGen on the closed tagged surface (occt_mesh_steps.h), in a child process where it may abort.
#define TETLIBRARY
#include <tetgen.h>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "occt_mesh_steps.h"

namespace cadinterp::occt {
namespace {

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

}  // namespace

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

}  // namespace cadinterp::occt
