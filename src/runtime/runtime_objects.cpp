// Building a cadinterp_asset from an opened reader, and the layout of an element's fields.
#include "runtime/runtime_objects.h"

#include "cadinterp_generated.h"

namespace cadinterp::runtime {

std::unique_ptr<cadinterp_asset> make_asset(std::unique_ptr<format::AssetReader> reader) {
  auto a = std::make_unique<cadinterp_asset>();
  a->reader = std::move(reader);
  const cadinterp::fb::Asset& idx = a->reader->index();
  for (const auto* p : *idx.parameters()) {
    a->names.push_back(p->name()->str());
    a->units.push_back(p->unit() ? p->unit()->str() : "");
  }
  if (idx.fields())
    for (const auto* f : *idx.fields())
      a->fields.push_back(
          {f->name()->str(),
           f->location() == cadinterp::fb::FieldLocation::Tet ? CADINTERP_PER_TET
                                                              : CADINTERP_PER_VERTEX,
           f->components(), f->max_abs_error(), f->unit() ? f->unit()->str() : std::string()});
  if (idx.regions())
    for (const auto* r : *idx.regions()) {
      RegionSlot s{r->name()->str(), r->kind() ? r->kind()->str() : "", {}};
      if (r->face_tags()) s.tags.assign(r->face_tags()->begin(), r->face_tags()->end());
      a->regions.push_back(std::move(s));
    }
  if (idx.outputs())  // format 1.3; checked at open (values finite where elements use them)
    for (const auto* o : *idx.outputs())
      a->outputs.push_back({o->name()->str(), o->unit() ? o->unit()->str() : std::string(),
                            std::vector<double>(o->values()->begin(), o->values()->end())});
  if (const auto* p = idx.provenance()) {
    a->builder_version = p->builder_version() ? p->builder_version()->str() : "";
    a->host = p->host() ? p->host()->str() : "";
    a->options = p->options() ? p->options()->str() : "";
  }
  if (const auto* inf = idx.infeasible())
    for (const auto* f : *inf) {
      a->infeasible_x.emplace_back(f->x()->begin(), f->x()->end());
      a->infeasible_message.push_back(f->message() ? f->message()->str() : "");
    }
  return a;
}

std::size_t field_offset(const cadinterp_asset& a, int f, std::size_t nv, std::size_t nt) {
  std::size_t off = 0;
  for (int j = 0; j < f; ++j)
    off += (a.fields[static_cast<std::size_t>(j)].location == CADINTERP_PER_VERTEX ? nv : nt) *
           static_cast<std::size_t>(a.fields[static_cast<std::size_t>(j)].components);
  return off;
}

std::size_t field_size(const cadinterp_asset& a, int f, std::size_t nv, std::size_t nt) {
  const FieldSlot& s = a.fields[static_cast<std::size_t>(f)];
  return (s.location == CADINTERP_PER_VERTEX ? nv : nt) * static_cast<std::size_t>(s.components);
}

}  // namespace cadinterp::runtime
