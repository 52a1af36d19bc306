// cadinterp-conformance CASES_DIR: runs the conformance cases against the runtime it is linked
// with, through the public C ABI only (so it works against any build of the runtime).
//
// Each case directory holds asset.cadi and expected.txt, a sequence of lines:
//   open STATUS                      status of cadinterp_open
//   open_message TEXT                cadinterp_open_error() contains TEXT
//   tolerance T / grad_tolerance T   |got - expected| <= T * (1 + |expected|)
//   point x1 .. xK                   the next expectations are at x (hex floats)
//   status STATUS                    status of cadinterp_eval (and cadinterp_grad) at x
//   element E                        element holding x
//   positions v...                   #V*3 expected positions
//   dpositions v...                  K lines: d positions / d x_k
//   field0 v... / dfield0 v...       field 0 and its K derivative arrays
//   unit I U                         field I's unit is U ("-": none, cadinterp_field_unit gives "")
//   output I NAME U                  output I (format 1.3) is NAME with unit U ("-": none)
//   outputs v...                     cadinterp_eval_outputs of every output at x
//   doutputs v...                    K lines: d outputs / d x_k (one value per output)
//
// --dump DIR writes what the C ABI returned, as raw bytes, for other bindings to compare against
// bit for bit (bindings/python's conformance test): DIR/GROUP/CASE/open (the status, text), and per
// `status` line N: pN_status, and on success pN_element (text), pN_positions, pN_tets,
// pN_triangles, pN_tags, pN_field0 (the whole array) from cadinterp_eval, then pN_grad_positions,
// pN_dpositions, pN_dfield0 from cadinterp_grad.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"

namespace fs = std::filesystem;

