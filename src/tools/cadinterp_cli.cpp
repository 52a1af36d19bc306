// cadinterp: the command-line tool.
//
//   cadinterp build    --host PATH|NAME -o OUT.cadi [options]   precompute an asset
//   cadinterp inspect  ASSET [--json]                             what an asset holds
//   cadinterp eval     ASSET X1 X2 ... [options]                  shape, metrics, exports at x
//   cadinterp bench    ASSET [--iterations N]                     open/eval/grad/vjp timings
//   cadinterp explore  ASSET [--port N] [--bind ADDR]             the web explorer for ASSET
//
// Exit codes: 0 success, 1 a runtime or build error (the message names the cadinterp_status),
// 2 a malformed command line. Evaluation goes through the public C ABI only, so the tool behaves
// as an application would; `inspect` (sizes, codecs, tree statistics) and `bench` (element boxes,
// to evaluate each element once cold) read the index with the format library, because those are
// not, and should not be, part of the ABI.
#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp_generated.h"
#include "cli_args.h"
#include "format/asset_reader.h"
#include "json_writer.h"
#include "mesh_export.h"

#ifdef CADINTERP_CLI_HAVE_BUILDER
#include "cadinterp/cadinterp_builder.h"
#endif
#ifdef CADINTERP_CLI_HAVE_ANALYTIC
#include "analytic_host.h"
#endif
#ifdef CADINTERP_CLI_HAVE_EXPLORE
#include <fstream>

#include "explore_server.h"
#endif

