// The version and feature checks of fileformat/SPEC.md, "Versions and features".
#include "format/format_version.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "cadinterp_generated.h"
#include "format/asset_format.h"

namespace cadinterp::format {

namespace {

[[noreturn]] void corrupt_version(const std::string& what) {
  throw FormatError(Status::CorruptIndex, "corrupt index: " + what);
}

std::string version_text(std::uint16_t minor) {
  return std::to_string(kFormatMajor) + "." + std::to_string(minor);
}

// Files of minor 0 and 1 (no version field in the index): the minor is the lowest one whose
// schema holds the content, 1 exactly when a field has a unit. Checked both ways, so that a
// flipped minor bit is reported like any other flipped bit.
void check_units_minor(const fb::Asset& index, std::uint16_t minor) {
  bool any_unit = false;
  if (const auto* fields = index.fields())
    for (const fb::FieldDesc* f : *fields) any_unit = any_unit || (f->unit() && f->unit()->size());
  if (minor != (any_unit ? kMinorFieldUnits : 0))
    corrupt_version("format minor " + std::to_string(minor) +
                    " does not match the content (field units " +
                    (any_unit ? "present: 1.1" : "absent: 1.0") + ")");
}

}  // namespace

void check_format_version(std::uint16_t major, std::uint16_t minor) {
  // Another major changes what existing fields mean: no reader may guess (SPEC.md).
  if (major != kFormatMajor)
    throw FormatError(Status::UnsupportedVersion,
                      "format " + std::to_string(major) + "." + std::to_string(minor) +
                          " (this reader: " + version_text(kFormatMinor) + ", major " +
                          std::to_string(kFormatMajor) + " only)");
}

void check_index_version(const fb::Asset& index, std::uint16_t minor) {
  const auto* features = index.required_features();
  // Outputs are 1.3 content: a file holding them says 1.3 or more.
  if (minor < kMinorOutputs && index.outputs())
    corrupt_version("format minor " + std::to_string(minor) + " with the outputs of format 1.3");
  if (minor < kMinorFeatures) {
    // Both fields are 1.2 content: a file holding them says 1.2 or more.
    if (flatbuffers::IsFieldPresent(&index, fb::Asset::VT_FORMAT_MINOR) || features)
      corrupt_version("format minor " + std::to_string(minor) +
                      " with the version fields of format 1.2");
    check_units_minor(index, minor);
    return;
  }
  // The minor is in the index, under its checksum: a flipped header minor is caught here.
  if (index.format_minor() != minor)
    corrupt_version("header says format " + version_text(minor) + ", index says " +
                    version_text(index.format_minor()));
  if (!features) return;
  for (const flatbuffers::String* f : *features) {
    if (f->size() == 0 || std::memchr(f->data(), '\0', f->size()))
      corrupt_version("a required feature name is empty or contains a NUL character");
    const std::string_view name(f->data(), f->size());
    if (std::find(kKnownFeatures.begin(), kKnownFeatures.end(), name) == kKnownFeatures.end())
      throw FormatError(Status::UnsupportedVersion,
                        "format " + version_text(minor) + " asset requires feature '" +
                            std::string(name) + "', which this reader (format " +
                            version_text(kFormatMinor) + ") does not implement");
  }
}

bool newer_minor(std::uint16_t minor) { return minor > kFormatMinor; }

}  // namespace cadinterp::format
