// Which asset format versions and features this reader reads (fileformat/SPEC.md, "Versions and
// features"): the forward-compatibility rules of glTF. A reader opens any minor of its major,
// ignoring tables and fields it does not know, and refuses a file only for another major or for
// a listed required feature it does not implement.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace cadinterp::fb {
struct Asset;
}

namespace cadinterp::format {

/// Names of the required features (Asset.required_features) this reader implements. Empty: every
/// capability of this reader is part of format 1.0 or 1.1, which every 1.x reader has, so no
/// writer lists one today. A codec, basis degree or other meaning added in a later minor that a
/// reader must understand gets a name here and in SPEC.md.
inline constexpr std::array<std::string_view, 0> kKnownFeatures{};

/// Checks the header's version fields. Throws FormatError(UnsupportedVersion) for another major;
/// any minor of this major is read.
void check_format_version(std::uint16_t major, std::uint16_t minor);

/// Checks the verified index against the header's minor, before anything else of the index is
/// read: format_minor repeats the minor exactly in files of minor >= 2 and is absent below;
/// required_features likewise only from 1.2, and each one must be implemented
/// (UnsupportedVersion naming the first that is not); in files of minor 0 and 1, the minor is 1
/// exactly when a field has a unit. Throws FormatError(CorruptIndex) for a mismatch.
void check_index_version(const fb::Asset& index, std::uint16_t minor);

/// True when a file of `minor` may hold blobs that only fields unknown to this reader reference
/// (a newer minor): its blob section may then have bytes no known reference covers.
bool newer_minor(std::uint16_t minor);

}  // namespace cadinterp::format