namespace {

using namespace cadinterp::cli;
namespace fb = cadinterp::fb;
namespace format = cadinterp::format;

constexpr int kExitOk = 0, kExitError = 1, kExitUsage = 2;

/// A failure reported with exit code 1; what() is the whole message.
struct RuntimeFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

const char* status_enum_name(int s) {
  switch (s) {
    case CADINTERP_OK:
      return "CADINTERP_OK";
    case CADINTERP_E_INVALID_ARGUMENT:
      return "CADINTERP_E_INVALID_ARGUMENT";
    case CADINTERP_E_OUT_OF_MEMORY:
      return "CADINTERP_E_OUT_OF_MEMORY";
    case CADINTERP_E_IO:
      return "CADINTERP_E_IO";
    case CADINTERP_E_BAD_MAGIC:
      return "CADINTERP_E_BAD_MAGIC";
    case CADINTERP_E_UNSUPPORTED_VERSION:
      return "CADINTERP_E_UNSUPPORTED_VERSION";
    case CADINTERP_E_TRUNCATED:
      return "CADINTERP_E_TRUNCATED";
    case CADINTERP_E_CORRUPT_INDEX:
      return "CADINTERP_E_CORRUPT_INDEX";
    case CADINTERP_E_CHECKSUM:
      return "CADINTERP_E_CHECKSUM";
    case CADINTERP_E_OUT_OF_RANGE:
      return "CADINTERP_E_OUT_OF_RANGE";
    case CADINTERP_E_LIMIT:
      return "CADINTERP_E_LIMIT";
    case CADINTERP_E_CORRUPT_BLOB:
      return "CADINTERP_E_CORRUPT_BLOB";
    case CADINTERP_E_OUTSIDE_DOMAIN:
      return "CADINTERP_E_OUTSIDE_DOMAIN";
    case CADINTERP_E_INFEASIBLE:
      return "CADINTERP_E_INFEASIBLE";
    case CADINTERP_E_INTERNAL:
      return "CADINTERP_E_INTERNAL";
    case CADINTERP_E_NOT_FOUND:
      return "CADINTERP_E_NOT_FOUND";
    case CADINTERP_E_CANCELLED:
      return "CADINTERP_E_CANCELLED";
    case CADINTERP_E_STORE_MISMATCH:
      return "CADINTERP_E_STORE_MISMATCH";
    default:
      return "unknown status";
  }
}

/// "CADINTERP_E_X (fixed text): detail" — the enum name is what users search for in the header.
std::string describe(int status, const std::string& detail) {
  std::string s = status_enum_name(status);
  std::string text = cadinterp_status_string(static_cast<cadinterp_status>(status));
  // A runtime older than the builder's statuses has no text for them.
  if (text == "unknown status") {
    if (status == CADINTERP_E_CANCELLED) text = "cancelled";
    if (status == CADINTERP_E_STORE_MISMATCH) text = "sample store of another model or box";
  }
  s += " (" + text + ")";
  if (!detail.empty()) s += ": " + detail;
  return s;
}

std::string fmt(const char* f, ...) __attribute__((format(printf, 1, 2)));
std::string fmt(const char* f, ...) {
  va_list a, b;
  va_start(a, f);
  va_copy(b, a);
  const int n = std::vsnprintf(nullptr, 0, f, a);
  va_end(a);
  std::string s(static_cast<std::size_t>(std::max(n, 0)) + 1, '\0');
  std::vsnprintf(s.data(), s.size(), f, b);
  va_end(b);
  s.pop_back();
  return s;
}

std::string human_bytes(std::uint64_t b) {
  if (b < 1024) return fmt("%llu B", static_cast<unsigned long long>(b));
  const char* units[] = {"KiB", "MiB", "GiB", "TiB"};
  double v = static_cast<double>(b) / 1024;
  int u = 0;
  while (v >= 1024 && u < 3) {
    v /= 1024;
    ++u;
  }
  return fmt("%.1f %s", v, units[u]);
}

std::string human_seconds(double s) {
  if (s < 0) return "?";
  if (s == 0) return "0 s";
  if (s < 1e-3) return fmt("%.1f us", s * 1e6);
  if (s < 1) return fmt("%.1f ms", s * 1e3);
  if (s < 120) return fmt("%.1f s", s);
  if (s < 7200) return fmt("%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  return fmt("%dh%02dm", static_cast<int>(s) / 3600, static_cast<int>(s) % 3600 / 60);
}

// ---- C ABI handles ---------------------------------------------------------------------------

struct AssetCloser {
  void operator()(cadinterp_asset* a) const { cadinterp_close(a); }
};
struct WorkspaceDestroyer {
  void operator()(cadinterp_workspace* w) const { cadinterp_workspace_destroy(w); }
};
using AssetPtr = std::unique_ptr<cadinterp_asset, AssetCloser>;
using WorkspacePtr = std::unique_ptr<cadinterp_workspace, WorkspaceDestroyer>;

AssetPtr open_asset(const std::string& path) {
  cadinterp_asset* a = nullptr;
  const cadinterp_status s = cadinterp_open(path.c_str(), &a);
  if (s != CADINTERP_OK)
    throw RuntimeFailure("cannot open " + path + ": " + describe(s, cadinterp_open_error()));
  return AssetPtr(a);
}

WorkspacePtr make_workspace(const cadinterp_asset* a) {
  cadinterp_workspace* w = nullptr;
  const cadinterp_status s = cadinterp_workspace_create(a, &w);
  if (s != CADINTERP_OK) throw RuntimeFailure("cannot create a workspace: " + describe(s, ""));
  return WorkspacePtr(w);
}

void check_ws(cadinterp_status s, const cadinterp_workspace* ws, const std::string& what) {
  if (s != CADINTERP_OK)
    throw RuntimeFailure(what + ": " + describe(s, cadinterp_workspace_error(ws)));
}

struct Param {
  std::string name, unit;
  double lower = 0, upper = 0;
};

std::vector<Param> parameters(const cadinterp_asset* a) {
  std::vector<Param> out;
  for (int i = 0; i < cadinterp_dim(a); ++i) {
    cadinterp_parameter_info p{};
    if (cadinterp_parameter(a, i, &p) != CADINTERP_OK) throw RuntimeFailure("parameter query");
    out.push_back({p.name ? p.name : "", p.unit ? p.unit : "", p.lower, p.upper});
  }
  return out;
}

/// Field indices for --fields (a comma list of names, "all", or "" for none).
std::vector<int> select_fields(const cadinterp_asset* a, const std::string& spec) {
  std::vector<int> idx;
  const int n = cadinterp_field_count(a);
  if (spec == "all") {
    for (int i = 0; i < n; ++i) idx.push_back(i);
    return idx;
  }
  for (const std::string& name : split_list(spec)) {
    int i = -1;
    if (cadinterp_find_field(a, name.c_str(), &i) != CADINTERP_OK) {
      std::string known;
      for (int j = 0; j < n; ++j) {
        cadinterp_field_info f{};
        cadinterp_field(a, j, &f);
        known += (known.empty() ? "" : ", ") + std::string(f.name);
      }
      throw UsageError("unknown field '" + name +
                       "' (the asset's fields: " + (known.empty() ? "none" : known) + ")");
    }
    idx.push_back(i);
  }
  return idx;
}

// ---- Top-level help ----------------------------------------------------------------------------

struct Command {
  const char* name;
  const char* summary;
  int (*run)(const std::vector<std::string>& args);
};

int cmd_build(const std::vector<std::string>& args);
int cmd_inspect(const std::vector<std::string>& args);
int cmd_eval(const std::vector<std::string>& args);
int cmd_bench(const std::vector<std::string>& args);
int cmd_explore(const std::vector<std::string>& args);

const Command kCommands[] = {
    {"build", "precompute a parametric model into an asset (.cadi) through a host", cmd_build},
    {"inspect", "show what an asset holds: parameters, tree, sizes, codecs, provenance",
     cmd_inspect},
    {"eval", "evaluate an asset at parameters x: metrics, derivatives, mesh export", cmd_eval},
    {"bench", "time opening and evaluating an asset", cmd_bench},
    {"explore", "serve the interactive web explorer for an asset (sliders, live mesh, fields)",
     cmd_explore},
};

std::string builtin_hosts() {
  std::string s;
#ifdef CADINTERP_CLI_HAVE_ANALYTIC
  s += "analytic";
#endif
  return s;
}

std::string top_help() {
  std::string s =
      "usage: cadinterp COMMAND [ARGS...]\n"
      "       cadinterp COMMAND --help\n\n"
      "Precompute parametric CAD models into interpolating assets and evaluate them.\n\n"
      "commands:\n";
  for (const Command& c : kCommands) s += fmt("  %-10s%s\n", c.name, c.summary);
  s += "\noptions:\n"
       "  --version   print the library, format and builder versions\n"
       "  -h, --help  show this help\n\n"
       "Exit status: 0 success, 1 runtime or build error, 2 usage error.\n";
  return s;
}

void print_version() {
  int major = 0, minor = 0;
  cadinterp_format_version(&major, &minor);
  std::printf("cadinterp %s (asset format %d.%d)\n", cadinterp_version(), major, minor);
#ifdef CADINTERP_CLI_HAVE_BUILDER
  std::printf("builder: yes\n");
#else
  std::printf("builder: no (built without libcadinterp_builder)\n");
#endif
  const std::string hosts = builtin_hosts();
  std::printf("built-in hosts: %s\n", hosts.empty() ? "none" : hosts.c_str());
}

// ---- inspect -----------------------------------------------------------------------------------

const char* codec_name(fb::Codec c) {
  switch (c) {
    case fb::Codec::Raw:
      return "raw";
    case fb::Codec::QuantDeltaZstd:
      return "quant-delta-zstd";
    case fb::Codec::Meshopt:
      return "meshopt";
    case fb::Codec::Draco:
      return "draco";
  }
  return "unknown";
}

struct Stat {
  double min = 0, max = 0, sum = 0;
  std::uint64_t n = 0;
  void add(double v) {
    min = n == 0 ? v : std::min(min, v);
    max = n == 0 ? v : std::max(max, v);
    sum += v;
    ++n;
  }
  double mean() const { return n ? sum / static_cast<double>(n) : 0; }
};

void write_stat(JsonWriter& w, const char* key, const Stat& s) {
  w.key(key).begin_object();
  if (s.n == 0) {
    w.field("min", nullptr).field("mean", nullptr).field("max", nullptr);
  } else {
    w.field("min", s.min).field("mean", s.mean()).field("max", s.max);
  }
  w.field("total", s.sum).end_object();
}

std::string stat_text(const Stat& s, int decimals = 1) {
  if (s.n == 0) return "-";
  return fmt("min %.*f, mean %.*f, max %.*f", 0, s.min, decimals, s.mean(), 0, s.max);
}

struct BlobKey {
  std::string kind;
  std::string codec;
  bool operator<(const BlobKey& o) const {
    return kind != o.kind ? kind < o.kind : codec < o.codec;
  }
};
struct BlobTotal {
  std::uint64_t count = 0;       // distinct blobs
  std::uint64_t references = 0;  // element references to them (topology blobs may be shared)
  std::uint64_t bytes = 0, raw_bytes = 0;
};

int cmd_inspect(const std::vector<std::string>& args) {
  std::string path;
  bool json = false;
  ArgParser p("cadinterp inspect", "ASSET [--json]",
              "Shows what an asset holds: parameters, basis degree, K-d tree statistics, the\n"
              "points the builder recorded as infeasible and why, element mesh sizes, stored\n"
              "bytes by kind and codec, fields, boundary-condition regions and the build's\n"
              "provenance. The whole index is verified first.");
  p.flag("json", 0, "print JSON instead of text", &json);
  p.positional("ASSET", "the asset file (.cadi)", &path);
  if (!p.parse(args)) return kExitOk;

  std::unique_ptr<format::AssetReader> reader;
  try {
    reader = format::AssetReader::open_file(path);
  } catch (const format::FormatError& e) {
    throw RuntimeFailure("cannot open " + path + ": " +
                         describe(static_cast<int>(e.status), e.what()));
  }
  const fb::Asset& idx = reader->index();
  const cadinterp::core::CompiledBasis& basis = reader->basis();
  const auto& parts = basis.parts();
  const int K = basis.dim();
  const int E = basis.element_count();
  const int degree = static_cast<int>(basis.degree());

  // Depth per direction: splits are at midpoints, so an element's unit width is 2^-depth.
  std::vector<Stat> depth(static_cast<std::size_t>(K));
  Stat terms, verts, tets, tris, err;
  std::vector<int> infeasible;
  std::uint64_t stored_meshes = 0;
  std::map<BlobKey, BlobTotal> blobs;
  std::uint64_t blob_bytes = 0;
  std::set<std::pair<std::uint64_t, std::uint64_t>> seen_blobs;  // (offset, size)
  const std::size_t fields_per_vertex = reader->field_values_per_vertex();
  const std::size_t fields_per_tet = reader->field_values_per_tet();
  for (int e = 0; e < E; ++e) {
    const auto ue = static_cast<std::size_t>(e);
    for (int d = 0; d < K; ++d) {
      const auto ud = static_cast<std::size_t>(d);
      const double w = parts.elem_box[ue * 2 * K + K + ud] - parts.elem_box[ue * 2 * K + ud];
      depth[ud].add(std::round(-std::log2(w)));
    }
    terms.add(static_cast<double>(parts.elem_term_begin[ue + 1] - parts.elem_term_begin[ue]));
    const fb::ElementMeshes* em = idx.elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
    if (!basis.element_feasible(e) || em->vertex_count() == 0) {
      infeasible.push_back(e);
      continue;
    }
    const std::uint64_t V = em->vertex_count(), T = em->tet_count(), F = em->triangle_count();
    verts.add(static_cast<double>(V));
    tets.add(static_cast<double>(T));
    tris.add(static_cast<double>(F));
    if (em->error_estimate() >= 0) err.add(em->error_estimate());
    auto add = [&](const char* kind, const fb::BlobRef* b, std::uint64_t raw) {
      if (!b) return;
      BlobTotal& t = blobs[{kind, codec_name(b->codec())}];
      ++t.references;
      // Elements may reference the same stored blob; its bytes exist once in the file.
      if (!seen_blobs.insert({b->offset(), b->size()}).second) return;
      ++t.count;
      t.bytes += b->size();
      t.raw_bytes += raw;
      blob_bytes += b->size();
    };
    add("tets", em->tets(), 16 * T);
    add("triangles", em->triangles(), 12 * F);
    add("triangle tags", em->triangle_tags(), 4 * F);
    add("canonical positions", em->canonical_positions(), 12 * V);
    if (em->positions()) {
      for (const fb::BlobRef* b : *em->positions()) add("positions", b, 12 * V);
      stored_meshes += em->positions()->size();
    }
    if (em->fields())
      for (const fb::BlobRef* b : *em->fields())
        add("fields", b, 4 * (fields_per_vertex * V + fields_per_tet * T));
  }

  struct FieldRow {
    std::string name, location;
    int components;
    double max_abs_error;
    std::string unit;  // "" when the asset gives none (format 1.0)
  };
  std::vector<FieldRow> fields;
  if (idx.fields())
    for (const fb::FieldDesc* f : *idx.fields())
      fields.push_back({f->name()->str(),
                        f->location() == fb::FieldLocation::Tet ? "tet" : "vertex", f->components(),
                        f->max_abs_error(), f->unit() ? f->unit()->str() : std::string()});
  struct RegionRow {
    std::string name, kind;
    std::vector<int> tags;
  };
  std::vector<RegionRow> regions;
  if (idx.regions())
    for (const fb::BoundaryRegion* r : *idx.regions()) {
      RegionRow row{r->name()->str(), r->kind() ? r->kind()->str() : "", {}};
      if (r->face_tags()) row.tags.assign(r->face_tags()->begin(), r->face_tags()->end());
      regions.push_back(std::move(row));
    }
  const fb::Provenance* prov = idx.provenance();
  auto prov_str = [&](const flatbuffers::String* s) { return s ? s->str() : std::string(); };
  const std::string builder_version = prov ? prov_str(prov->builder_version()) : "";
  const std::string host = prov ? prov_str(prov->host()) : "";
  const std::string options = prov ? prov_str(prov->options()) : "";
  const std::uint64_t file_size = reader->file_size();
  // The blobs tile the section after the index, so the index size follows from their sum.
  const std::uint64_t index_bytes = file_size - format::kHeaderSize - blob_bytes;
  const int bsplines = static_cast<int>(parts.bs_col_begin.size()) - 1;
  const int nodes = static_cast<int>(parts.node_dir.size());
  const std::string format_version = fmt("%d.%d", format::kFormatMajor, reader->format_minor());

  if (json) {
    std::string out;
    JsonWriter w(out);
    w.begin_object();
    w.field("asset", path).field("file_bytes", file_size).field("format", format_version);
    w.field("header_bytes", static_cast<std::uint64_t>(format::kHeaderSize));
    w.field("index_bytes", index_bytes).field("blob_bytes", blob_bytes);
    w.key("parameters").begin_array();
    for (int i = 0; i < K; ++i) {
      const fb::Parameter* q = idx.parameters()->Get(static_cast<flatbuffers::uoffset_t>(i));
      w.begin_object().field("name", q->name()->str());
      w.field("unit", q->unit() ? q->unit()->str() : "");
      w.field("lower", q->lower()).field("upper", q->upper()).end_object();
    }
    w.end_array();
    w.field("degree", degree);
    w.key("tree").begin_object();
    w.field("elements", E).field("infeasible_elements", static_cast<int>(infeasible.size()));
    w.field("nodes", nodes).field("samples", basis.sample_count()).field("bsplines", bsplines);
    w.field("stored_meshes", stored_meshes);
    w.key("depth").begin_array();
    for (int d = 0; d < K; ++d) {
      const Stat& s = depth[static_cast<std::size_t>(d)];
      w.begin_object().field(
          "parameter",
          idx.parameters()->Get(static_cast<flatbuffers::uoffset_t>(d))->name()->str());
      w.field("min", static_cast<int>(s.min)).field("max", static_cast<int>(s.max)).end_object();
    }
    w.end_array();
    write_stat(w, "terms_per_element", terms);
    w.key("infeasible").begin_array();
    for (const int e : infeasible) w.value(e);
    w.end_array();
    w.end_object();
    w.key("infeasible_points").begin_array();
    if (const auto* inf = idx.infeasible())
      for (const auto* f : *inf) {
        w.begin_object().key("x").begin_array();
        if (f->x())
          for (const double v : *f->x()) w.value(v);
        w.end_array().field("message", f->message() ? f->message()->str() : "").end_object();
      }
    w.end_array();
    w.key("element_sizes").begin_object();
    write_stat(w, "vertices", verts);
    write_stat(w, "tets", tets);
    write_stat(w, "triangles", tris);
    w.end_object();
    w.key("error_estimate").begin_object().field("measured", err.n);
    if (err.n) w.field("min", err.min).field("mean", err.mean()).field("max", err.max);
    w.end_object();
    w.field("position_max_abs_error", static_cast<double>(idx.position_max_abs_error()));
    w.key("blobs").begin_array();
    for (const auto& [k, t] : blobs) {
      w.begin_object().field("kind", k.kind).field("codec", k.codec).field("count", t.count);
      w.field("references", t.references)
          .field("bytes", t.bytes)
          .field("raw_bytes", t.raw_bytes)
          .end_object();
    }
    w.end_array();
    w.key("fields").begin_array();
    for (const FieldRow& f : fields) {
      w.begin_object().field("name", f.name).field("location", f.location);
      w.field("components", f.components).field("max_abs_error", f.max_abs_error);
      w.field("unit", f.unit).end_object();
    }
    w.end_array();
    w.key("regions").begin_array();
    for (const RegionRow& r : regions) {
      w.begin_object().field("name", r.name).field("kind", r.kind).key("face_tags").begin_array();
      for (const int t : r.tags) w.value(t);
      w.end_array().end_object();
    }
    w.end_array();
    w.key("provenance").begin_object();
    w.field("builder_version", builder_version).field("host", host);
    // Kept as text: the index does not promise the options are valid JSON.
    w.field("options", options).end_object();
    w.end_object();
    std::fputs(out.c_str(), stdout);
    return kExitOk;
  }

  std::printf("asset        %s\n", path.c_str());
  std::printf("file         %s (%llu bytes), format %s; index %s, blobs %s\n",
              human_bytes(file_size).c_str(), static_cast<unsigned long long>(file_size),
              format_version.c_str(), human_bytes(index_bytes).c_str(),
              human_bytes(blob_bytes).c_str());
  std::printf("\nparameters   %d\n", K);
  std::printf("  %-3s %-20s %-10s %14s %14s\n", "#", "name", "unit", "lower", "upper");
  for (int i = 0; i < K; ++i) {
    const fb::Parameter* q = idx.parameters()->Get(static_cast<flatbuffers::uoffset_t>(i));
    std::printf("  %-3d %-20s %-10s %14.6g %14.6g\n", i, q->name()->c_str(),
                q->unit() && q->unit()->size() ? q->unit()->c_str() : "-", q->lower(), q->upper());
  }
  std::printf("\nbasis        degree %d (%s)\n", degree,
              degree == 3 ? "cubic B-splines, C2" : "linear B-splines, C0");
  std::printf("tree         %d elements (%zu infeasible), %d nodes, %d samples, %d B-splines\n", E,
              infeasible.size(), nodes, basis.sample_count(), bsplines);
  std::printf("  depth      ");
  for (int d = 0; d < K; ++d) {
    const Stat& s = depth[static_cast<std::size_t>(d)];
    std::printf("%s%s %d..%d", d ? ", " : "",
                idx.parameters()->Get(static_cast<flatbuffers::uoffset_t>(d))->name()->c_str(),
                static_cast<int>(s.min), static_cast<int>(s.max));
  }
  std::printf("\n  terms      per element: %s\n", stat_text(terms).c_str());
  std::printf("  stored     %llu meshes (position arrays)\n",
              static_cast<unsigned long long>(stored_meshes));
  if (!infeasible.empty()) {
    std::printf("  infeasible elements:");
    for (std::size_t i = 0; i < infeasible.size() && i < 20; ++i) std::printf(" %d", infeasible[i]);
    if (infeasible.size() > 20) std::printf(" ... (%zu more)", infeasible.size() - 20);
    std::printf("\n");
  }
  // The builder's record of why: host failures at their points, and elements refused because a
  // term could not be mapped (at the element's centre, the term's sample named in the message).
  if (const auto* inf = idx.infeasible(); inf && inf->size() > 0) {
    std::printf("  infeasible points recorded: %u\n", inf->size());
    for (flatbuffers::uoffset_t i = 0; i < inf->size() && i < 20; ++i) {
      const auto* f = inf->Get(i);
      std::printf("    (");
      if (f->x())
        for (flatbuffers::uoffset_t d = 0; d < f->x()->size(); ++d)
          std::printf("%s%g", d ? ", " : "", f->x()->Get(d));
      std::printf(") %s\n", f->message() ? f->message()->c_str() : "");
    }
    if (inf->size() > 20) std::printf("    ... (%u more)\n", inf->size() - 20);
  }
  std::printf("\nelements     (feasible ones)\n");
  std::printf("  vertices   %s (total %.0f)\n", stat_text(verts).c_str(), verts.sum);
  std::printf("  tets       %s (total %.0f)\n", stat_text(tets).c_str(), tets.sum);
  std::printf("  triangles  %s (total %.0f)\n", stat_text(tris).c_str(), tris.sum);
  if (err.n)
    std::printf("  error est. min %.3g, mean %.3g, max %.3g (bbox diagonals; %llu measured)\n",
                err.min, err.mean(), err.max, static_cast<unsigned long long>(err.n));
  else
    std::printf("  error est. not measured\n");
  const float pos_err = idx.position_max_abs_error();
  std::printf("  positions  %s\n",
              pos_err > 0 ? fmt("lossy, max abs error %g", static_cast<double>(pos_err)).c_str()
                          : "lossless");

  std::printf("\nblobs        %-20s %-17s %8s %8s %12s %12s %7s\n", "kind", "codec", "count",
              "refs", "bytes", "raw bytes", "ratio");
  for (const auto& [k, t] : blobs)
    std::printf(
        "             %-20s %-17s %8llu %8llu %12llu %12llu %7.3f\n", k.kind.c_str(),
        k.codec.c_str(), static_cast<unsigned long long>(t.count),
        static_cast<unsigned long long>(t.references), static_cast<unsigned long long>(t.bytes),
        static_cast<unsigned long long>(t.raw_bytes),
        t.raw_bytes ? static_cast<double>(t.bytes) / static_cast<double>(t.raw_bytes) : 0.0);

  std::printf("\nfields       %zu\n", fields.size());
  for (const FieldRow& f : fields)
    std::printf(
        "  %-20s %-8s per %-6s %2d component%s, %s\n", f.name.c_str(),
        f.unit.empty() ? "-" : ("[" + f.unit + "]").c_str(), f.location.c_str(), f.components,
        f.components == 1 ? "" : "s",
        f.max_abs_error > 0 ? fmt("max abs error %g", f.max_abs_error).c_str() : "lossless");
  std::printf("regions      %zu\n", regions.size());
  for (const RegionRow& r : regions) {
    std::printf("  %-20s %-8s tags", r.name.c_str(), r.kind.empty() ? "-" : r.kind.c_str());
    for (const int t : r.tags) std::printf(" %d", t);
    std::printf("\n");
  }
  std::printf("\nprovenance\n");
  std::printf("  builder    %s\n", builder_version.empty() ? "-" : builder_version.c_str());
  std::printf("  host       %s\n", host.empty() ? "-" : host.c_str());
  std::printf("  options    %s\n", options.empty() ? "-" : options.c_str());
  return kExitOk;
}

// ---- eval --------------------------------------------------------------------------------------

/// Parses the K parameter values; wrong arity and non-numbers are usage errors.
std::vector<double> parse_point(const std::vector<std::string>& tokens,
                                const std::vector<Param>& params) {
  const std::size_t K = params.size();
  std::string names;
  for (const Param& q : params) names += (names.empty() ? "" : ", ") + q.name;
  if (tokens.size() != K)
    throw UsageError(fmt("the asset has %zu parameter%s (%s); got %zu value%s", K,
                         K == 1 ? "" : "s", names.c_str(), tokens.size(),
                         tokens.size() == 1 ? "" : "s"));
  std::vector<double> x(K);
  for (std::size_t i = 0; i < K; ++i)
    if (!parse_double(tokens[i], &x[i]))
      throw UsageError("parameter " + std::to_string(i + 1) + " (" + params[i].name +
                       ") must be a finite number, got '" + tokens[i] + "'");
  return x;
}

/// Outside-domain and infeasible points fail here with the runtime's status and which
/// parameter is out of range, before any mesh work.
int locate_or_fail(const cadinterp_asset* a, const std::vector<double>& x,
                   const std::vector<Param>& params) {
  int element = -1, feasible = 0;
  const cadinterp_status s = cadinterp_locate(a, x.data(), &element, &feasible);
  if (s == CADINTERP_E_OUTSIDE_DOMAIN) {
    std::string why;
    for (std::size_t i = 0; i < params.size(); ++i)
      if (!(x[i] >= params[i].lower && x[i] <= params[i].upper))
        why += fmt("%s%s = %g is outside [%g, %g]", why.empty() ? "" : "; ", params[i].name.c_str(),
                   x[i], params[i].lower, params[i].upper);
    throw RuntimeFailure(describe(s, why));
  }
  if (s != CADINTERP_OK) throw RuntimeFailure("locate: " + describe(s, ""));
  if (!feasible)
    throw RuntimeFailure(describe(
        CADINTERP_E_INFEASIBLE,
        fmt("x lies in element %d, which depends on a sample the host could not build", element)));
  return element;
}

// The properties as named rows, for the tables and JSON alike.
std::vector<std::pair<std::string, double>> property_values(const cadinterp_properties& p) {
  std::vector<std::pair<std::string, double>> v = {
      {"volume", p.volume},
      {"mass", p.mass},
      {"area", p.area},
      {"frontal_area", p.frontal_area},
      {"centroid_x", p.centroid[0]},
      {"centroid_y", p.centroid[1]},
      {"centroid_z", p.centroid[2]},
  };
  const char* axes = "xyz";
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      v.push_back({std::string("inertia_") + axes[r] + axes[c], p.inertia[3 * r + c]});
  return v;
}

int cmd_eval(const std::vector<std::string>& args) {
  std::string path, fields_spec = "all", direction_spec = "1,0,0", vtu, obj, gltf;
  std::vector<std::string> xs;
  bool grad = false, json = false, vtu_ascii = false;
  double density = 1.0;
  ArgParser p(
      "cadinterp eval", "ASSET X1 X2 ... [options]",
      "Evaluates the asset at the parameter vector x (one value per parameter, in the order\n"
      "'cadinterp inspect' lists them): element, error estimate, mesh counts, field ranges and\n"
      "mass properties; with --grad their derivatives. Optionally writes the mesh.");
  p.positional("ASSET", "the asset file (.cadi)", &path);
  p.rest("X1 X2 ...", "parameter values (negative values are fine: -0.5)", &xs, 0);
  p.option("fields", 0, "A,B", "fields to evaluate and export ('all', or '' for none)",
           &fields_spec);
  p.flag("grad", 0, "also print derivatives of the properties with respect to x", &grad);
  p.option("density", 0, "RHO", "uniform density for mass and inertia", &density, 0, 1e300);
  p.option("direction", 0, "X,Y,Z", "direction of the frontal (projected) area", &direction_spec);
  p.option("vtu", 0, "FILE", "write the tet mesh and fields as VTK XML (.vtu)", &vtu);
  p.flag("ascii", 0, "write the .vtu as ASCII instead of base64 binary", &vtu_ascii);
  p.option("obj", 0, "FILE", "write the boundary triangles as Wavefront OBJ", &obj);
  p.option("gltf", 0, "FILE", "write the boundary triangles as glTF 2.0 (.gltf or .glb)", &gltf);
  p.flag("json", 0, "print JSON instead of text", &json);
  p.epilog(
      "examples:\n"
      "  cadinterp eval part.cadi 0.5 12 --grad\n"
      "  cadinterp eval part.cadi 0.5 12 --fields temperature --vtu x.vtu --gltf x.glb");
  if (!p.parse(args)) return kExitOk;
  if (p.seen("ascii") && vtu.empty()) throw UsageError("--ascii applies to --vtu only");

  double dir[3];
  {
    const std::vector<std::string> d = split_list(direction_spec);
    if (d.size() != 3 || !parse_double(d[0], &dir[0]) || !parse_double(d[1], &dir[1]) ||
        !parse_double(d[2], &dir[2]))
      throw UsageError("--direction expects three numbers X,Y,Z, got '" + direction_spec + "'");
    const double n = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    if (!(n > 0)) throw UsageError("--direction must not be the zero vector");
    for (double& c : dir) c /= n;
  }

  AssetPtr asset = open_asset(path);
  const std::vector<Param> params = parameters(asset.get());
  const std::vector<double> x = parse_point(xs, params);
  const std::vector<int> field_idx = select_fields(asset.get(), fields_spec);
  const int element = locate_or_fail(asset.get(), x, params);
  double error_estimate = -1;
  cadinterp_error_estimate(asset.get(), x.data(), &error_estimate);

  WorkspacePtr ws = make_workspace(asset.get());
  cadinterp_mesh mesh{};
  check_ws(cadinterp_eval(ws.get(), x.data(), field_idx.data(), static_cast<int>(field_idx.size()),
                          &mesh),
           ws.get(), "eval");

  // Everything that reads the mesh happens before the next call with this workspace.
  ExportMesh em =
      export_mesh_of(asset.get(), mesh, field_idx.data(), static_cast<int>(field_idx.size()));
  em.generator = std::string("cadinterp ") + cadinterp_version();
  struct FieldSummary {
    std::string name;
    bool per_tet;
    int components;
    double min, max;
  };
  std::vector<FieldSummary> field_summaries;
  for (std::size_t i = 0; i < field_idx.size(); ++i) {
    const ExportMesh::Field& f = em.fields[i];
    const std::size_t n = static_cast<std::size_t>(f.per_tet ? mesh.tet_count : mesh.vertex_count) *
                          static_cast<std::size_t>(f.components);
    FieldSummary fs{f.name, f.per_tet, f.components, 0, 0};
    if (n > 0) {
      const auto mm = std::minmax_element(mesh.fields[i], mesh.fields[i] + n);
      fs.min = *mm.first;
      fs.max = *mm.second;
    }
    field_summaries.push_back(fs);
  }
  struct Written {
    std::string format, path;
    ExportSummary summary;
  };
  std::vector<Written> written;
  auto do_export = [&](const std::string& fmt_name, const std::string& out, auto writer) {
    if (out.empty()) return;
    try {
      written.push_back({fmt_name, out, writer(out)});
    } catch (const std::exception& e) {
      throw RuntimeFailure(
          describe(CADINTERP_E_IO, fmt_name + " export to " + out + ": " + e.what()));
    }
  };
  do_export("vtu", vtu, [&](const std::string& f) {
    return write_vtu(f, em, vtu_ascii ? VtuEncoding::Ascii : VtuEncoding::Base64);
  });
  do_export("obj", obj, [&](const std::string& f) { return write_obj(f, em); });
  do_export("gltf", gltf, [&](const std::string& f) { return write_gltf(f, em); });
  const std::uint32_t V = mesh.vertex_count, T = mesh.tet_count, F = mesh.triangle_count;

  cadinterp_properties props{};
  std::vector<cadinterp_properties> dprops(grad ? params.size() : 0);
  check_ws(cadinterp_properties_eval(ws.get(), x.data(), density, dir, &props,
                                     grad ? dprops.data() : nullptr),
           ws.get(), "properties");
  // Largest vertex speed |dP_v/dx_d| per parameter: how strongly each parameter moves the shape.
  std::vector<double> max_speed(params.size(), 0.0);
  if (grad) {
    cadinterp_mesh_grad g{};
    check_ws(cadinterp_grad(ws.get(), x.data(), nullptr, 0, &g), ws.get(), "grad");
    for (std::size_t d = 0; d < params.size(); ++d)
      for (std::size_t v = 0; v < g.vertex_count; ++v) {
        const float* dp = g.dpositions + d * 3 * g.vertex_count + 3 * v;
        max_speed[d] = std::max(max_speed[d], std::sqrt(static_cast<double>(dp[0]) * dp[0] +
                                                        static_cast<double>(dp[1]) * dp[1] +
                                                        static_cast<double>(dp[2]) * dp[2]));
      }
  }
  const auto values = property_values(props);

  if (json) {
    std::string out;
    JsonWriter w(out);
    w.begin_object().field("asset", path);
    w.key("x").begin_object();
    for (std::size_t i = 0; i < params.size(); ++i) w.field(params[i].name, x[i]);
    w.end_object();
    w.field("element", element);
    if (error_estimate >= 0) {
      w.field("error_estimate", error_estimate);
    } else {
      w.key("error_estimate").null();
    }
    w.field("vertices", V).field("tets", T).field("triangles", F);
    w.key("fields").begin_array();
    for (const FieldSummary& f : field_summaries) {
      w.begin_object().field("name", f.name).field("location", f.per_tet ? "tet" : "vertex");
      w.field("components", f.components).field("min", f.min).field("max", f.max).end_object();
    }
    w.end_array();
    w.key("properties").begin_object().field("density", density);
    w.key("direction").begin_array().value(dir[0]).value(dir[1]).value(dir[2]).end_array();
    for (const auto& [name, v] : values) w.field(name, v);
    w.end_object();
    if (grad) {
      w.key("gradient").begin_object();
      for (std::size_t d = 0; d < params.size(); ++d) {
        w.key(params[d].name).begin_object();
        for (const auto& [name, v] : property_values(dprops[d])) w.field(name, v);
        w.field("max_vertex_speed", max_speed[d]).end_object();
      }
      w.end_object();
    }
    w.key("exports").begin_array();
    for (const Written& e : written) {
      w.begin_object().field("format", e.format).field("path", e.path);
      w.field("vertices", e.summary.vertices).field("cells", e.summary.cells);
      w.field("bytes", e.summary.bytes).end_object();
    }
    w.end_array().end_object();
    std::fputs(out.c_str(), stdout);
    return kExitOk;
  }

  std::printf("asset        %s\n", path.c_str());
  std::printf("x           ");
  for (std::size_t i = 0; i < params.size(); ++i)
    std::printf("%s %s = %.9g%s%s", i ? "," : "", params[i].name.c_str(), x[i],
                params[i].unit.empty() ? "" : " ", params[i].unit.c_str());
  std::printf("\nelement      %d\n", element);
  if (error_estimate >= 0)
    std::printf("error est.   %.3g (relative to the bounding-box diagonal)\n", error_estimate);
  else
    std::printf("error est.   not measured\n");
  std::printf("mesh         %u vertices, %u tets, %u boundary triangles\n", V, T, F);
  for (const FieldSummary& f : field_summaries)
    std::printf("field        %-16s per %-6s %d comp.  min %.6g  max %.6g\n", f.name.c_str(),
                f.per_tet ? "tet" : "vertex", f.components, f.min, f.max);
  std::printf("\nproperties   (density %g, frontal direction %.3g %.3g %.3g)\n", density, dir[0],
              dir[1], dir[2]);
  std::printf("  volume        %.9g\n", props.volume);
  std::printf("  mass          %.9g\n", props.mass);
  std::printf("  area          %.9g\n", props.area);
  std::printf("  frontal area  %.9g\n", props.frontal_area);
  std::printf("  centroid      %.9g %.9g %.9g\n", props.centroid[0], props.centroid[1],
              props.centroid[2]);
  for (int r = 0; r < 3; ++r)
    std::printf("  %s  %14.6g %14.6g %14.6g\n", r == 0 ? "inertia     " : "            ",
                props.inertia[3 * r], props.inertia[3 * r + 1], props.inertia[3 * r + 2]);
  if (grad) {
    std::printf("\nderivatives   ");
    for (const Param& q : params) std::printf(" %14s", ("d/d " + q.name).c_str());
    std::printf("\n");
    for (std::size_t r = 0; r < values.size(); ++r) {
      std::printf("  %-12s", values[r].first.c_str());
      for (std::size_t d = 0; d < params.size(); ++d)
        std::printf(" %14.6g", property_values(dprops[d])[r].second);
      std::printf("\n");
    }
    std::printf("  %-12s", "max |dP/dx|");
    for (const double s : max_speed) std::printf(" %14.6g", s);
    std::printf("\n");
  }
  for (const Written& e : written)
    std::printf("wrote        %s (%s: %llu vertices, %llu %s, %s)\n", e.path.c_str(),
                e.format.c_str(), static_cast<unsigned long long>(e.summary.vertices),
                static_cast<unsigned long long>(e.summary.cells),
                e.format == "vtu" ? "tets" : "triangles", human_bytes(e.summary.bytes).c_str());
  return kExitOk;
}

// ---- bench -------------------------------------------------------------------------------------

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct Timing {
  std::vector<double> s;
  double quantile(double q) const {
    if (s.empty()) return 0;
    std::vector<double> v = s;
    const std::size_t k =
        std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
  }
  double mean() const {
    return s.empty() ? 0 : std::accumulate(s.begin(), s.end(), 0.0) / static_cast<double>(s.size());
  }
};

int cmd_bench(const std::vector<std::string>& args) {
  std::string path, fields_spec = "all";
  int iterations = 1000, seed = 1;
  ArgParser p("cadinterp bench", "ASSET [--iterations N]",
              "Times opening an asset and evaluating it at random feasible points: open, cold\n"
              "eval (the first eval in each element, which decodes it), warm eval, eval+grad,\n"
              "vector-Jacobian product and mass properties. A quick look, not the project's\n"
              "benchmark suite (see runtime_bench).");
  p.positional("ASSET", "the asset file (.cadi)", &path);
  p.option("iterations", 'n', "N", "calls per measurement", &iterations, 1, 100000000);
  p.option("fields", 0, "A,B", "fields evaluated with the mesh ('all', or '' for none)",
           &fields_spec);
  p.option("seed", 0, "S", "random seed of the points", &seed, 0, 2147483647);
  if (!p.parse(args)) return kExitOk;

  Timing open_t;
  const int opens = std::min(iterations, 20);
  for (int i = 0; i < opens; ++i) {
    const auto t0 = Clock::now();
    AssetPtr a = open_asset(path);
    open_t.s.push_back(seconds_since(t0));
  }

  // Element boxes come from the index (not part of the ABI); the timed calls use the ABI only.
  std::unique_ptr<format::AssetReader> reader;
  try {
    reader = format::AssetReader::open_file(path);
  } catch (const format::FormatError& e) {
    throw RuntimeFailure("cannot open " + path + ": " +
                         describe(static_cast<int>(e.status), e.what()));
  }
  const auto& basis = reader->basis();
  const int K = basis.dim();
  const auto uK = static_cast<std::size_t>(K);

  AssetPtr asset = open_asset(path);
  const std::vector<int> field_idx = select_fields(asset.get(), fields_spec);
  const int nf = static_cast<int>(field_idx.size());
  WorkspacePtr ws = make_workspace(asset.get());
  cadinterp_mesh mesh{};

  Timing cold;
  std::vector<double> lo(uK), hi(uK), x(uK);
  for (int e = 0; e < basis.element_count(); ++e) {
    if (!basis.element_feasible(e)) continue;
    basis.element_box(e, lo.data(), hi.data());
    for (std::size_t d = 0; d < uK; ++d) x[d] = 0.5 * (lo[d] + hi[d]);
    const auto t0 = Clock::now();
    check_ws(cadinterp_eval(ws.get(), x.data(), field_idx.data(), nf, &mesh), ws.get(), "eval");
    cold.s.push_back(seconds_since(t0));
  }
  if (cold.s.empty())
    throw RuntimeFailure(describe(CADINTERP_E_INFEASIBLE, "the asset has no feasible element"));

  std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
  const std::vector<double>& plo = basis.lower();
  const std::vector<double>& phi = basis.upper();
  auto random_point = [&](std::vector<double>& out) {
    for (int attempt = 0; attempt < 10000; ++attempt) {
      for (std::size_t d = 0; d < uK; ++d)
        out[d] = std::uniform_real_distribution<double>(plo[d], phi[d])(rng);
      int el = -1, feasible = 0;
      if (cadinterp_locate(asset.get(), out.data(), &el, &feasible) == CADINTERP_OK && feasible)
        return;
    }
    throw RuntimeFailure("no feasible point found in 10000 random draws");
  };
  const auto n = static_cast<std::size_t>(iterations);
  std::vector<std::vector<double>> points(n, std::vector<double>(uK));
  for (auto& q : points) random_point(q);

  Timing warm, grad_t, vjp_t, prop_t, propg_t;
  for (const auto& q : points) {
    const auto t0 = Clock::now();
    check_ws(cadinterp_eval(ws.get(), q.data(), field_idx.data(), nf, &mesh), ws.get(), "eval");
    warm.s.push_back(seconds_since(t0));
  }
  cadinterp_mesh_grad g{};
  for (const auto& q : points) {
    const auto t0 = Clock::now();
    check_ws(cadinterp_grad(ws.get(), q.data(), field_idx.data(), nf, &g), ws.get(), "grad");
    grad_t.s.push_back(seconds_since(t0));
  }
  std::vector<float> adjoint;
  std::vector<double> dfdx(uK);
  std::normal_distribution<float> normal;
  for (const auto& q : points) {
    check_ws(cadinterp_eval(ws.get(), q.data(), nullptr, 0, &mesh), ws.get(), "eval");
    adjoint.resize(3 * static_cast<std::size_t>(mesh.vertex_count));
    for (float& v : adjoint) v = normal(rng);
    const auto t0 = Clock::now();
    check_ws(cadinterp_vjp(ws.get(), q.data(), adjoint.data(), nullptr, nullptr, 0, dfdx.data()),
             ws.get(), "vjp");
    vjp_t.s.push_back(seconds_since(t0));
  }
  const double dir[3] = {1, 0, 0};
  cadinterp_properties props{};
  std::vector<cadinterp_properties> dprops(uK);
  for (const auto& q : points) {
    auto t0 = Clock::now();
    check_ws(cadinterp_properties_eval(ws.get(), q.data(), 1.0, dir, &props, nullptr), ws.get(),
             "properties");
    prop_t.s.push_back(seconds_since(t0));
    t0 = Clock::now();
    check_ws(cadinterp_properties_eval(ws.get(), q.data(), 1.0, dir, &props, dprops.data()),
             ws.get(), "properties");
    propg_t.s.push_back(seconds_since(t0));
  }

  std::printf(
      "asset %s: K=%d, degree %d, %d elements, %d fields evaluated, %d points (seed %d)\n\n",
      path.c_str(), K, static_cast<int>(basis.degree()), basis.element_count(), nf, iterations,
      seed);
  std::printf("%-24s %8s %12s %12s %12s\n", "operation", "calls", "median", "mean", "p90");
  auto row = [](const char* name, const Timing& t) {
    std::printf("%-24s %8zu %12s %12s %12s\n", name, t.s.size(),
                human_seconds(t.quantile(0.5)).c_str(), human_seconds(t.mean()).c_str(),
                human_seconds(t.quantile(0.9)).c_str());
  };
  row("open", open_t);
  row("eval, cold (1/element)", cold);
  row("eval, warm", warm);
  row("eval+grad", grad_t);
  row("vjp (positions)", vjp_t);
  row("properties", prop_t);
  row("properties+grad", propg_t);
  return kExitOk;
}

// ---- explore -----------------------------------------------------------------------------------

#ifdef CADINTERP_CLI_HAVE_EXPLORE

bool is_regular_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return f.good() && f.peek() != std::ifstream::traits_type::eof();
}

std::vector<std::uint8_t> read_whole_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) throw RuntimeFailure(describe(CADINTERP_E_IO, "cannot open " + path));
  const std::streamoff size = f.tellg();
  if (size < 0) throw RuntimeFailure(describe(CADINTERP_E_IO, "cannot read " + path));
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  f.seekg(0);
  if (!f.read(reinterpret_cast<char*>(bytes.data()), size))
    throw RuntimeFailure(describe(CADINTERP_E_IO, "cannot read " + path));
  return bytes;
}