namespace {

/// Raw outputs for --dump (see the top of this file); does nothing without a directory.
struct Dump {
  fs::path dir;
  void write(const std::string& name, const void* data, std::size_t bytes) const {
    if (dir.empty()) return;
    std::ofstream out(dir / name, std::ios::binary);
    out.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
    if (!out) throw std::runtime_error("cannot write " + (dir / name).string());
  }
  void text(const std::string& name, const std::string& value) const {
    write(name, value.data(), value.size());
  }
};

const std::map<std::string, cadinterp_status> kStatus = {
    {"CADINTERP_OK", CADINTERP_OK},
    {"CADINTERP_E_INVALID_ARGUMENT", CADINTERP_E_INVALID_ARGUMENT},
    {"CADINTERP_E_OUT_OF_MEMORY", CADINTERP_E_OUT_OF_MEMORY},
    {"CADINTERP_E_IO", CADINTERP_E_IO},
    {"CADINTERP_E_BAD_MAGIC", CADINTERP_E_BAD_MAGIC},
    {"CADINTERP_E_UNSUPPORTED_VERSION", CADINTERP_E_UNSUPPORTED_VERSION},
    {"CADINTERP_E_TRUNCATED", CADINTERP_E_TRUNCATED},
    {"CADINTERP_E_CORRUPT_INDEX", CADINTERP_E_CORRUPT_INDEX},
    {"CADINTERP_E_CHECKSUM", CADINTERP_E_CHECKSUM},
    {"CADINTERP_E_OUT_OF_RANGE", CADINTERP_E_OUT_OF_RANGE},
    {"CADINTERP_E_LIMIT", CADINTERP_E_LIMIT},
    {"CADINTERP_E_CORRUPT_BLOB", CADINTERP_E_CORRUPT_BLOB},
    {"CADINTERP_E_OUTSIDE_DOMAIN", CADINTERP_E_OUTSIDE_DOMAIN},
    {"CADINTERP_E_INFEASIBLE", CADINTERP_E_INFEASIBLE},
    {"CADINTERP_E_INTERNAL", CADINTERP_E_INTERNAL},
    {"CADINTERP_E_NOT_FOUND", CADINTERP_E_NOT_FOUND},
};

struct Failure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

cadinterp_status parse_status(const std::string& s) {
  const auto it = kStatus.find(s);
  if (it == kStatus.end()) throw Failure("unknown status name " + s);
  return it->second;
}

std::vector<double> numbers(std::istringstream& in) {
  std::vector<double> v;
  std::string tok;
  while (in >> tok) v.push_back(std::strtod(tok.c_str(), nullptr));
  return v;
}

void compare(const std::string& what, const float* got, const std::vector<double>& want,
             double tol) {
  for (std::size_t i = 0; i < want.size(); ++i)
    if (!(std::abs(got[i] - want[i]) <= tol * (1.0 + std::abs(want[i]))))
      throw Failure(what + "[" + std::to_string(i) + "]: got " + std::to_string(got[i]) +
                    ", expected " + std::to_string(want[i]));
}

/// Values of field 0 in a call's output: #V or #T rows (its location) of its components.
std::size_t field0_values(const cadinterp_asset* asset, std::uint32_t vertices,
                          std::uint32_t tets) {
  cadinterp_field_info f{};
  if (cadinterp_field(asset, 0, &f) != CADINTERP_OK) throw Failure("cadinterp_field 0 failed");
  return std::size_t(f.location == CADINTERP_PER_TET ? tets : vertices) * std::size_t(f.components);
}

/// Every output of the asset at x, with the gradient (#outputs by K).
void eval_all_outputs(cadinterp_workspace* ws, const cadinterp_asset* asset,
                      const std::vector<double>& x, std::vector<double>& values,
                      std::vector<double>& grad) {
  const int n = cadinterp_output_count(asset);
  std::vector<int> all(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = i;
  values.assign(all.size(), 0.0);
  grad.assign(all.size() * x.size(), 0.0);
  if (cadinterp_eval_outputs(ws, x.data(), all.data(), n, values.data(), grad.data()) !=
      CADINTERP_OK)
    throw Failure(std::string("cadinterp_eval_outputs failed: ") + cadinterp_workspace_error(ws));
}

void compare(const std::string& what, const std::vector<double>& got,
             const std::vector<double>& want, double tol) {
  if (got.size() != want.size()) throw Failure(what + ": count differs");
  for (std::size_t i = 0; i < want.size(); ++i)
    if (!(std::abs(got[i] - want[i]) <= tol * (1.0 + std::abs(want[i]))))
      throw Failure(what + "[" + std::to_string(i) + "]: got " + std::to_string(got[i]) +
                    ", expected " + std::to_string(want[i]));
}

void check_output_name(const cadinterp_asset* asset, std::istringstream& in) {
  int i = -1;
  std::string want_name, want_unit;
  in >> i >> want_name >> want_unit;
  if (want_unit == "-") want_unit.clear();
  const char *name = nullptr, *unit = nullptr;
  if (cadinterp_output(asset, i, &name, &unit) != CADINTERP_OK)
    throw Failure("cadinterp_output " + std::to_string(i) + " failed");
  if (want_name != name || want_unit != unit)
    throw Failure("output " + std::to_string(i) + " is '" + name + "' [" + unit + "]");
}

void run_case(const fs::path& dir, const Dump& dump) {
  std::ifstream exp(dir / "expected.txt");
  if (!exp) throw Failure("no expected.txt");
  cadinterp_asset* asset = nullptr;
  cadinterp_workspace* ws = nullptr;
  struct Cleanup {
    cadinterp_asset*& a;
    cadinterp_workspace*& w;
    ~Cleanup() {
      cadinterp_workspace_destroy(w);
      cadinterp_close(a);
    }
  } cleanup{asset, ws};
  double tol = 1e-5, grad_tol = 1e-4;
  std::vector<double> x;
  cadinterp_mesh mesh{};
  cadinterp_mesh_grad grad{};
  int dpos = 0, dfield = 0, doutput = 0, points = 0;
  std::vector<double> output_values, output_grad;
  std::string line;
  while (std::getline(exp, line)) {
    std::istringstream in(line);
    std::string key;
    if (!(in >> key) || key[0] == '#') continue;
    if (key == "open") {
      std::string s;
      in >> s;
      const cadinterp_status got = cadinterp_open((dir / "asset.cadi").u8string().c_str(), &asset);
      dump.text("open", std::to_string(got));
      if (got != parse_status(s))
        throw Failure(std::string("open: got ") + cadinterp_status_string(got) + " (" +
                      cadinterp_open_error() + "), expected " + s);
      if (got == CADINTERP_OK && cadinterp_workspace_create(asset, &ws) != CADINTERP_OK)
        throw Failure("workspace");
    } else if (key == "open_message") {
      std::string want;
      std::getline(in >> std::ws, want);
      if (std::string(cadinterp_open_error()).find(want) == std::string::npos)
        throw Failure(std::string("open message '") + cadinterp_open_error() + "' lacks '" + want +
                      "'");
    } else if (key == "unit") {
      int i = -1;
      std::string want;
      in >> i >> want;
      if (want == "-") want.clear();
      const char* got = nullptr;
      if (cadinterp_field_unit(asset, i, &got) != CADINTERP_OK || !got)
        throw Failure("cadinterp_field_unit " + std::to_string(i) + " failed");
      if (want != got)
        throw Failure("field " + std::to_string(i) + " unit '" + got + "', expected '" + want +
                      "'");
    } else if (key == "tolerance") {
      in >> tol;
    } else if (key == "grad_tolerance") {
      in >> grad_tol;
    } else if (key == "point") {
      x = numbers(in);
      if (!asset || static_cast<int>(x.size()) != cadinterp_parameter_count(asset))
        throw Failure("point dimension");
    } else if (key == "status") {
      std::string s;
      in >> s;
      const int fields[1] = {0};
      const int nf = cadinterp_field_count(asset) > 0 ? 1 : 0;
      const cadinterp_status got = cadinterp_eval(ws, x.data(), fields, nf, &mesh);
      const std::string p = "p" + std::to_string(points++) + "_";
      dump.text(p + "status", std::to_string(got));
      if (got != parse_status(s))
        throw Failure(std::string("eval: got ") + cadinterp_status_string(got) + " (" +
                      cadinterp_workspace_error(ws) + "), expected " + s);
      if (got == CADINTERP_OK) {
        const std::size_t v = mesh.vertex_count, t = mesh.tet_count, f = mesh.triangle_count;
        const std::size_t nf0 = nf ? field0_values(asset, mesh.vertex_count, mesh.tet_count) : 0;
        const std::size_t k = x.size();
        dump.text(p + "element", std::to_string(mesh.element));
        dump.write(p + "positions", mesh.positions, 3 * v * sizeof(float));
        dump.write(p + "tets", mesh.tets, 4 * t * sizeof(std::uint32_t));
        dump.write(p + "triangles", mesh.triangles, 3 * f * sizeof(std::uint32_t));
        dump.write(p + "tags", mesh.triangle_tags, f * sizeof(std::int32_t));
        if (nf) dump.write(p + "field0", mesh.fields[0], nf0 * sizeof(float));
        // eval's arrays live until the next call: copy what later lines compare.
        static thread_local std::vector<float> pos, fld;
        pos.assign(mesh.positions, mesh.positions + 3 * mesh.vertex_count);
        if (nf) fld.assign(mesh.fields[0], mesh.fields[0] + mesh.vertex_count);
        const int element = mesh.element;
        const std::uint32_t nv = mesh.vertex_count;
        if (cadinterp_grad(ws, x.data(), fields, nf, &grad) != CADINTERP_OK)
          throw Failure("grad failed");
        dump.write(p + "grad_positions", grad.positions, 3 * v * sizeof(float));
        dump.write(p + "dpositions", grad.dpositions, k * 3 * v * sizeof(float));
        if (nf) dump.write(p + "dfield0", grad.dfields[0], k * nf0 * sizeof(float));
        mesh = cadinterp_mesh{};
        mesh.element = element;
        mesh.vertex_count = nv;
        mesh.positions = pos.data();
        static thread_local const float* fptr[1];
        fptr[0] = fld.data();
        mesh.fields = fptr;
      }
      dpos = dfield = doutput = 0;
    } else if (key == "output") {
      check_output_name(asset, in);
    } else if (key == "outputs") {
      eval_all_outputs(ws, asset, x, output_values, output_grad);
      compare("outputs", output_values, numbers(in), tol);
    } else if (key == "doutputs") {
      const std::size_t K = x.size(), d = static_cast<std::size_t>(doutput++);
      std::vector<double> got;
      for (std::size_t i = 0; i < output_values.size(); ++i) got.push_back(output_grad[i * K + d]);
      compare("doutputs", got, numbers(in), grad_tol);
    } else if (key == "element") {
      int e;
      in >> e;
      if (e != mesh.element)
        throw Failure("element " + std::to_string(mesh.element) + ", expected " +
                      std::to_string(e));
    } else if (key == "positions") {
      const auto want = numbers(in);
      if (want.size() != 3 * std::size_t(mesh.vertex_count)) throw Failure("vertex count");
      compare("positions", mesh.positions, want, tol);
    } else if (key == "dpositions") {
      const auto want = numbers(in);
      compare("dpositions", grad.dpositions + std::size_t(dpos++) * want.size(), want, grad_tol);
    } else if (key == "field0") {
      compare("field0", mesh.fields[0], numbers(in), tol);
    } else if (key == "dfield0") {
      const auto want = numbers(in);
      compare("dfield0", grad.dfields[0] + std::size_t(dfield++) * want.size(), want, grad_tol);
    } else {
      throw Failure("unknown line: " + line);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  Dump dump;
  if (argc == 4 && std::string(argv[2]) == "--dump") dump.dir = argv[3];
  if (argc != 2 && dump.dir.empty()) {
    std::fprintf(stderr, "usage: %s CASES_DIR [--dump DIR]   (e.g. conformance/cases)\n", argv[0]);
    return 2;
  }
  int passed = 0, failed = 0;
  std::vector<fs::path> cases;
  for (const char* group : {"valid", "invalid"})
    for (const auto& e : fs::directory_iterator(fs::path(argv[1]) / group))
      cases.push_back(e.path());
  std::sort(cases.begin(), cases.end());
  for (const fs::path& c : cases) {
    const std::string name = c.parent_path().filename().string() + "/" + c.filename().string();
    try {
      Dump case_dump;
      if (!dump.dir.empty()) {
        case_dump.dir = dump.dir / name;
        fs::create_directories(case_dump.dir);
      }
      run_case(c, case_dump);
      std::printf("PASS %s\n", name.c_str());
      ++passed;
    } catch (const std::exception& e) {
      std::printf("FAIL %s: %s\n", name.c_str(), e.what());
      ++failed;
    }
  }
  std::printf("conformance: %d passed, %d failed\n", passed, failed);
  return failed == 0 && passed > 0 ? 0 : 1;
}
