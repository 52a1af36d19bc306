// Assets of a format minor newer than this runtime's, for the forward-compatibility conformance
// cases (fileformat/SPEC.md, "Versions and features"). They are written with a test-only schema
// (conformance/future/cadinterp_future.fbs: cadinterp.fbs with fields appended), so the unknown
// table and blob really are in the bytes a reader sees.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cadinterp::tools {

/// `asset` (a valid file this runtime writes) rewritten as format 1.(kFormatMinor + 1): the same
/// index with the future schema's `annotations` table and `preview` blob appended (the blob at
/// the end of the blob section, referenced by nothing a current reader knows), `format_minor`
/// set, and `required_features` listed (may be empty). Everything a current reader knows is
/// unchanged, so it must evaluate the result exactly as `asset` unless a feature is required.
/// Throws std::runtime_error if `asset` is not a file of this format.
std::vector<std::uint8_t> as_future_minor(const std::vector<std::uint8_t>& asset,
                                          const std::vector<std::string>& required_features);

}  // namespace cadinterp::tools