struct ExploreListening {
  std::string asset;
};

void print_explore_url(const std::string& url, void* user) {
  const auto* l = static_cast<const ExploreListening*>(user);
  // The URL line is what scripts wait for (scripts/test-explorer.sh parses it): flush at once.
  std::printf("serving %s at %s  (Ctrl-C to stop)\n", l->asset.c_str(), url.c_str());
  std::fflush(stdout);
}

int cmd_explore(const std::vector<std::string>& args) {
  std::string path, bind = "127.0.0.1";
  std::string web_root = CADINTERP_EXPLORER_WEB_ROOT, wasm_dir = CADINTERP_EXPLORER_WASM_DIR;
  int port = 8080;
  bool quick = false;
  ArgParser p(
      "cadinterp explore", "ASSET [--port N] [--bind ADDR] [--web-root DIR] [--wasm-dir DIR]",
      "Serves the interactive explorer for ASSET: a web page with one slider per parameter that\n"
      "evaluates the asset in the browser with the WebAssembly runtime (shape, fields, mass\n"
      "properties, boundary conditions, infeasible ranges, error estimate). The asset is first\n"
      "validated with the native runtime: its index, and one evaluation with every field in\n"
      "each feasible element. Runs until Ctrl-C.");
  p.positional("ASSET", "the asset file (.cadi)", &path);
  p.option("port", 'p', "N", "TCP port; 0 picks any free port", &port, 0, 65535);
  p.option("bind", 0, "ADDR", "address to listen on (0.0.0.0: every interface)", &bind);
  p.option("web-root", 0, "DIR", "the built explorer page", &web_root);
  p.option("wasm-dir", 0, "DIR",
           "the WebAssembly runtime (cadinterp.mjs, cadinterp_wasm.mjs,\ncadinterp_wasm.wasm; "
           "scripts/build-wasm.sh writes them)",
           &wasm_dir);
  p.flag("quick", 0, "validate the header and index only, not each element's meshes", &quick);
  p.epilog(
      "examples:\n"
      "  cadinterp explore bracket.cadi                 # then open http://127.0.0.1:8080/\n"
      "  cadinterp explore bracket.cadi --port 0        # any free port (the URL is printed)");
  if (!p.parse(args)) return kExitOk;

  // The bytes served are the bytes validated here: read once, checked from memory.
  const std::vector<std::uint8_t> bytes = read_whole_file(path);
  cadinterp_asset* raw = nullptr;
  const cadinterp_status s = cadinterp_open_memory(bytes.data(), bytes.size(), 0, &raw);
  if (s != CADINTERP_OK)
    throw RuntimeFailure("invalid asset " + path + ": " + describe(s, cadinterp_open_error()));
  AssetPtr asset(raw);
  std::unique_ptr<format::AssetReader> reader;
  try {
    reader = format::AssetReader::open_memory(bytes.data(), bytes.size(), false);
  } catch (const format::FormatError& e) {
    throw RuntimeFailure("invalid asset " + path + ": " +
                         describe(static_cast<int>(e.status), e.what()));
  }
  const cadinterp::core::CompiledBasis& basis = reader->basis();
  const auto uK = static_cast<std::size_t>(basis.dim());
  int feasible = 0, verified = 0;
  const auto t0 = Clock::now();
  {
    // Every element's blobs are decoded (and checksummed) by one evaluation with all fields, so
    // a damaged blob is found here instead of as an error in the browser mid-drag.
    const std::vector<int> all_fields = select_fields(asset.get(), "all");
    WorkspacePtr ws = make_workspace(asset.get());
    std::vector<double> lo(uK), hi(uK), x(uK);
    cadinterp_mesh mesh{};
    for (int e = 0; e < basis.element_count(); ++e) {
      if (!basis.element_feasible(e)) continue;
      ++feasible;
      if (quick) continue;
      basis.element_box(e, lo.data(), hi.data());
      for (std::size_t d = 0; d < uK; ++d) x[d] = 0.5 * (lo[d] + hi[d]);
      const cadinterp_status es = cadinterp_eval(ws.get(), x.data(), all_fields.data(),
                                                 static_cast<int>(all_fields.size()), &mesh);
      if (es != CADINTERP_OK)
        throw RuntimeFailure("invalid asset " + path + ": element " + std::to_string(e) + ": " +
                             describe(es, cadinterp_workspace_error(ws.get())));
      ++verified;
    }
  }
  const double check_seconds = seconds_since(t0);
  if (feasible == 0)
    throw RuntimeFailure(describe(CADINTERP_E_INFEASIBLE,
                                  path + " has no feasible element: there is nothing to explore"));

  if (!is_regular_file(web_root + "/index.html"))
    throw RuntimeFailure(describe(
        CADINTERP_E_IO, "the explorer page is not built: " + web_root +
                            "/index.html is missing (build the target cadinterp_explorer_page "
                            "after `npm ci` in examples/explorer, or pass --web-root)"));
  for (const char* f : {"cadinterp.mjs", "cadinterp_wasm.mjs", "cadinterp_wasm.wasm"})
    if (!is_regular_file(wasm_dir + "/" + f))
      throw RuntimeFailure(
          describe(CADINTERP_E_IO, "the WebAssembly runtime is missing: " + wasm_dir + "/" + f +
                                       " not found (build it with scripts/build-wasm.sh, or pass "
                                       "--wasm-dir)"));

  std::string name = path;
  if (const std::size_t slash = name.find_last_of('/'); slash != std::string::npos)
    name = name.substr(slash + 1);
  std::string summary;
  {
    JsonWriter w(summary);
    w.begin_object().field("name", name).field("bytes", static_cast<std::uint64_t>(bytes.size()));
    w.field("runtime", std::string(cadinterp_version()));
    w.field("parameters", static_cast<int>(uK)).field("elements", basis.element_count());
    w.field("feasible_elements", feasible).field("verified_elements", verified);
    w.field("fields", cadinterp_field_count(asset.get())).end_object();
  }
  std::printf("asset %s: %zu parameters, %d elements (%d feasible), %d fields; %s\n", path.c_str(),
              uK, basis.element_count(), feasible, cadinterp_field_count(asset.get()),
              quick ? "index verified"
                    : fmt("every feasible element evaluated natively in %s",
                          human_seconds(check_seconds).c_str())
                          .c_str());

  ExploreServerOptions o;
  o.bind = bind;
  o.port = port;
  o.web_root = web_root;
  o.wasm_dir = wasm_dir;
  o.asset_name = name;
  o.asset_bytes = &bytes;
  o.asset_summary_json = summary;
  ExploreListening listening{path};
  try {
    run_explore_server(o, print_explore_url, &listening);
  } catch (const std::runtime_error& e) {
    throw RuntimeFailure(describe(CADINTERP_E_IO, e.what()));
  }
  std::printf("stopped\n");
  return kExitOk;
}

