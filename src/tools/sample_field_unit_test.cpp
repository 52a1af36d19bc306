// The builder half of field units (format 1.1): cadinterp_sample_set_field_unit on the object a
// host's simulate callback writes into, and the sample store's serialization of the units
// (version 2, still reading the version 1 bytes of stores written before units existed), and
// cadinterp_sample_add_output on the same object (scalar outputs, store version 3).
// Lives with the tools because the builder's own test target belongs to another component.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "cadinterp/cadinterp_builder.h"
#include "mesh/host_call.h"
#include "mesh/sample.h"

namespace {

using cadinterp::mesh::Sample;

// A one-tet sample with a per-vertex scalar and a per-vertex vector field, as a host writes it.
cadinterp_sample one_tet_sample() {
  cadinterp_sample s;
  const double v[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::uint32_t tet[4] = {0, 1, 2, 3};
  const std::uint32_t tri[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  const std::int32_t tags[4] = {1, 2, 3, 4};
  EXPECT_EQ(cadinterp_sample_set_mesh(&s, v, 4, tet, 1, tri, tags, 4), CADINTERP_OK);
  const double t[4] = {20, 21, 22, 23};
  const double u[12] = {0.1, 0, 0, 0.2, 0, 0, 0.3, 0, 0, 0.4, 0, 0};
  EXPECT_EQ(cadinterp_sample_add_field(&s, "temperature", CADINTERP_PER_VERTEX, 1, t, 4),
            CADINTERP_OK);
  EXPECT_EQ(cadinterp_sample_add_field(&s, "displacement", CADINTERP_PER_VERTEX, 3, u, 4),
            CADINTERP_OK);
  s.sample.feasible = true;
  return s;
}

TEST(SampleFieldUnit, SetsTheUnitOfANamedField) {
  cadinterp_sample s = one_tet_sample();
  EXPECT_EQ(cadinterp_sample_set_field_unit(&s, "displacement", "mm"), CADINTERP_OK);
  EXPECT_EQ(cadinterp_sample_set_field_unit(&s, "temperature", "\u00B0C"), CADINTERP_OK);
  ASSERT_EQ(s.sample.fields.size(), 2u);
  EXPECT_EQ(s.sample.fields[0].unit, "\u00B0C");
  EXPECT_EQ(s.sample.fields[1].unit, "mm");
  // Set again: replaced; "" clears.
  EXPECT_EQ(cadinterp_sample_set_field_unit(&s, "displacement", "m"), CADINTERP_OK);
  EXPECT_EQ(s.sample.fields[1].unit, "m");
  EXPECT_EQ(cadinterp_sample_set_field_unit(&s, "temperature", ""), CADINTERP_OK);
  EXPECT_EQ(s.sample.fields[0].unit, "");
  // Named failures, nothing changed.
  EXPECT_EQ(cadinterp_sample_set_field_unit(&s, "stress", "MPa"), CADINTERP_E_NOT_FOUND);
  EXPECT_EQ(cadinterp_sample_set_field_unit(&s, "", "MPa"), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_sample_set_field_unit(&s, nullptr, "MPa"), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_sample_set_field_unit(&s, "displacement", nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_sample_set_field_unit(nullptr, "displacement", "mm"),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(s.sample.fields[1].unit, "m");
  EXPECT_EQ(cadinterp::mesh::validate(s.sample), "");
}

TEST(SampleFieldUnit, StoreBytesKeepUnitsAndReadVersion1) {
  cadinterp_sample s = one_tet_sample();
  ASSERT_EQ(cadinterp_sample_set_field_unit(&s, "displacement", "mm"), CADINTERP_OK);
  const std::vector<std::uint8_t> bytes = cadinterp::mesh::serialize(s.sample);
  const Sample back = cadinterp::mesh::deserialize(bytes.data(), bytes.size());
  ASSERT_EQ(back.fields.size(), 2u);
  EXPECT_EQ(back.fields[0].unit, "");
  EXPECT_EQ(back.fields[1].unit, "mm");
  EXPECT_EQ(back.fields[1].values, s.sample.fields[1].values);
  EXPECT_EQ(cadinterp::mesh::serialize(back), bytes);
  // Every prefix is refused (the units are part of every sample from version 2 on).
  for (std::size_t n = 0; n < bytes.size(); ++n)
    EXPECT_THROW(cadinterp::mesh::deserialize(bytes.data(), n), std::runtime_error) << n;

  // Version 1 (a store written before units): the same bytes without the trailing output count
  // (version 3, a u64: 0 here) and unit strings (one u64 length and its text per field),
  // version word 1. Read with no units.
  std::vector<std::uint8_t> v1 = bytes;
  const std::size_t units = 2 * 8 + 2;  // "" and "mm"
  v1.resize(v1.size() - 8 - units);
  const std::uint32_t one = 1;
  std::memcpy(v1.data() + 4, &one, 4);
  const Sample old = cadinterp::mesh::deserialize(v1.data(), v1.size());
  ASSERT_EQ(old.fields.size(), 2u);
  EXPECT_EQ(old.fields[1].unit, "");
  EXPECT_EQ(old.fields[1].values, s.sample.fields[1].values);
  EXPECT_EQ(old.vertices, s.sample.vertices);
  // Any other version is refused.
  std::vector<std::uint8_t> v4 = bytes;
  const std::uint32_t four = 4;
  std::memcpy(v4.data() + 4, &four, 4);
  EXPECT_THROW(cadinterp::mesh::deserialize(v4.data(), v4.size()), std::runtime_error);
}

TEST(SampleOutput, AddOutputChecksAndValidates) {
  cadinterp_sample s = one_tet_sample();
  EXPECT_EQ(cadinterp_sample_add_output(&s, "brep_volume", 2.5, "mm^3"), CADINTERP_OK);
  EXPECT_EQ(cadinterp_sample_add_output(&s, "compliance", -1.0, nullptr), CADINTERP_OK);
  EXPECT_EQ(cadinterp_sample_add_output(&s, "brep_volume", 3.0, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_sample_add_output(&s, "", 3.0, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_sample_add_output(&s, nullptr, 3.0, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_sample_add_output(nullptr, "x", 3.0, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  ASSERT_EQ(s.sample.outputs.size(), 2u);
  EXPECT_EQ(s.sample.outputs[0].unit, "mm^3");
  EXPECT_EQ(s.sample.outputs[1].unit, "");
  EXPECT_EQ(cadinterp::mesh::validate(s.sample), "");
  const std::vector<std::uint8_t> bytes = cadinterp::mesh::serialize(s.sample);
  const Sample back = cadinterp::mesh::deserialize(bytes.data(), bytes.size());
  ASSERT_EQ(back.outputs.size(), 2u);
  EXPECT_EQ(back.outputs[1].value, -1.0);
  // A non-finite value is accepted by the call and refused after the callback (validate).
  EXPECT_EQ(cadinterp_sample_add_output(&s, "bad", std::nan(""), nullptr), CADINTERP_OK);
  EXPECT_NE(cadinterp::mesh::validate(s.sample).find("'bad' is not finite"), std::string::npos);
}

}  // namespace
