// The forward-compatibility assets of conformance_future.h, through the object API of the
// test-only schema: unpack the index, append the future fields, pack, reassemble the file.
#include "tools/conformance_future.h"

#include <xxhash.h>

#include <cstring>
#include <memory>
#include <stdexcept>

#include "cadinterp_future_generated.h"
#include "format/asset_format.h"

namespace cadinterp::tools {

namespace {

std::uint64_t get_le(const std::vector<std::uint8_t>& b, std::size_t at, int n) {
  std::uint64_t v = 0;
  for (int i = n - 1; i >= 0; --i) v = (v << 8) | b[at + static_cast<std::size_t>(i)];
  return v;
}

void put_le(std::vector<std::uint8_t>& b, std::size_t at, std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i)
    b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}

}  // namespace

std::vector<std::uint8_t> as_future_minor(const std::vector<std::uint8_t>& asset,
                                          const std::vector<std::string>& required_features) {
  using format::kHeaderSize;
  if (asset.size() < kHeaderSize || std::memcmp(asset.data(), format::kMagic, 8) != 0)
    throw std::runtime_error("as_future_minor: not an asset");
  const std::uint64_t index_size = get_le(asset, 32, 8);
  const std::uint8_t* index = asset.data() + kHeaderSize;
  flatbuffers::Verifier verifier(index, static_cast<std::size_t>(index_size));
  if (!future_fb::VerifyAssetBuffer(verifier))
    throw std::runtime_error("as_future_minor: the index does not verify");
  const std::unique_ptr<future_fb::AssetT> t = future_fb::UnPackAsset(index);

  const auto minor = static_cast<std::uint16_t>(format::kFormatMinor + 1);
  t->format_minor = minor;
  t->required_features = required_features;
  auto note = std::make_unique<future_fb::AnnotationT>();
  note->key = "written_by";
  note->value = "cadinterp-make-conformance, test-only schema conformance/future";
  t->annotations.push_back(std::move(note));
  // The preview blob: bytes only the unknown field references, after the known blobs.
  const std::string preview = "a preview a later minor might store: 1.x readers skip it";
  const std::uint64_t section = asset.size() - kHeaderSize - index_size;
  t->preview = std::make_unique<future_fb::BlobRef>(
      section, preview.size(), XXH64(preview.data(), preview.size(), 0), future_fb::Codec::Raw);

  flatbuffers::FlatBufferBuilder fbb;
  future_fb::FinishAssetBuffer(fbb, future_fb::Asset::Pack(fbb, t.get()));
  // Header (fields rewritten below), the new index, the known blobs, the preview blob.
  const std::size_t index_bytes = fbb.GetSize();
  const auto known = static_cast<std::size_t>(section);
  std::vector<std::uint8_t> out(kHeaderSize + index_bytes + known + preview.size());
  std::memcpy(out.data(), asset.data(), kHeaderSize);
  std::memcpy(out.data() + kHeaderSize, fbb.GetBufferPointer(), index_bytes);
  std::memcpy(out.data() + kHeaderSize + index_bytes, asset.data() + asset.size() - known, known);
  std::memcpy(out.data() + kHeaderSize + index_bytes + known, preview.data(), preview.size());
  put_le(out, 10, minor, 2);
  put_le(out, 16, out.size(), 8);
  put_le(out, 32, fbb.GetSize(), 8);
  put_le(out, 40, XXH64(fbb.GetBufferPointer(), fbb.GetSize(), 0), 8);
  return out;
}

}  // namespace cadinterp::tools