#else

int cmd_explore(const std::vector<std::string>& args) {
  ArgParser p("cadinterp explore", "ASSET [--port N] [--bind ADDR] [--web-root DIR]",
              "Serves the interactive web explorer for an asset. This cadinterp was built without\n"
              "it (CADINTERP_WITH_EXPLORER=OFF or cpp-httplib missing).");
  if (std::find(args.begin(), args.end(), "--help") != args.end() ||
      std::find(args.begin(), args.end(), "-h") != args.end()) {
    std::fputs(p.help().c_str(), stdout);
    return kExitOk;
  }
  throw RuntimeFailure("this cadinterp was built without the explorer (CADINTERP_WITH_EXPLORER)");
}

#endif

// ---- build -------------------------------------------------------------------------------------

#ifdef CADINTERP_CLI_HAVE_BUILDER

volatile std::sig_atomic_t g_cancel = 0;

extern "C" void on_sigint(int) { g_cancel = 1; }

struct ProgressState {
  bool tty = false;
  bool quiet = false;
  double last_print = -1e9;
  bool line_open = false;  // a \r-updated line is on the terminal
};

std::string progress_line(const cadinterp_progress& p, bool bar) {
  const int total = p.samples_done + p.samples_queued;
  std::string s;
  if (bar) {
    constexpr int kWidth = 24;
    const int filled = total > 0 ? kWidth * p.samples_done / total : 0;
    s = "[" + std::string(static_cast<std::size_t>(filled), '#') +
        std::string(static_cast<std::size_t>(kWidth - filled), '.') + "] ";
  }
  s += fmt("%d/%d samples, %d elements, %s", p.samples_done, total, p.elements,
           human_seconds(p.seconds).c_str());
  if (p.eta_seconds >= 0) s += ", ETA " + human_seconds(p.eta_seconds);
  if (g_cancel) s += " (cancelling)";
  return s;
}

