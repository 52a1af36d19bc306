// cadinterp-make-conformance OUTDIR: regenerates conformance/cases (see conformance/README.md).
//
// Valid cases: small synthetic assets (K = 1..4, linear and cubic, fields, T-junctions, an
// infeasible region) with expected eval and grad at fixed points, computed here independently of
// the runtime: the compiled basis' weights (core) applied to the stored arrays in double.
// Invalid cases: a valid asset broken in one way each, with the exact status expected at open or
// at eval.
#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "cadinterp_generated.h"
#include "format/asset_reader.h"
#include "format/synthetic_asset.h"
#include "tools/conformance_future.h"

namespace fs = std::filesystem;
using namespace cadinterp;

namespace {

// The first minor newer than this runtime's, and a feature no reader implements.
const std::string kNewerMinor = "1." + std::to_string(cadinterp::format::kFormatMinor + 1);
const std::string kUnknownFeature = "conformance_unknown_feature";

std::string hex(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

void write_bytes(const fs::path& p, const std::vector<std::uint8_t>& b) {
  std::ofstream f(p, std::ios::binary);
  f.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  if (!f) throw std::runtime_error("cannot write " + p.string());
}

struct Valid {
  const char* name;
  std::string description;
  format::SyntheticSpec spec;
  format::Codec codec;
};

format::SyntheticSpec make_spec(int K, core::Degree g, int samples, bool fields, bool infeasible) {
  format::SyntheticSpec s;
  s.K = K;
  s.degree = g;
  s.cells[0] = 2;
  s.cells[1] = 1;
  s.cells[2] = 1;
  s.tolerance = 1e-3;
  s.max_samples = samples;
  s.fields = fields;
  s.infeasible_corner = infeasible;
  return s;
}

format::SyntheticSpec with_units(format::SyntheticSpec s) {
  s.field_units = true;
  return s;
}

format::SyntheticSpec with_outputs(format::SyntheticSpec s) {
  s.outputs = true;
  return s;
}

// Expected outputs at x: positions, requested fields, and (if feasible) their K derivatives.
void expect_point(std::ofstream& out, const format::SyntheticAsset& a,
                  const std::vector<double>& x) {
  const core::CompiledBasis& cb = *a.basis;
  const int K = cb.dim();
  out << "point";
  for (double v : x) out << ' ' << hex(v);
  out << '\n';
  const int e = cb.locate(x.data());
  if (!cb.element_feasible(e)) {
    out << "status CADINTERP_E_INFEASIBLE\n";
    return;
  }
  core::EvalWorkspace ws = cb.make_workspace();
  core::BasisWeights w;
  cb.eval(x.data(), ws, true, &w);
  const format::ElementData& ed = a.content.elements[static_cast<std::size_t>(e)];
  out << "status CADINTERP_OK\nelement " << e << '\n';
  auto emit = [&](const char* tag, const std::vector<std::vector<float>>& arrays, std::size_t begin,
                  std::size_t n) {
    out << tag;
    for (std::size_t i = begin; i < begin + n; ++i) {
      double s = 0.0;
      for (int t = 0; t < w.count; ++t) s += w.psi[t] * arrays[static_cast<std::size_t>(t)][i];
      out << ' ' << hex(s);
    }
    out << '\n';
    for (int d = 0; d < K; ++d) {
      out << 'd' << tag;
      for (std::size_t i = begin; i < begin + n; ++i) {
        double s = 0.0;
        for (int t = 0; t < w.count; ++t)
          s += w.dpsi[d * w.count + t] * arrays[static_cast<std::size_t>(t)][i];
        out << ' ' << hex(s);
      }
      out << '\n';
    }
  };
  emit("positions", ed.positions, 0, ed.vertex_count * 3);
  if (!ed.fields.empty()) emit("field0", ed.fields, 0, ed.vertex_count);  // temperature
  if (a.content.outputs.empty()) return;
  // Outputs (format 1.3): the same weights on the per-sample values.
  out << "outputs";
  for (const format::OutputInfo& o : a.content.outputs) {
    double s = 0.0;
    for (int t = 0; t < w.count; ++t)
      s += w.psi[t] * o.values[static_cast<std::size_t>(w.samples[t])];
    out << ' ' << hex(s);
  }
  out << '\n';
  for (int d = 0; d < K; ++d) {
    out << "doutputs";
    for (const format::OutputInfo& o : a.content.outputs) {
      double s = 0.0;
      for (int t = 0; t < w.count; ++t)
        s += w.dpsi[d * w.count + t] * o.values[static_cast<std::size_t>(w.samples[t])];
      out << ' ' << hex(s);
    }
    out << '\n';
  }
}

// Rewrites the index checksum after an in-place index edit.
void rehash(std::vector<std::uint8_t>& b) {
  std::uint64_t size = 0;
  for (int i = 7; i >= 0; --i) size = (size << 8) | b[static_cast<std::size_t>(32 + i)];
  const std::uint64_t h = XXH64(b.data() + format::kHeaderSize, static_cast<std::size_t>(size), 0);
  for (int i = 0; i < 8; ++i)
    b[static_cast<std::size_t>(40 + i)] = static_cast<std::uint8_t>(h >> (8 * i));
}

fb::Asset* index_of(std::vector<std::uint8_t>& b) {
  return fb::GetMutableAsset(b.data() + format::kHeaderSize);
}

std::uint64_t blob_section(const std::vector<std::uint8_t>& b) {
  std::uint64_t size = 0;
  for (int i = 7; i >= 0; --i) size = (size << 8) | b[static_cast<std::size_t>(32 + i)];
  return format::kHeaderSize + size;
}

void set_le(std::vector<std::uint8_t>& b, std::size_t at, std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i)
    b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}

// The valid cases: one per basis dimension and degree, codec, fields or none, an infeasible
// corner, the format 1.1 feature (field units) and the format 1.3 one (outputs).
std::vector<Valid> valid_cases() {
  return {
      {"k1_linear", "K=1 linear, fields", make_spec(1, core::Degree::Linear, 9, true, false),
       format::Codec::Raw},
      {"k2_linear", "K=2 linear, fields, T-junctions",
       make_spec(2, core::Degree::Linear, 30, true, false), format::Codec::QuantDeltaZstd},
      {"k2_cubic", "K=2 cubic, fields, T-junctions",
       make_spec(2, core::Degree::Cubic, 30, true, false), format::Codec::QuantDeltaZstd},
      {"k3_linear", "K=3 linear, no fields, meshopt",
       make_spec(3, core::Degree::Linear, 40, false, false), format::Codec::Meshopt},
      {"k3_cubic", "K=3 cubic, fields, meshopt", make_spec(3, core::Degree::Cubic, 27, true, false),
       format::Codec::Meshopt},
      {"k4_linear", "K=4 linear, fields, draco",
       make_spec(4, core::Degree::Linear, 81, true, false), format::Codec::Draco},
      {"k2_infeasible", "K=2 linear, infeasible corner",
       make_spec(2, core::Degree::Linear, 40, true, true), format::Codec::QuantDeltaZstd},
      // Format 1.1 (field units); every case above uses nothing of 1.1 and stays a 1.0 file.
      {"k1_units", "K=1 linear, fields with units (format 1.1)",
       with_units(make_spec(1, core::Degree::Linear, 9, true, false)), format::Codec::Raw},
      // Format 1.3 (per-sample scalar outputs, interpolated with the basis weights).
      {"k2_outputs", "K=2 cubic, a scalar output per sample (format 1.3), infeasible corner",
       with_outputs(make_spec(2, core::Degree::Cubic, 30, true, true)),
       format::Codec::QuantDeltaZstd},
  };
}

// Writes valid/NAME (asset.cadi, expected.txt) and its INDEX.txt line; returns the asset.
// Expected: field units, four seeded random points, the centre (on element faces), a point in
// the infeasible corner where there is one, and a point outside the domain.
// `rewrite`, if given, turns the written asset into the case's bytes.
std::vector<std::uint8_t> write_valid_case(
    const fs::path& root, const Valid& v, std::ofstream& index,
    const std::function<std::vector<std::uint8_t>(const std::vector<std::uint8_t>&)>& rewrite =
        nullptr) {
  const format::SyntheticAsset a = format::make_synthetic_asset(v.spec);
  format::WriteOptions o;
  o.float_codec = v.codec;
  o.index_codec = v.codec;
  std::vector<std::uint8_t> bytes = format::write_asset(a.content, o);
  if (rewrite) bytes = rewrite(bytes);
  const fs::path dir = root / "valid" / v.name;
  fs::create_directories(dir);
  write_bytes(dir / "asset.cadi", bytes);
  std::ofstream exp(dir / "expected.txt");
  exp << "# " << v.description << "\nopen CADINTERP_OK\ntolerance 1e-5\ngrad_tolerance 1e-4\n";
  for (std::size_t f = 0; f < a.content.fields.size(); ++f)
    exp << "unit " << f << ' '
        << (a.content.fields[f].unit.empty() ? "-" : a.content.fields[f].unit) << '\n';
  for (std::size_t i = 0; i < a.content.outputs.size(); ++i)
    exp << "output " << i << ' ' << a.content.outputs[i].name << ' '
        << (a.content.outputs[i].unit.empty() ? "-" : a.content.outputs[i].unit) << '\n';
  std::mt19937_64 rng(17);
  std::vector<std::vector<double>> points;
  for (int i = 0; i < 4; ++i) {
    std::vector<double> x(static_cast<std::size_t>(v.spec.K));
    for (double& c : x) c = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    points.push_back(x);
  }
  points.emplace_back(static_cast<std::size_t>(v.spec.K), 0.5);  // on element faces
  if (v.spec.infeasible_corner) points.emplace_back(static_cast<std::size_t>(v.spec.K), 0.99);
  for (const auto& x : points) expect_point(exp, a, x);
  std::vector<double> outside(static_cast<std::size_t>(v.spec.K), 0.5);
  outside[0] = 1.25;
  exp << "point";
  for (double c : outside) exp << ' ' << hex(c);
  exp << "\nstatus CADINTERP_E_OUTSIDE_DOMAIN\n";
  index << "valid/" << v.name << " | CADINTERP_OK | " << v.description << " (" << bytes.size()
        << " bytes)\n";
  return bytes;
}

struct Invalid {
  const char* name;
  const char* when;  // "open" or "eval"
  const char* status;
  std::string description;
  std::function<void(std::vector<std::uint8_t>&)> mutate;
};

// Broken headers: magic, version, and the sizes the header gives.
std::vector<Invalid> header_cases() {
  return {
      {"empty", "open", "CADINTERP_E_BAD_MAGIC", "zero bytes", [](auto& b) { b.clear(); }},
      {"bad_magic", "open", "CADINTERP_E_BAD_MAGIC", "first magic byte changed",
       [](auto& b) { b[0] = 'C'; }},
      {"newer_major", "open", "CADINTERP_E_UNSUPPORTED_VERSION", "format 2.0",
       [](auto& b) { set_le(b, 8, 2, 2); }},
      {"newer_minor_not_in_index", "open", "CADINTERP_E_CORRUPT_INDEX",
       "header says format " + kNewerMinor + ", the index does not repeat it",
       [](auto& b) { set_le(b, 10, format::kFormatMinor + 1u, 2); }},
      {"truncated_header", "open", "CADINTERP_E_TRUNCATED", "first 20 bytes",
       [](auto& b) { b.resize(20); }},
      {"truncated", "open", "CADINTERP_E_TRUNCATED", "last byte missing",
       [](auto& b) { b.pop_back(); }},
      {"trailing_bytes", "open", "CADINTERP_E_CORRUPT_INDEX", "one byte appended",
       [](auto& b) { b.push_back(0); }},
  };
}

// Broken indexes, found at open: checksum, extent, FlatBuffers structure, and contents that
// verify as FlatBuffers but break the format's own rules (checksum updated so that these are
// what open reports).
std::vector<Invalid> index_cases() {
  return {
      {"index_checksum", "open", "CADINTERP_E_CHECKSUM", "an index byte flipped",
       [](auto& b) { b[format::kHeaderSize + 9] ^= 0x10; }},
      {"index_out_of_range", "open", "CADINTERP_E_OUT_OF_RANGE", "index size beyond the file",
       [](auto& b) { set_le(b, 32, b.size(), 8); }},
      {"corrupt_flatbuffer", "open", "CADINTERP_E_CORRUPT_INDEX",
       "root offset broken, checksum updated",
       [](auto& b) {
         set_le(b, format::kHeaderSize, 0xFFFFFF0u, 4);
         rehash(b);
       }},
      {"counts_exhaust_memory", "open", "CADINTERP_E_LIMIT", "vertex count 2^31, checksum updated",
       [](auto& b) {
         index_of(b)->mutable_elements()->GetMutableObject(0)->mutate_vertex_count(1u << 31);
         rehash(b);
       }},
      {"blob_offset_out_of_range", "open", "CADINTERP_E_OUT_OF_RANGE",
       "a blob offset beyond the file, checksum updated",
       [](auto& b) {
         auto* r = index_of(b)->mutable_elements()->GetMutableObject(0)->mutable_tets();
         r->mutate_offset(std::uint64_t(1) << 40);
         rehash(b);
       }},
      {"basis_index_out_of_range", "open", "CADINTERP_E_CORRUPT_INDEX",
       "a term's sample id out of range, checksum updated",
       [](auto& b) {
         index_of(b)->mutable_basis()->mutable_term_sample()->Mutate(0, 1 << 20);
         rehash(b);
       }},
      {"nan_parameter_range", "open", "CADINTERP_E_CORRUPT_INDEX",
       "NaN upper bound, checksum updated",
       [](auto& b) {
         index_of(b)->mutable_parameters()->GetMutableObject(0)->mutate_upper(std::nan(""));
         rehash(b);
       }},
      // Found by fuzzing the C ABI (fuzz_api, fuzz_open_eval):
      {"short_index", "open", "CADINTERP_E_CORRUPT_INDEX",
       "index size 4 (shorter than a FlatBuffers header), file size kept",
       [](auto& b) { set_le(b, 32, 4, 8); }},
      {"nul_in_name", "open", "CADINTERP_E_CORRUPT_INDEX",
       "NUL inside the first parameter's name, checksum updated",
       [](auto& b) {
         // Found by its text (its bytes live in the index; a name is unique enough here).
         const std::string name = index_of(b)->parameters()->Get(0)->name()->str();
         const auto at =
             std::search(b.begin() + format::kHeaderSize, b.end(), name.begin(), name.end());
         if (at != b.end()) *at = 0;
         rehash(b);
       }},
      {"basis_width_off_tree", "open", "CADINTERP_E_CORRUPT_INDEX",
       "a B-spline's inverse width times 1.5 (finite, not from a tree), checksum updated",
       [](auto& b) {
         auto* w = index_of(b)->mutable_basis()->mutable_bs_inv_width();
         w->Mutate(0, w->Get(0) * 1.5);
         rehash(b);
       }},
      {"nan_error_estimate", "open", "CADINTERP_E_CORRUPT_INDEX",
       "NaN error estimate of an element, checksum updated",
       [](auto& b) {
         index_of(b)->mutable_elements()->GetMutableObject(0)->mutate_error_estimate(std::nan(""));
         rehash(b);
       }},
  };
}

// Broken blobs, found at eval (open checks only their extents).
std::vector<Invalid> blob_cases() {
  return {
      {"blob_checksum", "eval", "CADINTERP_E_CHECKSUM", "a canonical-positions byte flipped",
       [](auto& b) {
         const auto* r = index_of(b)->elements()->Get(0)->canonical_positions();
         b[blob_section(b) + r->offset() + 5] ^= 0x01;
       }},
      {"nan_payload", "eval", "CADINTERP_E_CORRUPT_BLOB",
       "NaN canonical position (raw blob), checksums updated",
       [](auto& b) {
         auto* r =
             index_of(b)->mutable_elements()->GetMutableObject(0)->mutable_canonical_positions();
         const float nan = std::nanf("");
         std::uint8_t* p = b.data() + blob_section(b) + r->offset();
         std::memcpy(p, &nan, 4);
         r->mutate_checksum(XXH64(p, static_cast<std::size_t>(r->size()), 0));
         rehash(b);
       }},
  };
}

// Writes invalid/NAME (the base asset broken by c.mutate, expected.txt) and its INDEX.txt line.
void write_invalid_case(const fs::path& root, const Invalid& c,
                        const std::vector<std::uint8_t>& base, std::ofstream& index) {
  std::vector<std::uint8_t> b = base;
  c.mutate(b);
  const fs::path dir = root / "invalid" / c.name;
  fs::create_directories(dir);
  write_bytes(dir / "asset.cadi", b);
  std::ofstream exp(dir / "expected.txt");
  exp << "# " << c.description << "\n";
  if (std::string(c.when) == "open") {
    exp << "open " << c.status << "\n";
  } else {
    // Element 0 holds x = 0 (the base asset has K = 1).
    exp << "open CADINTERP_OK\npoint 0x0p+0\nstatus " << c.status << "\n";
  }
  index << "invalid/" << c.name << " | " << c.when << ' ' << c.status << " | " << c.description
        << "\n";
}

// Forward compatibility (SPEC.md, "Versions and features"), with assets of the next minor
// written through the test-only future schema: k1_linear with a table and a blob this runtime
// does not know must evaluate exactly as k1_linear; the same with a required feature no reader
// implements must be refused, naming the feature; with its minor set to 0 it is corrupt.
// Returns the number of cases written.
int write_forward_compat_cases(const fs::path& root, const std::vector<std::uint8_t>& base,
                               std::ofstream& index) {
  const Valid newer{
      "k1_newer_minor",
      "K=1 linear as format " + kNewerMinor + ": unknown table and blob, no required feature",
      make_spec(1, core::Degree::Linear, 9, true, false), format::Codec::Raw};
  write_valid_case(root, newer, index, [](const auto& b) { return tools::as_future_minor(b, {}); });
  const Invalid feature{"unknown_required_feature", "open", "CADINTERP_E_UNSUPPORTED_VERSION",
                        "format " + kNewerMinor + " requiring feature " + kUnknownFeature,
                        [](auto& b) { b = tools::as_future_minor(b, {kUnknownFeature}); }};
  write_invalid_case(root, feature, base, index);
  std::ofstream(root / "invalid" / feature.name / "expected.txt", std::ios::app)
      << "open_message " << kUnknownFeature << "\n";
  // The version fields are 1.2 content: a file claiming minor 0 must not hold them (this also
  // makes a flip of the header's minor down to 0 or 1 visible).
  write_invalid_case(root,
                     {"version_fields_in_minor_0", "open", "CADINTERP_E_CORRUPT_INDEX",
                      "the asset of k1_newer_minor with the header's minor set to 0",
                      [](auto& b) {
                        b = tools::as_future_minor(b, {});
                        set_le(b, 10, 0, 2);
                      }},
                     base, index);
  return 3;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2 || std::string(argv[1]) == "--help") {
    std::fprintf(argc == 2 ? stdout : stderr,
                 "usage: %s OUTDIR\n  Writes the conformance cases (valid/, invalid/, INDEX.txt) "
                 "to OUTDIR.\n",
                 argv[0]);
    return argc == 2 ? 0 : 2;
  }
  try {
    const fs::path root = argv[1];
    fs::create_directories(root / "valid");
    fs::create_directories(root / "invalid");
    std::ofstream index(root / "INDEX.txt");
    index << "# case | expectation | description (regenerate: cadinterp-make-conformance DIR)\n";

    const std::vector<Valid> valid = valid_cases();
    std::vector<std::uint8_t> base;  // a valid asset to break for the invalid cases
    for (const Valid& v : valid) {
      std::vector<std::uint8_t> bytes = write_valid_case(root, v, index);
      if (std::string(v.name) == "k1_linear")
        base = std::move(bytes);  // the smallest: each invalid case breaks a copy
    }
    std::size_t invalid = 0;
    for (auto* group : {header_cases, index_cases, blob_cases})
      for (const Invalid& c : group()) {
        write_invalid_case(root, c, base, index);
        ++invalid;
      }
    const int forward = write_forward_compat_cases(root, base, index);
    std::printf("wrote %zu valid, %zu invalid and %d forward-compatibility cases to %s\n",
                valid.size(), invalid, forward, root.string().c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
