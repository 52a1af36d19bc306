// libFuzzer target: arbitrary bytes through open + eval + grad + vjp + properties of the C ABI.
// Any crash, sanitizer report or leak is a bug; every input must end in a status.
// Build and run: scripts/fuzz.sh [seconds] (seeds: conformance/cases/*/*/asset.cadi).
#include <cstddef>
#include <cstdint>
#include <vector>

#include <xxhash.h>

#include "cadinterp/cadinterp.h"
#include "cadinterp_generated.h"

namespace {

std::uint64_t get_le(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
void set_le(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// Checksums stop almost every mutation at the door. Recompute them (blob checksums where a blob
// lies inside the file, then the index checksum) so that mutations reach the FlatBuffers
// verifier, the semantic checks and the decoders.
void fix_checksums(std::vector<std::uint8_t>& b) {
  if (b.size() < 48) return;
  const std::uint64_t index_size = get_le(&b[32]);
  if (index_size > b.size() - 48 || index_size > (1u << 30)) return;
  std::uint8_t* index = b.data() + 48;
  const std::uint64_t section = 48 + index_size;
  flatbuffers::Verifier v(index, static_cast<std::size_t>(index_size));
  if (cadinterp::fb::VerifyAssetBuffer(v)) {
    auto* elems = cadinterp::fb::GetMutableAsset(index)->mutable_elements();
    auto fix = [&](cadinterp::fb::BlobRef* r) {
      if (!r || r->size() > b.size() - section || r->offset() > b.size() - section - r->size())
        return;
      r->mutate_checksum(
          XXH64(b.data() + section + r->offset(), static_cast<std::size_t>(r->size()), 0));
    };
    auto aligned = [](const auto* vec) {
      return vec && reinterpret_cast<std::uintptr_t>(vec->Data()) % 8 == 0;
    };
    for (flatbuffers::uoffset_t e = 0; elems && e < elems->size(); ++e) {
      auto* m = elems->GetMutableObject(e);
      if (!aligned(m->positions()) || (m->fields() && !aligned(m->fields()))) continue;
      fix(m->mutable_tets());
      fix(m->mutable_triangles());
      fix(m->mutable_triangle_tags());
      fix(m->mutable_canonical_positions());
      if (auto* p = m->mutable_positions())
        for (flatbuffers::uoffset_t i = 0; i < p->size(); ++i) fix(p->GetMutableObject(i));
      if (auto* f = m->mutable_fields())
        for (flatbuffers::uoffset_t i = 0; i < f->size(); ++i) fix(f->GetMutableObject(i));
    }
  }
  set_le(&b[40], XXH64(index, static_cast<std::size_t>(index_size), 0));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> bytes(data, data + size);
  fix_checksums(bytes);
  cadinterp_asset* asset = nullptr;
  if (cadinterp_open_memory(bytes.data(), bytes.size(), 0, &asset) != CADINTERP_OK) return 0;
  cadinterp_workspace* ws = nullptr;
  if (cadinterp_workspace_create(asset, &ws) == CADINTERP_OK) {
    const int K = cadinterp_parameter_count(asset);
    std::vector<double> x(static_cast<std::size_t>(K));
    const int fields[1] = {0};
    const int nf = cadinterp_field_count(asset) > 0 ? 1 : 0;
    for (double u : {0.0, 0.37, 0.5, 1.0}) {
      for (int d = 0; d < K; ++d) {
        cadinterp_parameter_info p;
        cadinterp_parameter(asset, d, &p);
        x[static_cast<std::size_t>(d)] = p.lower + u * (p.upper - p.lower);
      }
      cadinterp_mesh m;
      if (cadinterp_eval(ws, x.data(), fields, nf, &m) != CADINTERP_OK) continue;
      cadinterp_mesh_grad g;
      cadinterp_grad(ws, x.data(), fields, nf, &g);
      std::vector<float> adj(static_cast<std::size_t>(m.vertex_count) * 3, 1.0f);
      std::vector<double> out(static_cast<std::size_t>(K));
      cadinterp_vjp(ws, x.data(), adj.data(), nullptr, nullptr, 0, out.data());
      const double dir[3] = {0, 0, 1};
      cadinterp_properties props;
      cadinterp_eval_properties(ws, x.data(), 1.0, dir, &props, nullptr);
    }
    cadinterp_workspace_destroy(ws);
  }
  cadinterp_close(asset);
  return 0;
}