extern "C" int on_progress(void* user, const cadinterp_progress* p) {
  auto* st = static_cast<ProgressState*>(user);
  if (!st->quiet) {
    // A terminal gets a redrawn bar at most 10 times a second; a log gets a line a second.
    const double interval = st->tty ? 0.1 : 1.0;
    if (p->seconds - st->last_print >= interval) {
      st->last_print = p->seconds;
      if (st->tty) {
        std::fprintf(stderr, "\r%s\x1b[K", progress_line(*p, true).c_str());
        st->line_open = true;
      } else {
        std::fprintf(stderr, "progress: %s\n", progress_line(*p, false).c_str());
      }
      std::fflush(stderr);
    }
  }
  return g_cancel ? 1 : 0;
}

struct LoadedHost {
  void* library = nullptr;
  const cadinterp_host* host = nullptr;
  std::string source;
  LoadedHost() = default;
  LoadedHost(const LoadedHost&) = delete;
  LoadedHost& operator=(const LoadedHost&) = delete;
  ~LoadedHost() {
    if (library) dlclose(library);
  }
};

bool looks_like_path(const std::string& s) {
  return s.find('/') != std::string::npos || s.find(".so") != std::string::npos;
}

void load_host(const std::string& spec, const std::string& model, const std::string& options,
               LoadedHost& out) {
  cadinterp_host_entry_fn entry = nullptr;
  if (looks_like_path(spec)) {
    out.library = dlopen(spec.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!out.library) {
      const char* e = dlerror();
      throw RuntimeFailure(describe(
          CADINTERP_E_IO, "cannot load host library " + spec + ": " + (e ? e : "unknown error")));
    }
    // POSIX: a function pointer obtained from dlsym is usable as such.
    void* sym = dlsym(out.library, CADINTERP_HOST_ENTRY_NAME);
    if (!sym)
      throw RuntimeFailure(
          describe(CADINTERP_E_INVALID_ARGUMENT, spec + " exports no " CADINTERP_HOST_ENTRY_NAME
                                                        " function (see cadinterp_host_entry_fn)"));
    std::memcpy(&entry, &sym, sizeof entry);
    out.source = spec;
  } else {
#ifdef CADINTERP_CLI_HAVE_ANALYTIC
    if (spec == "analytic") {
      entry = &cadinterp_host_entry;
      out.source = "built-in analytic host";
    }
#endif
    if (!entry) {
      const std::string hosts = builtin_hosts();
      throw UsageError("unknown host '" + spec +
                       "': give the path of a host library (.so) or a built-in host (" +
                       (hosts.empty() ? "none in this build" : hosts) + ")");
    }
  }
  const char* error = nullptr;
  out.host = entry(model.empty() ? nullptr : model.c_str(),
                   options.empty() ? nullptr : options.c_str(), &error);
  if (!out.host)
    throw RuntimeFailure(
        describe(CADINTERP_E_INVALID_ARGUMENT, "the host (" + out.source + ") refused model '" +
                                                   model + "' with options '" + options +
                                                   "': " + (error ? error : "no message")));
}

