// `cadinterp inspect`: what an asset holds (parameters, basis, K-d tree statistics, recorded
// infeasible points, element mesh sizes, stored bytes by kind and codec, fields, regions,
// provenance), as text or JSON. It reads the index with the format library, since sizes and
// codecs are not, and should not be, part of the C ABI.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cadinterp_generated.h"
#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"
#include "format/asset_reader.h"
#include "format/codec.h"
#include "format/error_model.h"
#include "json_writer.h"

namespace cadinterp::cli {
namespace {

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

struct FieldRow {
  std::string name, location;
  int components;
  double max_abs_error;
  std::string unit;  // "" when the asset gives none (format 1.0)
};
struct RegionRow {
  std::string name, kind;
  std::vector<int> tags;
};

/// Everything `inspect` reports, gathered from the verified index once; the text and JSON
/// printers only format it.
struct AssetSummary {
  std::string path, format_version;
  std::uint64_t file_size = 0, index_bytes = 0, blob_bytes = 0;
  int K = 0, E = 0, degree = 0, nodes = 0, samples = 0, bsplines = 0;
  // Depth per direction: splits are at midpoints, so an element's unit width is 2^-depth.
  std::vector<Stat> depth;
  Stat terms, verts, tets, tris, err;
  // Per field (FieldDesc order): the largest estimate over each element, relative to the
  // field's range, as cadinterp_error_estimates reports it.
  std::vector<Stat> field_err;
  std::vector<int> infeasible;
  std::uint64_t stored_meshes = 0;
  std::map<BlobKey, BlobTotal> blobs;
  std::vector<FieldRow> fields;
  std::vector<RegionRow> regions;
  std::string builder_version, host, options;
  const fb::Asset* idx = nullptr;  // parameters and infeasible points; owned by the reader
};

/// Per-element statistics: tree depth, terms, mesh sizes, error estimates and stored blobs.
void tally_elements(const format::AssetReader& reader, AssetSummary& s) {
  const fb::Asset& idx = reader.index();
  const cadinterp::core::CompiledBasis& basis = reader.basis();
  const auto& parts = basis.parts();
  const int K = s.K;
  s.depth.assign(static_cast<std::size_t>(K), Stat());
  s.field_err.assign(idx.fields() ? idx.fields()->size() : 0, Stat());
  std::set<std::pair<std::uint64_t, std::uint64_t>> seen_blobs;  // (offset, size)
  const std::size_t fields_per_vertex = reader.field_values_per_vertex();
  const std::size_t fields_per_tet = reader.field_values_per_tet();
  for (int e = 0; e < s.E; ++e) {
    const auto ue = static_cast<std::size_t>(e);
    for (int d = 0; d < K; ++d) {
      const auto ud = static_cast<std::size_t>(d);
      const double w = parts.elem_box[ue * 2 * K + K + ud] - parts.elem_box[ue * 2 * K + ud];
      s.depth[ud].add(std::round(-std::log2(w)));
    }
    s.terms.add(static_cast<double>(parts.elem_term_begin[ue + 1] - parts.elem_term_begin[ue]));
    const fb::ElementMeshes* em = idx.elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
    if (!basis.element_feasible(e) || em->vertex_count() == 0) {
      s.infeasible.push_back(e);
      continue;
    }
    const std::uint64_t V = em->vertex_count(), T = em->tet_count(), F = em->triangle_count();
    s.verts.add(static_cast<double>(V));
    s.tets.add(static_cast<double>(T));
    s.tris.add(static_cast<double>(F));
    // The largest estimate cadinterp_error_estimates gives in the element, per quantity (format
    // 1.3: the error model, scaled as the runtime scales it); before, the stored geometry one.
    const bool cubic = basis.element_cubic(e);
    const auto* model = em->error_model();
    const std::size_t W = static_cast<std::size_t>(K) + 1;
    if (model && model->size() == W * (1 + s.field_err.size())) {
      for (std::size_t q = 0; q <= s.field_err.size(); ++q) {
        const double v = format::error_model_reported(
            format::error_model_max(model->data() + q * W, K), cubic, q == 0,
            format::element_error_floor(*em, static_cast<int>(q)));
        if (v >= 0) (q ? s.field_err[q - 1] : s.err).add(v);
      }
    } else if (em->error_estimate() >= 0) {
      s.err.add(em->error_estimate());
    }
    auto add = [&](const char* kind, const fb::BlobRef* b, std::uint64_t raw) {
      if (!b) return;
      // The index stores format::Codec's values (asset_writer.cpp), so the name is the codec's.
      BlobTotal& t = s.blobs[{kind, format::codec_name(static_cast<format::Codec>(b->codec()))}];
      ++t.references;
      // Elements may reference the same stored blob; its bytes exist once in the file.
      if (!seen_blobs.insert({b->offset(), b->size()}).second) return;
      ++t.count;
      t.bytes += b->size();
      t.raw_bytes += raw;
      s.blob_bytes += b->size();
    };
    add("tets", em->tets(), 16 * T);
    add("triangles", em->triangles(), 12 * F);
    add("triangle tags", em->triangle_tags(), 4 * F);
    add("canonical positions", em->canonical_positions(), 12 * V);
    if (em->positions()) {
      for (const fb::BlobRef* b : *em->positions()) add("positions", b, 12 * V);
      s.stored_meshes += em->positions()->size();
    }
    if (em->fields())
      for (const fb::BlobRef* b : *em->fields())
        add("fields", b, 4 * (fields_per_vertex * V + fields_per_tet * T));
  }
}

AssetSummary summarize(const format::AssetReader& reader, const std::string& path) {
  const fb::Asset& idx = reader.index();
  const cadinterp::core::CompiledBasis& basis = reader.basis();
  const auto& parts = basis.parts();
  AssetSummary s;
  s.path = path;
  s.idx = &idx;
  s.K = basis.dim();
  s.E = basis.element_count();
  s.degree = static_cast<int>(basis.degree());
  tally_elements(reader, s);

  if (idx.fields())
    for (const fb::FieldDesc* f : *idx.fields())
      s.fields.push_back(
          {f->name()->str(), f->location() == fb::FieldLocation::Tet ? "tet" : "vertex",
           f->components(), f->max_abs_error(), f->unit() ? f->unit()->str() : std::string()});
  if (idx.regions())
    for (const fb::BoundaryRegion* r : *idx.regions()) {
      RegionRow row{r->name()->str(), r->kind() ? r->kind()->str() : "", {}};
      if (r->face_tags()) row.tags.assign(r->face_tags()->begin(), r->face_tags()->end());
      s.regions.push_back(std::move(row));
    }
  const fb::Provenance* prov = idx.provenance();
  auto prov_str = [&](const flatbuffers::String* str) { return str ? str->str() : std::string(); };
  s.builder_version = prov ? prov_str(prov->builder_version()) : "";
  s.host = prov ? prov_str(prov->host()) : "";
  s.options = prov ? prov_str(prov->options()) : "";
  s.file_size = reader.file_size();
  // The blobs tile the section after the index, so the index size follows from their sum.
  s.index_bytes = s.file_size - format::kHeaderSize - s.blob_bytes;
  s.bsplines = static_cast<int>(parts.bs_col_begin.size()) - 1;
  s.nodes = static_cast<int>(parts.node_dir.size());
  s.samples = basis.sample_count();
  s.format_version = fmt("%d.%d", format::kFormatMajor, reader.format_minor());
  return s;
}

const fb::Parameter* parameter(const AssetSummary& s, int i) {
  return s.idx->parameters()->Get(static_cast<flatbuffers::uoffset_t>(i));
}

void print_json(const AssetSummary& s) {
  std::string out;
  JsonWriter w(out);
  w.begin_object();
  w.field("asset", s.path).field("file_bytes", s.file_size).field("format", s.format_version);
  w.field("header_bytes", static_cast<std::uint64_t>(format::kHeaderSize));
  w.field("index_bytes", s.index_bytes).field("blob_bytes", s.blob_bytes);
  w.key("parameters").begin_array();
  for (int i = 0; i < s.K; ++i) {
    const fb::Parameter* q = parameter(s, i);
    w.begin_object().field("name", q->name()->str());
    w.field("unit", q->unit() ? q->unit()->str() : "");
    w.field("lower", q->lower()).field("upper", q->upper()).end_object();
  }
  w.end_array();
  w.field("degree", s.degree);
  w.key("tree").begin_object();
  w.field("elements", s.E).field("infeasible_elements", static_cast<int>(s.infeasible.size()));
  w.field("nodes", s.nodes).field("samples", s.samples).field("bsplines", s.bsplines);
  w.field("stored_meshes", s.stored_meshes);
  w.key("depth").begin_array();
  for (int d = 0; d < s.K; ++d) {
    const Stat& st = s.depth[static_cast<std::size_t>(d)];
    w.begin_object().field("parameter", parameter(s, d)->name()->str());
    w.field("min", static_cast<int>(st.min)).field("max", static_cast<int>(st.max)).end_object();
  }
  w.end_array();
  write_stat(w, "terms_per_element", s.terms);
  w.key("infeasible").begin_array();
  for (const int e : s.infeasible) w.value(e);
  w.end_array();
  w.end_object();
  w.key("infeasible_points").begin_array();
  if (const auto* inf = s.idx->infeasible())
    for (const auto* f : *inf) {
      w.begin_object().key("x").begin_array();
      if (f->x())
        for (const double v : *f->x()) w.value(v);
      w.end_array().field("message", f->message() ? f->message()->str() : "").end_object();
    }
  w.end_array();
  w.key("element_sizes").begin_object();
  write_stat(w, "vertices", s.verts);
  write_stat(w, "tets", s.tets);
  write_stat(w, "triangles", s.tris);
  w.end_object();
  w.key("error_estimate").begin_object().field("measured", s.err.n);
  if (s.err.n) w.field("min", s.err.min).field("mean", s.err.mean()).field("max", s.err.max);
  w.key("fields").begin_array();
  for (std::size_t f = 0; f < s.field_err.size() && f < s.fields.size(); ++f) {
    const Stat& e = s.field_err[f];
    w.begin_object().field("name", s.fields[f].name).field("measured", e.n);
    if (e.n) w.field("min", e.min).field("mean", e.mean()).field("max", e.max);
    w.end_object();
  }
  w.end_array();
  w.end_object();
  w.field("position_max_abs_error", static_cast<double>(s.idx->position_max_abs_error()));
  w.key("blobs").begin_array();
  for (const auto& [k, t] : s.blobs) {
    w.begin_object().field("kind", k.kind).field("codec", k.codec).field("count", t.count);
    w.field("references", t.references)
        .field("bytes", t.bytes)
        .field("raw_bytes", t.raw_bytes)
        .end_object();
  }
  w.end_array();
  w.key("fields").begin_array();
  for (const FieldRow& f : s.fields) {
    w.begin_object().field("name", f.name).field("location", f.location);
    w.field("components", f.components).field("max_abs_error", f.max_abs_error);
    w.field("unit", f.unit).end_object();
  }
  w.end_array();
  w.key("regions").begin_array();
  for (const RegionRow& r : s.regions) {
    w.begin_object().field("name", r.name).field("kind", r.kind).key("face_tags").begin_array();
    for (const int t : r.tags) w.value(t);
    w.end_array().end_object();
  }
  w.end_array();
  w.key("provenance").begin_object();
  w.field("builder_version", s.builder_version).field("host", s.host);
  // Kept as text: the index does not promise the options are valid JSON.
  w.field("options", s.options).end_object();
  w.end_object();
  std::fputs(out.c_str(), stdout);
}

/// The file, parameters, basis and tree sections, with the builder's record of infeasibility.
void print_text_tree(const AssetSummary& s) {
  std::printf("asset        %s\n", s.path.c_str());
  std::printf("file         %s (%llu bytes), format %s; index %s, blobs %s\n",
              human_bytes(s.file_size).c_str(), static_cast<unsigned long long>(s.file_size),
              s.format_version.c_str(), human_bytes(s.index_bytes).c_str(),
              human_bytes(s.blob_bytes).c_str());
  std::printf("\nparameters   %d\n", s.K);
  std::printf("  %-3s %-20s %-10s %14s %14s\n", "#", "name", "unit", "lower", "upper");
  for (int i = 0; i < s.K; ++i) {
    const fb::Parameter* q = parameter(s, i);
    std::printf("  %-3d %-20s %-10s %14.6g %14.6g\n", i, q->name()->c_str(),
                q->unit() && q->unit()->size() ? q->unit()->c_str() : "-", q->lower(), q->upper());
  }
  std::printf("\nbasis        degree %d (%s)\n", s.degree,
              s.degree == 3 ? "cubic B-splines, C2" : "linear B-splines, C0");
  std::printf("tree         %d elements (%zu infeasible), %d nodes, %d samples, %d B-splines\n",
              s.E, s.infeasible.size(), s.nodes, s.samples, s.bsplines);
  std::printf("  depth      ");
  for (int d = 0; d < s.K; ++d) {
    const Stat& st = s.depth[static_cast<std::size_t>(d)];
    std::printf("%s%s %d..%d", d ? ", " : "", parameter(s, d)->name()->c_str(),
                static_cast<int>(st.min), static_cast<int>(st.max));
  }
  std::printf("\n  terms      per element: %s\n", stat_text(s.terms).c_str());
  std::printf("  stored     %llu meshes (position arrays)\n",
              static_cast<unsigned long long>(s.stored_meshes));
  if (!s.infeasible.empty()) {
    std::printf("  infeasible elements:");
    for (std::size_t i = 0; i < s.infeasible.size() && i < 20; ++i)
      std::printf(" %d", s.infeasible[i]);
    if (s.infeasible.size() > 20) std::printf(" ... (%zu more)", s.infeasible.size() - 20);
    std::printf("\n");
  }
  // The builder's record of why: host failures at their points, and elements refused because a
  // term could not be mapped (at the element's centre, the term's sample named in the message).
  if (const auto* inf = s.idx->infeasible(); inf && inf->size() > 0) {
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
}

/// The element sizes, stored blobs, fields, regions and provenance sections.
void print_text_contents(const AssetSummary& s) {
  std::printf("\nelements     (feasible ones)\n");
  std::printf("  vertices   %s (total %.0f)\n", stat_text(s.verts).c_str(), s.verts.sum);
  std::printf("  tets       %s (total %.0f)\n", stat_text(s.tets).c_str(), s.tets.sum);
  std::printf("  triangles  %s (total %.0f)\n", stat_text(s.tris).c_str(), s.tris.sum);
  if (s.err.n)
    std::printf(
        "  error est. geometry: min %.3g, mean %.3g, max %.3g (of the bbox diagonal; %llu "
        "measured)\n",
        s.err.min, s.err.mean(), s.err.max, static_cast<unsigned long long>(s.err.n));
  else
    std::printf("  error est. not measured\n");
  for (std::size_t f = 0; f < s.field_err.size() && f < s.fields.size(); ++f)
    if (s.field_err[f].n)
      std::printf("  error est. %s: min %.3g, mean %.3g, max %.3g (of its range)\n",
                  s.fields[f].name.c_str(), s.field_err[f].min, s.field_err[f].mean(),
                  s.field_err[f].max);
  const float pos_err = s.idx->position_max_abs_error();
  std::printf("  positions  %s\n",
              pos_err > 0 ? fmt("lossy, max abs error %g", static_cast<double>(pos_err)).c_str()
                          : "lossless");

  std::printf("\nblobs        %-20s %-17s %8s %8s %12s %12s %7s\n", "kind", "codec", "count",
              "refs", "bytes", "raw bytes", "ratio");
  for (const auto& [k, t] : s.blobs)
    std::printf(
        "             %-20s %-17s %8llu %8llu %12llu %12llu %7.3f\n", k.kind.c_str(),
        k.codec.c_str(), static_cast<unsigned long long>(t.count),
        static_cast<unsigned long long>(t.references), static_cast<unsigned long long>(t.bytes),
        static_cast<unsigned long long>(t.raw_bytes),
        t.raw_bytes ? static_cast<double>(t.bytes) / static_cast<double>(t.raw_bytes) : 0.0);

  std::printf("\nfields       %zu\n", s.fields.size());
  for (const FieldRow& f : s.fields)
    std::printf(
        "  %-20s %-8s per %-6s %2d component%s, %s\n", f.name.c_str(),
        f.unit.empty() ? "-" : ("[" + f.unit + "]").c_str(), f.location.c_str(), f.components,
        f.components == 1 ? "" : "s",
        f.max_abs_error > 0 ? fmt("max abs error %g", f.max_abs_error).c_str() : "lossless");
  std::printf("regions      %zu\n", s.regions.size());
  for (const RegionRow& r : s.regions) {
    std::printf("  %-20s %-8s tags", r.name.c_str(), r.kind.empty() ? "-" : r.kind.c_str());
    for (const int t : r.tags) std::printf(" %d", t);
    std::printf("\n");
  }
  std::printf("\nprovenance\n");
  std::printf("  builder    %s\n", s.builder_version.empty() ? "-" : s.builder_version.c_str());
  std::printf("  host       %s\n", s.host.empty() ? "-" : s.host.c_str());
  std::printf("  options    %s\n", s.options.empty() ? "-" : s.options.c_str());
}

}  // namespace

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

  const std::unique_ptr<format::AssetReader> reader = open_index(path);
  const AssetSummary s = summarize(*reader, path);
  if (json) {
    print_json(s);
  } else {
    print_text_tree(s);
    print_text_contents(s);
  }
  return kExitOk;
}

}  // namespace cadinterp::cli
