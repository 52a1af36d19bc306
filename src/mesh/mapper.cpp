#include "mesh/mapper.h"

namespace cadinterp::mesh {

bool IdentityMapper::map(const Sample& source, const Sample& canonical, MappedSample& out,
                         std::string& why) const {
  if (!same_combinatorics(source, canonical)) {
    why = "meshes differ in combinatorics (" + std::to_string(source.vertex_count()) + " vs " +
          std::to_string(canonical.vertex_count()) +
          " vertices); the identity mapper maps equal combinatorics only";
    return false;
  }
  out.vertices = source.vertices;
  out.fields.clear();
  for (const Field& f : source.fields) out.fields.push_back(f.values);
  return true;
}

}  // namespace cadinterp::mesh