struct BuilderDestroyer {
  void operator()(cadinterp_builder* b) const { cadinterp_builder_destroy(b); }
};

int cmd_build(const std::vector<std::string>& args) {
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  std::string host_spec, model, host_options, store, output;
  std::string degree = std::to_string(o.degree);
  bool quiet = false;
  ArgParser p(
      "cadinterp build", "--host PATH|NAME -o OUT.cadi [options]",
      "Precomputes a parametric model into an asset: samples the host adaptively on a K-d tree\n"
      "until every element meets the tolerances or a budget is reached, then writes the asset.\n"
      "Ctrl-C cancels cleanly; with --store, running the same command again resumes without\n"
      "evaluating finished samples again.");
  const std::string hosts = builtin_hosts();
  p.option("host", 0, "PATH|NAME",
           "host library (.so exporting " CADINTERP_HOST_ENTRY_NAME ")\nor built-in host (" +
               (hosts.empty() ? std::string("none in this build") : hosts) + ")",
           &host_spec)
      .required();
  p.option("model", 'm', "NAME", "model of the host (default: the host's default model)", &model);
  p.option("host-options", 0, "K=V,...", "host settings, passed through to the host",
           &host_options);
  p.choice("degree", 0, "basis degree: 1 linear (C0), 3 cubic (C2)", {"1", "3"}, &degree);
  p.option("geometry-tol", 0, "REL", "Hausdorff error target / bbox diagonal",
           &o.geometry_tolerance, 1e-12, 1);
  p.option("field-tol", 0, "REL", "field error target / the field's value range",
           &o.field_tolerance, 1e-12, 1e6);
  p.option("max-samples", 0, "N", "no refinement starts beyond this many samples", &o.max_samples,
           1, 100000000);
  p.option("max-depth", 0, "N", "splits per direction", &o.max_depth, 0, 30);
  p.option("threads", 'j', "N", "host evaluations in parallel (0: all cores)", &o.threads, 0, 4096);
  p.option("store", 0, "FILE", "sample store (SQLite) to resume from and save to", &store);
  p.option("lossy-positions", 0, "ERR",
           "max absolute error the codec may add to positions,\nin model units (0: lossless)",
           &o.position_max_abs_error, 0, 1e300);
  bool simulate_mapped = false;
  p.flag("simulate-mapped", 0,
         "a sample mapped onto another's mesh gets the host's simulate\non the mapped mesh "
         "instead of its own fields carried over",
         &simulate_mapped);
  p.option("canonical-refinement", 0, "N",
           "rounds of canonical refinement where a mapped term departs\nfrom its own boundary "
           "(0: none)",
           &o.canonical_refinement, 0, 20);
  p.option("output", 'o', "OUT.cadi", "the asset to write", &output).required();
  p.flag("quiet", 'q', "no progress output (the summary is still printed)", &quiet);
  p.epilog("A host library is loaded with dlopen; its function " CADINTERP_HOST_ENTRY_NAME
           "(model, options, &error)\nreturns the host (cadinterp_host_entry_fn in "
           "cadinterp_builder.h).\n"
           "\nexamples:\n"
           "  cadinterp build --host analytic -o demo.cadi\n"
           "  cadinterp build --host ./libmyhost.so --model bracket --degree 3 \\\n"
           "      --geometry-tol 1e-3 --max-samples 500 --store bracket.db -o bracket.cadi");
  if (!p.parse(args)) return kExitOk;
  o.degree = std::stoi(degree);
  o.simulate_mapped = simulate_mapped ? 1 : 0;
  if (!store.empty()) o.store_path = store.c_str();

  LoadedHost host;
  load_host(host_spec, model, host_options, host);

  ProgressState progress;
  progress.tty = isatty(STDERR_FILENO) != 0;
  progress.quiet = quiet;
  o.progress = on_progress;
  o.progress_user = &progress;

  cadinterp_builder* raw = nullptr;
  cadinterp_status s = cadinterp_builder_create(host.host, &o, &raw);
  if (s != CADINTERP_OK)
    throw RuntimeFailure("cannot create the builder: " +
                         describe(s, cadinterp_builder_create_error()));
  std::unique_ptr<cadinterp_builder, BuilderDestroyer> builder(raw);

  if (!quiet) {
    std::fprintf(stderr, "building %s with %s (%d parameter%s, degree %d)%s\n", output.c_str(),
                 host.source.c_str(), host.host->parameter_count,
                 host.host->parameter_count == 1 ? "" : "s", o.degree,
                 store.empty() ? "" : (", store " + store).c_str());
  }
  // SA_RESETHAND: the first Ctrl-C asks for a clean stop, a second one kills as usual.
  struct sigaction sa {
  }, old{};
  sa.sa_handler = on_sigint;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &sa, &old);
  const auto t0 = Clock::now();
  s = cadinterp_builder_run(builder.get(), output.c_str());
  const double wall = seconds_since(t0);
  sigaction(SIGINT, &old, nullptr);
  // The bar's last frame may be up to 0.1 s stale: replace it by the outcome below.
  if (progress.line_open) std::fputs("\r\x1b[K", stderr);

  cadinterp_build_report r{};
  r.struct_size = sizeof r;
  cadinterp_builder_report(builder.get(), &r);
  if (s == CADINTERP_E_CANCELLED) {
    throw RuntimeFailure(describe(
        s, fmt("stopped after %s; %s", human_seconds(wall).c_str(),
               store.empty()
                   ? "the samples were in memory only (use --store to resume later)"
                   : ("finished samples are kept in " + store + ": run the same command to resume")
                         .c_str())));
  }
  cadinterp_build_stages st;
  std::memset(&st, 0, sizeof st);
  st.struct_size = sizeof st;
  cadinterp_builder_stages(builder.get(), &st);
  // What the run did, also when it failed (cadinterp_builder_report covers every exit path).
  auto print_summary = [&](std::FILE* out) {
    std::fprintf(out,
                 "  samples            %d (points requested %d, host evaluations %d, from the "
                 "store %d, infeasible %d)\n",
                 r.samples, st.points_requested, r.host_evaluations, r.store_hits,
                 r.infeasible_points);
    for (int i = 0; i < st.infeasible_reasons; ++i) {
      const char* message = nullptr;
      int count = 0;
      if (cadinterp_builder_infeasible_reason(builder.get(), i, &message, &count) == CADINTERP_OK)
        std::fprintf(out, "    infeasible x%-5d %s\n", count, message);
    }
    if (st.other_infeasible_points > 0)
      std::fprintf(out, "    infeasible x%-5d (other messages)\n", st.other_infeasible_points);
    std::fprintf(out, "  elements           %d (infeasible %d, of which unmapped %d)\n", r.elements,
                 r.infeasible_elements, st.unmapped_elements);
    if (o.simulate_mapped)
      std::fprintf(out,
                   "  simulate mapped    %d mapped terms simulated on their mapped mesh, %d "
                   "failed (their fields carried over)\n",
                   st.mapped_simulated, st.mapped_simulate_failures);
    if (st.mapped_simulate_failures > 0)
      std::fprintf(out, "    first failure    %s\n", st.first_mapped_simulate_failure);
    if (st.refined_elements > 0)
      std::fprintf(out, "  refined canonical  %d elements, %d vertices added\n",
                   st.refined_elements, st.refined_vertices);
    std::fprintf(
        out,
        "  stages             store %s, sampling %s, refinement %s, elements %s, "
        "writing %s\n",
        human_seconds(st.store_seconds).c_str(), human_seconds(st.sampling_seconds).c_str(),
        human_seconds(st.refinement_seconds).c_str(), human_seconds(st.elements_seconds).c_str(),
        human_seconds(st.write_seconds).c_str());
  };
  if (s != CADINTERP_OK) {
    std::fprintf(stderr, "build summary (failed after %s)\n", human_seconds(wall).c_str());
    print_summary(stderr);
    throw RuntimeFailure("build failed: " + describe(s, cadinterp_builder_error(builder.get())));
  }
  if (!quiet)
    std::fprintf(stderr, "%sdone: %d samples, %d elements in %s\n",
                 progress.tty ? "" : "progress: ", r.samples, r.elements,
                 human_seconds(r.wall_seconds).c_str());

  std::printf("build summary\n");
  std::printf("  asset              %s, %s (%llu bytes)\n", output.c_str(),
              human_bytes(r.asset_bytes).c_str(), static_cast<unsigned long long>(r.asset_bytes));
  print_summary(stdout);
  std::printf("  stored meshes      %d\n", r.stored_meshes);
  std::printf("  max error          %.3g x the target (%s)\n", r.max_error,
              r.max_error <= 1 ? "met" : "not met");
  std::printf("  time               %s wall, %s in the host", human_seconds(r.wall_seconds).c_str(),
              human_seconds(r.host_seconds).c_str());
  if (r.host_evaluations > 0)
    std::printf(", %s per sample", human_seconds(r.host_seconds / r.host_evaluations).c_str());
  std::printf("\n");
  if (r.budget_exhausted)
    std::printf(
        "note: --max-samples (%d) stopped refinement before every element met the tolerance\n",
        o.max_samples);
  return kExitOk;
}

