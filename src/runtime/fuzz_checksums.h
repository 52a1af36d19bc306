// Checksum fix-up shared by the libFuzzer targets fuzz_open_eval and fuzz_api. Checksums stop
// almost every mutation at the door, so the blob checksums (where a blob lies inside the file)
// and then the index checksum are recomputed, and mutations reach the FlatBuffers verifier, the
// semantic checks and the decoders.
//
// In two passes, every BlobRef and its new checksum found before any is written: the verifier
// checks bounds and alignment, not that tables and structs are disjoint, so in a mutated index
// a checksum written into one BlobRef can be another table's offset, and reading through that
// table after the write would leave the buffer.
#pragma once

#include <xxhash.h>

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "cadinterp_generated.h"

namespace cadinterp_fuzz {

inline std::uint64_t load_le64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

inline void store_le64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// Header: index size at offset 32, index checksum at 40, the index from 48, then the blobs.
// BlobRef structs are rewritten only where their vector is 8-aligned, as a misaligned one is
// rejected at open anyway.
inline void fix_checksums(std::vector<std::uint8_t>& b) {
  if (b.size() < 48) return;
  const std::uint64_t index_size = load_le64(&b[32]);
  if (index_size > b.size() - 48 || index_size > (1u << 30)) return;
  std::uint8_t* index = b.data() + 48;
  const std::uint64_t section = 48 + index_size;
  const std::uint64_t section_size = b.size() - section;
  std::vector<std::pair<cadinterp::fb::BlobRef*, std::uint64_t>> updates;
  flatbuffers::Verifier verifier(index, static_cast<std::size_t>(index_size));
  if (cadinterp::fb::VerifyAssetBuffer(verifier)) {
    auto add = [&](cadinterp::fb::BlobRef* r) {
      if (!r || r->size() > section_size || r->offset() > section_size - r->size()) return;
      updates.emplace_back(
          r, XXH64(b.data() + section + r->offset(), static_cast<std::size_t>(r->size()), 0));
    };
    auto aligned = [](const auto* v) {
      return !v || reinterpret_cast<std::uintptr_t>(v->Data()) % 8 == 0;
    };
    auto* elements = cadinterp::fb::GetMutableAsset(index)->mutable_elements();
    for (flatbuffers::uoffset_t e = 0; elements && e < elements->size(); ++e) {
      auto* m = elements->GetMutableObject(e);
      if (!aligned(m->positions()) || !aligned(m->fields())) continue;
      add(m->mutable_tets());
      add(m->mutable_triangles());
      add(m->mutable_triangle_tags());
      add(m->mutable_canonical_positions());
      if (auto* p = m->mutable_positions())
        for (flatbuffers::uoffset_t i = 0; i < p->size(); ++i) add(p->GetMutableObject(i));
      if (auto* f = m->mutable_fields())
        for (flatbuffers::uoffset_t i = 0; i < f->size(); ++i) add(f->GetMutableObject(i));
    }
  }
  for (const auto& [r, checksum] : updates) r->mutate_checksum(checksum);
  store_le64(&b[40], XXH64(index, static_cast<std::size_t>(index_size), 0));
}

}  // namespace cadinterp_fuzz