#else

int cmd_build(const std::vector<std::string>& args) {
  ArgParser p("cadinterp build", "--host PATH|NAME -o OUT.cadi [options]",
              "Precomputes a parametric model into an asset. This cadinterp was built without\n"
              "the builder library (libcadinterp_builder), so building is not available.");
  if (std::find(args.begin(), args.end(), "--help") != args.end() ||
      std::find(args.begin(), args.end(), "-h") != args.end()) {
    std::fputs(p.help().c_str(), stdout);
    return kExitOk;
  }
  throw RuntimeFailure("this cadinterp was built without libcadinterp_builder");
}

#endif

int run(const std::vector<std::string>& args) {
  if (args.empty()) {
    std::fputs(top_help().c_str(), stderr);
    return kExitUsage;
  }
  const std::string& cmd = args[0];
  if (cmd == "-h" || cmd == "--help") {
    std::fputs(top_help().c_str(), stdout);
    return kExitOk;
  }
  if (cmd == "--version" || cmd == "version") {
    print_version();
    return kExitOk;
  }
  std::vector<std::string> rest(args.begin() + 1, args.end());
  const Command* c = nullptr;
  std::string name = cmd;
  if (cmd == "help") {
    if (rest.empty()) {
      std::fputs(top_help().c_str(), stdout);
      return kExitOk;
    }
    name = rest[0];
    rest = {"--help"};
  }
  for (const Command& k : kCommands)
    if (name == k.name) c = &k;
  if (!c) {
    std::fprintf(stderr,
                 "cadinterp: unknown command '%s' (commands: build, inspect, eval, bench, explore; "
                 "see 'cadinterp --help')\n",
                 name.c_str());
    return kExitUsage;
  }
  const std::string prog = std::string("cadinterp ") + c->name;
  try {
    return c->run(rest);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n(see '%s --help')\n", prog.c_str(), e.what(), prog.c_str());
    return kExitUsage;
  } catch (const RuntimeFailure& e) {
    std::fprintf(stderr, "%s: error: %s\n", prog.c_str(), e.what());
    return kExitError;
  } catch (const format::FormatError& e) {
    std::fprintf(stderr, "%s: error: %s\n", prog.c_str(),
                 describe(static_cast<int>(e.status), e.what()).c_str());
    return kExitError;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: error: %s\n", prog.c_str(),
                 describe(CADINTERP_E_OUT_OF_MEMORY, "").c_str());
    return kExitError;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", prog.c_str(), e.what());
    return kExitError;
  }
}

}  // namespace

int main(int argc, char** argv) { return run(std::vector<std::string>(argv + 1, argv + argc)); }
