// Builder tests: the store, and whole builds through the C ABI with
// a host over the synthetic deformed box (format/synthetic_asset.h), whose true answer is known
// at every x: accuracy of the opened asset, determinism across thread counts, host failures,
// cancellation, the mapping hook's refusal of unmapped combinatorics, and kill -9 resumption.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <thread>

#include "builder/build.h"
#include "builder/builder_e2e.h"
#include "builder/sample_store.h"
#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"
#include "format/synthetic_asset.h"
#include "mesh/surface_distance.h"

namespace {

using namespace cadinterp;
using mesh::Sample;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("cadinterp_builder_test_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

std::vector<std::uint8_t> read_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(f), {});
}

// ---- The test host: the synthetic box through the C callbacks -------------------------------

struct BoxHost {
  format::SyntheticSpec spec;
  format::BoxMesh box;
  bool fail_corner = false;      // regenerate fails where x0 > 0.75 and x1 > 0.75
  bool throw_corner = false;     // ... throws instead
  bool vary_resolution = false;  // more cells where x0 > 0.5: combinatorics change
  std::string log_path;          // appends x of every regenerate call (resume test)
  int sleep_ms = 0;
  std::atomic<int> calls{0};
  std::vector<cadinterp_parameter_desc> params;
  cadinterp_host host{};

  explicit BoxHost(int K) {
    spec.K = K;
    spec.cells[0] = 3;
    spec.cells[1] = 2;
    spec.cells[2] = 2;
    box = format::synthetic_box(spec);
    static const char* names[4] = {"bend", "twist", "taper", "stretch"};
    for (int d = 0; d < K; ++d) params.push_back({names[d], "1", 0.0, 1.0});
    host.struct_size = sizeof host;
    host.name = "test box";
    host.identity = "box 3x2x2";
    host.parameter_count = K;
    host.parameters = params.data();
    host.user = this;
    host.regenerate = &regenerate;
    host.references = &references;
    host.simulate = &simulate;
    host.thread_safe = 1;
  }

  // The mesh at x: the shared box, or where vary_resolution refines it, one built into `local`.
  const format::BoxMesh* box_at(const double* x, format::SyntheticSpec& s,
                                format::BoxMesh& local) const {
    s = spec;
    if (!vary_resolution || x[0] <= 0.5) return &box;
    s.cells[0] = 4;
    local = format::synthetic_box(s);
    return &local;
  }

  static cadinterp_status regenerate(void* user, const double* x, cadinterp_sample* out) {
    auto* h = static_cast<BoxHost*>(user);
    ++h->calls;
    if (!h->log_path.empty()) {
      std::FILE* f = std::fopen(h->log_path.c_str(), "a");
      for (int d = 0; d < h->spec.K; ++d) std::fprintf(f, "%a ", x[d]);
      std::fprintf(f, "\n");
      std::fclose(f);
    }
    if (h->sleep_ms) std::this_thread::sleep_for(std::chrono::milliseconds(h->sleep_ms));
    if ((h->fail_corner || h->throw_corner) && x[0] > 0.75 && x[1] > 0.75) {
      if (h->throw_corner) throw std::runtime_error("fillet too large");
      cadinterp_sample_set_message(out, "fillet too large");
      return CADINTERP_E_INFEASIBLE;
    }
    format::SyntheticSpec spec;
    format::BoxMesh local;
    const format::BoxMesh* box = h->box_at(x, spec, local);
    std::vector<float> pos, fld;
    format::synthetic_host(spec, *box, x, pos, fld);
    const std::vector<double> V(pos.begin(), pos.end());
    return cadinterp_sample_set_mesh(out, V.data(), box->vertex_count, box->tets.data(),
                                     box->tets.size() / 4, box->triangles.data(), box->tags.data(),
                                     box->tags.size());
  }
  static cadinterp_status references(void*, const double*, cadinterp_sample* out) {
    const int32_t fixed[1] = {0}, load[1] = {1};
    cadinterp_sample_add_region(out, "clamp", "fixed", fixed, 1);
    cadinterp_sample_add_region(out, "tip", "force", load, 1);
    return CADINTERP_OK;
  }
  static cadinterp_status simulate(void* user, const double* x, const cadinterp_host_mesh* m,
                                   cadinterp_sample* out) {
    auto* h = static_cast<BoxHost*>(user);
    format::SyntheticSpec spec;
    format::BoxMesh local;
    const format::BoxMesh* box = h->box_at(x, spec, local);
    std::vector<float> pos, fld;
    format::synthetic_host(spec, *box, x, pos, fld);
    const std::vector<double> temp(fld.begin(), fld.begin() + static_cast<long>(m->vertex_count));
    const std::vector<double> stress(fld.begin() + static_cast<long>(m->vertex_count), fld.end());
    cadinterp_status s = cadinterp_sample_add_field(out, "temperature", CADINTERP_PER_VERTEX, 1,
                                                    temp.data(), temp.size());
    if (s != CADINTERP_OK) return s;
    return cadinterp_sample_add_field(out, "stress", CADINTERP_PER_TET, 1, stress.data(),
                                      stress.size());
  }

  // The true mesh at x, through the same callbacks the builder calls.
  Sample truth(const double* x) const { return mesh::Host(host).evaluate(x); }
};

using Built = builder::BuildOutcome;
Built build(BoxHost& h, const cadinterp_build_options& o, const std::string& path) {
  return builder::build_asset(h.host, o, path);
}

cadinterp_build_options small_options() {
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.geometry_tolerance = 2e-3;
  o.field_tolerance = 2e-2;
  o.max_samples = 120;
  o.max_depth = 6;
  o.threads = 2;
  return o;
}

// ---- Unit pieces ----------------------------------------------------------------------------

TEST(SampleStore, KeepsSamplesAndRefusesAnotherModel) {
  const std::string path = temp_path("store.sqlite");
  std::filesystem::remove(path);
  BoxHost h(2);
  const std::vector<double> x = {0.25, 0.5};
  const Sample s = h.truth(x.data());
  {
    builder::SampleStore store(path, "model A");
    Sample got;
    EXPECT_FALSE(store.get(x, got));
    store.put(x, s);
    Sample failed;
    failed.message = "no";
    store.put({0.5, 0.5}, failed);
  }
  {
    builder::SampleStore store(path, "model A");
    Sample got;
    ASSERT_TRUE(store.get(x, got));
    EXPECT_EQ(mesh::serialize(got), mesh::serialize(s));
    ASSERT_TRUE(store.get({0.5, 0.5}, got));
    EXPECT_FALSE(got.feasible);
    EXPECT_EQ(got.message, "no");
    EXPECT_EQ(store.size(), 2);
    EXPECT_FALSE(store.get({0.25, std::nextafter(0.5, 1.0)}, got));  // bit-exact keys
    try {
      builder::SampleStore other(path, "model B");
      ADD_FAILURE() << "a store of another model was accepted";
    } catch (const builder::StoreError& e) {
      EXPECT_EQ(e.kind, builder::StoreError::Kind::Mismatch);
    }
  }
  // Closed first, so that SQLite leaves no -wal or -shm file beside a removed database.
  std::filesystem::remove(path);
  EXPECT_FALSE(std::filesystem::exists(path + "-wal"));
  EXPECT_FALSE(std::filesystem::exists(path + "-shm"));
}

// ---- Whole builds ---------------------------------------------------------------------------

// Boundary-surface error of the opened asset against the host at random points (a small
// Table 2): max and 99th percentile relative to the bbox diagonal, and the field error.
TEST(Build, AssetMatchesTheHostAtRandomPoints) {
  BoxHost h(3);
  const std::string path = temp_path("accuracy.cadi");
  const Built r = build(h, small_options(), path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  EXPECT_GT(r.report.elements, 8);
  EXPECT_EQ(r.report.infeasible_elements, 0);

  cadinterp_asset* a = nullptr;
  ASSERT_EQ(cadinterp_open(path.c_str(), &a), CADINTERP_OK) << cadinterp_open_error();
  cadinterp_workspace* ws = nullptr;
  ASSERT_EQ(cadinterp_workspace_create(a, &ws), CADINTERP_OK);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> geo, fld;
  const int fields[2] = {0, 1};
  for (int i = 0; i < 100; ++i) {
    const double x[3] = {u(rng), u(rng), u(rng)};
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(ws, x, fields, 2, &m), CADINTERP_OK) << cadinterp_workspace_error(ws);
    const Sample t = h.truth(x);
    const std::vector<double> V(m.positions, m.positions + 3 * m.vertex_count);
    const std::vector<std::uint32_t> F(m.triangles, m.triangles + 3 * m.triangle_count);
    geo.push_back(mesh::symmetric_hausdorff(V, F, t.vertices, t.triangles) / t.bbox_diagonal());
    // Same combinatorics here, so fields compare value by value.
    double e = 0, range = 0;
    for (std::size_t k = 0; k < m.vertex_count; ++k) {
      e = std::max(e, std::abs(m.fields[0][k] - t.fields[0].values[k]));
      range = std::max(range, std::abs(t.fields[0].values[k]));
    }
    fld.push_back(e / range);
  }
  std::sort(geo.begin(), geo.end());
  std::sort(fld.begin(), fld.end());
  std::printf(
      "[ figures ] box K=3: %d samples, %d elements; geometry max %.2e p99 %.2e; "
      "temperature max %.2e (targets 2e-3, 2e-2)\n",
      r.report.samples, r.report.elements, geo.back(), geo[98], fld.back());
  // The targets hold at the centres and face centres the builder tests; between them the
  // interpolant may exceed them by a small factor.
  EXPECT_LT(geo.back(), 4 * 2e-3);
  EXPECT_LT(fld.back(), 4 * 2e-2);
  cadinterp_workspace_destroy(ws);
  cadinterp_close(a);
  std::filesystem::remove(path);
}

TEST(Build, IsDeterministicAcrossThreadCounts) {
  BoxHost h(2);
  std::vector<std::vector<std::uint8_t>> assets;
  for (int threads : {1, 2, 5}) {
    cadinterp_build_options o = small_options();
    o.threads = threads;
    const std::string path = temp_path("threads" + std::to_string(threads) + ".cadi");
    const Built r = build(h, o, path);
    ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
    assets.push_back(read_bytes(path));
    std::filesystem::remove(path);
  }
  EXPECT_EQ(assets[0], assets[1]);
  EXPECT_EQ(assets[0], assets[2]);
}

TEST(Build, HostFailuresBecomeInfeasibleRegions) {
  for (bool throws : {false, true}) {
    BoxHost h(2);
    h.fail_corner = !throws;
    h.throw_corner = throws;
    const std::string path = temp_path("fail.cadi");
    const Built r = build(h, small_options(), path);
    ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
    EXPECT_GT(r.report.infeasible_points, 0);
    EXPECT_GT(r.report.infeasible_elements, 0);
    // Refused for their failed samples, none for a mapping (the meshes never differ).
    EXPECT_EQ(r.stages.unmapped_elements, 0);
    cadinterp_asset* a = nullptr;
    ASSERT_EQ(cadinterp_open(path.c_str(), &a), CADINTERP_OK);
    cadinterp_workspace* ws = nullptr;
    ASSERT_EQ(cadinterp_workspace_create(a, &ws), CADINTERP_OK);
    cadinterp_mesh m;
    const double bad[2] = {0.95, 0.95}, good[2] = {0.2, 0.3};
    EXPECT_EQ(cadinterp_eval(ws, bad, nullptr, 0, &m), CADINTERP_E_INFEASIBLE);
    // The asset records where the host failed and why.
    ASSERT_EQ(cadinterp_infeasible_point_count(a), r.report.infeasible_points);
    double x[2];
    const char* message = nullptr;
    ASSERT_EQ(cadinterp_infeasible_point(a, 0, x, &message), CADINTERP_OK);
    EXPECT_GT(x[0], 0.75);
    EXPECT_GT(x[1], 0.75);
    EXPECT_NE(std::string(message).find("fillet too large"), std::string::npos) << message;
    EXPECT_EQ(cadinterp_infeasible_point(a, -1, x, &message), CADINTERP_E_INVALID_ARGUMENT);
    EXPECT_EQ(cadinterp_eval(ws, good, nullptr, 0, &m), CADINTERP_OK);
    cadinterp_workspace_destroy(ws);
    cadinterp_close(a);
    std::filesystem::remove(path);
  }
}

TEST(Build, UnmappedCombinatoricsAreReportedNotBlended) {
  BoxHost h(2);
  h.vary_resolution = true;
  const std::string path = temp_path("vary.cadi");
  const Built r = build(h, small_options(), path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  // Elements whose samples straddle x0 = 0.5 differ in combinatorics, and the box host gives no
  // control points, so the mesh mapper (paper §6 matches meshes through references only) refuses
  // them: they become infeasible with its message, never blended vertex by vertex.
  EXPECT_GT(r.report.infeasible_elements, 0);
  EXPECT_LT(r.report.infeasible_elements, r.report.elements);
  // Every sample is feasible: each refused element is refused for a mapping.
  EXPECT_EQ(r.report.infeasible_points, 0);
  EXPECT_EQ(r.stages.unmapped_elements, r.report.infeasible_elements);
  std::filesystem::remove(path);

  // The same through build(): each infeasible element carries the mapper's message, whichever
  // mapper it is.
  struct Refusing final : mesh::Mapper {
    bool map(const Sample&, const Sample&, mesh::MappedSample&, std::string& why) const override {
      why = "refused by the test mapper";
      return false;
    }
    const char* name() const override { return "refusing"; }
  } refusing;
  const mesh::Host host(h.host);
  for (const mesh::Mapper* mapper :
       {&builder::default_mapper(), static_cast<const mesh::Mapper*>(&refusing)}) {
    builder::BuildOptions o;
    o.geometry_tolerance = 2e-3;
    o.field_tolerance = 2e-2;
    o.max_samples = 60;
    o.threads = 2;
    o.mapper = mapper;
    const builder::BuildResult b = builder::build(host, o);
    EXPECT_GT(b.report.infeasible_elements, 0);
    ASSERT_FALSE(b.infeasible.empty());
    const std::string expected =
        mapper == &refusing ? "refused by the test mapper" : "no control point with the same ID";
    // ... and names the failing term's sample, so that the pair can be mapped again alone.
    for (const builder::InfeasiblePoint& p : b.infeasible) {
      EXPECT_NE(p.message.find(expected), std::string::npos) << p.message;
      EXPECT_NE(p.message.find(", term sample at ("), std::string::npos) << p.message;
    }
  }
}

TEST(Build, RejectsBadArgumentsWithNamedErrors) {
  BoxHost h(2);
  // A failed create sets *out to NULL, whatever it held before.
  int not_a_builder = 0;
  cadinterp_builder* const stale = reinterpret_cast<cadinterp_builder*>(&not_a_builder);
  cadinterp_builder* b = stale;
  cadinterp_build_options o = small_options();
  o.degree = 2;
  EXPECT_EQ(cadinterp_builder_create(&h.host, &o, &b), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(cadinterp_builder_create_error()).find("degree"), std::string::npos);
  // The deprecated name, kept for one release, gives the same message.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
  EXPECT_STREQ(cadinterp_builder_open_error(), cadinterp_builder_create_error());
#pragma GCC diagnostic pop
  EXPECT_EQ(b, nullptr);
  b = stale;
  EXPECT_EQ(cadinterp_builder_create(nullptr, nullptr, &b), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(b, nullptr);
  EXPECT_EQ(cadinterp_builder_create(&h.host, nullptr, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  cadinterp_host bad = h.host;
  bad.regenerate = nullptr;
  b = stale;
  EXPECT_EQ(cadinterp_builder_create(&bad, nullptr, &b), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(b, nullptr);
  std::vector<cadinterp_parameter_desc> p = h.params;
  p[1].upper = p[1].lower;
  bad = h.host;
  bad.parameters = p.data();
  EXPECT_EQ(cadinterp_builder_create(&bad, nullptr, &b), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(cadinterp_builder_create_error()).find("twist"), std::string::npos);
  ASSERT_EQ(cadinterp_builder_create(&h.host, nullptr, &b), CADINTERP_OK);
  EXPECT_EQ(cadinterp_builder_run(b, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_builder_run(b, "/nonexistent-dir/x.cadi"), CADINTERP_E_IO)
      << cadinterp_builder_error(b);
  // Refused before the build: the message names the file, and the host was never called.
  EXPECT_NE(std::string(cadinterp_builder_error(b)).find("/nonexistent-dir/x.cadi.tmp"),
            std::string::npos)
      << cadinterp_builder_error(b);
  cadinterp_build_report rep;
  std::memset(&rep, 0, sizeof rep);
  EXPECT_EQ(cadinterp_builder_report(b, &rep), CADINTERP_E_INVALID_ARGUMENT);  // no struct_size
  rep.struct_size = sizeof rep;
  ASSERT_EQ(cadinterp_builder_report(b, &rep), CADINTERP_OK);
  EXPECT_EQ(rep.struct_size, sizeof rep);
  EXPECT_EQ(rep.host_evaluations, 0);
  cadinterp_builder_destroy(b);
  cadinterp_builder_destroy(nullptr);
}

TEST(Build, ProgressCanCancelAndTheStoreKeepsTheWork) {
  BoxHost h(2);
  const std::string store = temp_path("cancel.sqlite"), path = temp_path("cancel.cadi");
  std::filesystem::remove(store);
  cadinterp_build_options o = small_options();
  o.store_path = store.c_str();
  int seen = 0;
  o.progress_user = &seen;
  o.progress = [](void* user, const cadinterp_progress* p) {
    ++*static_cast<int*>(user);
    return p->samples_done >= 12 ? 1 : 0;
  };
  Built r = build(h, o, path);
  EXPECT_EQ(r.status, CADINTERP_E_CANCELLED) << r.error;
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_GT(seen, 0);
  const int first = h.calls.load();
  EXPECT_GE(first, 12);

  o.progress = nullptr;
  r = build(h, o, path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  EXPECT_EQ(r.report.store_hits, first);  // nothing finished is evaluated again
  EXPECT_EQ(h.calls.load(), first + r.report.host_evaluations);

  // The same store for another parameter box is refused by name.
  BoxHost other(2);
  other.params[0].upper = 2.0;
  r = build(other, o, path);
  EXPECT_EQ(r.status, CADINTERP_E_STORE_MISMATCH) << r.error;
  std::filesystem::remove(store);
  std::filesystem::remove(path);
}

std::set<std::string> logged_points(const std::string& log, std::size_t from_line,
                                    std::vector<std::string>* lines_out) {
  std::ifstream f(log);
  std::string line;
  std::set<std::string> out;
  for (std::size_t n = 0; std::getline(f, line); ++n) {
    if (n < from_line) continue;
    out.insert(line);
    if (lines_out) lines_out->push_back(line);
  }
  return out;
}

std::string key_text(const std::vector<double>& x) {
  std::string s;
  char buf[40];
  for (double v : x) {
    std::snprintf(buf, sizeof buf, "%a ", v);
    s += buf;
  }
  return s;
}

// kill -9 at random moments, resume, repeat: the final asset equals an uninterrupted build's byte
// for byte, and no point that was in the store when a run started is evaluated by that run.
TEST(Build, ResumesAfterKillWithoutRepeatingFinishedSamples) {
  const std::string ref_path = temp_path("ref.cadi"), path = temp_path("resumed.cadi");
  const std::string store = temp_path("resume.sqlite"), log = temp_path("resume.log");
  for (const auto& p : {ref_path, path, store, log}) std::filesystem::remove(p);
  cadinterp_build_options o = small_options();
  {
    BoxHost h(2);
    ASSERT_EQ(build(h, o, ref_path).status, CADINTERP_OK);
  }
  o.store_path = store.c_str();
  std::mt19937 rng(5);
  int kills = 0, repeated = 0, runs = 0;
  std::size_t log_lines = 0;
  for (bool finished = false; !finished && runs < 40; ++runs) {
    std::set<std::string> before;
    if (std::filesystem::exists(store)) {
      BoxHost h(2);
      builder::SampleStore s(store, builder::store_fingerprint(mesh::Host(h.host)));
      for (const auto& k : s.keys()) before.insert(key_text(k));
    }
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      BoxHost h(2);
      h.log_path = log;
      h.sleep_ms = 10;
      _exit(build(h, o, path).status == CADINTERP_OK ? 0 : 3);
    }
    const bool kill_it = kills < 6;
    if (kill_it) {
      std::this_thread::sleep_for(
          std::chrono::milliseconds(std::uniform_int_distribution<int>(20, 150)(rng)));
      ::kill(pid, SIGKILL);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (WIFSIGNALED(status)) {
      ++kills;
    } else {
      ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
      finished = true;
    }
    std::vector<std::string> calls;
    logged_points(log, log_lines, &calls);
    log_lines += calls.size();
    for (const auto& c : calls) repeated += before.count(c) ? 1 : 0;
  }
  std::printf("[ figures ] resume: %d kills, %d runs, %zu host calls in all, %d repeated\n", kills,
              runs, log_lines, repeated);
  EXPECT_GE(kills, 3);
  EXPECT_EQ(repeated, 0);
  EXPECT_EQ(read_bytes(path), read_bytes(ref_path));
  for (const auto& p : {ref_path, path, store, log}) std::filesystem::remove(p);
}

// ---- The report of a build, failed or not ----------------------------------------------------

// The points the host was called at, parsed back from its own log (independent of the builder).
std::vector<std::vector<double>> logged_calls(const std::string& log) {
  std::vector<std::vector<double>> out;
  std::ifstream f(log);
  std::string line;
  while (std::getline(f, line)) {
    std::vector<double> x;
    const char* p = line.c_str();
    for (char* end = nullptr;; p = end) {
      const double v = std::strtod(p, &end);
      if (end == p) break;
      x.push_back(v);
    }
    out.push_back(std::move(x));
  }
  return out;
}

bool in_fail_corner(const std::vector<double>& x) { return x[0] > 0.75 && x[1] > 0.75; }

builder::BuildOptions small_build_options() {
  builder::BuildOptions o;
  o.geometry_tolerance = 2e-3;
  o.field_tolerance = 2e-2;
  o.max_samples = 120;
  o.max_depth = 6;
  o.threads = 2;
  return o;
}

// Every point of the box lies in the host's failing corner (its regeneration refuses there, as
// a CAD host refuses a fillet too large): the build fails, and its report still says how many
// points were asked for and evaluated, that all were infeasible and why, and where the time
// went; the counts agree with the host's own log of its calls.
TEST(BuildReport, SaysWhatAnAllInfeasibleBuildDidAndWhy) {
  for (bool throws : {false, true}) {
    BoxHost h(2);
    h.fail_corner = !throws;
    h.throw_corner = throws;
    h.log_path = temp_path("all_infeasible.log");
    std::filesystem::remove(h.log_path);
    h.params[0].lower = 0.8;  // the box is now inside the corner x0, x1 > 0.75
    h.params[1].lower = 0.8;
    const mesh::Host host(h.host);
    builder::BuildReport rep;
    rep.counts.samples = -7;  // overwritten: the report starts afresh
    std::string what;
    try {
      builder::build(host, small_build_options(), &rep);
    } catch (const builder::BuildInfeasible& e) {
      what = e.what();
    }
    const std::string host_message =
        throws ? "regenerate threw: fillet too large"
               : "regenerate failed (status " + std::to_string(CADINTERP_E_INFEASIBLE);
    ASSERT_NE(what.find("failed at every sample point"), std::string::npos) << what;
    EXPECT_NE(what.find(host_message), std::string::npos) << what;
    EXPECT_EQ(rep.failure, what);
    if (!throws) std::printf("[ message ] %s\n", what.c_str());

    const std::vector<std::vector<double>> calls = logged_calls(h.log_path);
    const int n = static_cast<int>(calls.size());
    ASSERT_GE(n, 3);  // at least the box's corners and centre
    EXPECT_EQ(h.calls.load(), n);
    EXPECT_EQ(rep.points_requested, n);
    EXPECT_EQ(rep.counts.host_evaluations, n);
    EXPECT_EQ(rep.counts.store_hits, 0);
    EXPECT_EQ(rep.counts.infeasible_points, n);
    EXPECT_GE(rep.counts.samples, 1);
    EXPECT_LE(rep.counts.samples, n);
    EXPECT_GE(rep.counts.elements, 1);
    EXPECT_EQ(rep.counts.stored_meshes, 0);
    EXPECT_NE(what.find(std::to_string(n) + " points"), std::string::npos) << what;
    // One reason, the host's message, counted at every point; its first point was called.
    ASSERT_EQ(rep.infeasible_reasons.size(), 1u);
    const builder::BuildReport::Reason& why = rep.infeasible_reasons[0];
    EXPECT_EQ(why.message.find(host_message), 0u) << why.message;
    EXPECT_NE(why.message.find("fillet too large"), std::string::npos) << why.message;
    EXPECT_EQ(why.count, n);
    EXPECT_EQ(rep.other_infeasible_points, 0);
    EXPECT_NE(std::find(calls.begin(), calls.end(), why.first_x), calls.end());
    EXPECT_TRUE(rep.element_reasons.empty());
    // Time per stage: the host ran (sampling), the refinement ran; stages add up to no more
    // than the whole call.
    EXPECT_GT(rep.counts.host_seconds, 0.0);
    EXPECT_GT(rep.sampling_seconds, 0.0);
    EXPECT_GE(rep.refinement_seconds, 0.0);
    EXPECT_GE(rep.elements_seconds, 0.0);
    EXPECT_EQ(rep.store_seconds, 0.0);  // no store
    EXPECT_LE(rep.sampling_seconds + rep.refinement_seconds + rep.elements_seconds,
              rep.counts.wall_seconds * (1 + 1e-9));

    // Through the C ABI: the same status and message, and the C report, the stages and the
    // reasons still say what the failed run did.
    const std::string path = temp_path("all_infeasible.cadi");
    cadinterp_build_options o = small_options();
    cadinterp_builder* b = nullptr;
    ASSERT_EQ(cadinterp_builder_create(&h.host, &o, &b), CADINTERP_OK);
    EXPECT_EQ(cadinterp_builder_run(b, path.c_str()), CADINTERP_E_INFEASIBLE);
    EXPECT_NE(std::string(cadinterp_builder_error(b)).find("fillet too large"), std::string::npos)
        << cadinterp_builder_error(b);
    EXPECT_FALSE(std::filesystem::exists(path));
    cadinterp_build_report c{};
    c.struct_size = sizeof c;
    ASSERT_EQ(cadinterp_builder_report(b, &c), CADINTERP_OK);
    EXPECT_GE(c.host_evaluations, 3);
    EXPECT_EQ(c.infeasible_points, c.host_evaluations);
    EXPECT_GE(c.samples, 1);
    EXPECT_GT(c.wall_seconds, 0.0);
    cadinterp_build_stages st;
    std::memset(&st, 0, sizeof st);
    st.struct_size = sizeof st;
    ASSERT_EQ(cadinterp_builder_stages(b, &st), CADINTERP_OK);
    EXPECT_EQ(st.points_requested, c.host_evaluations);
    EXPECT_EQ(st.infeasible_reasons, 1);
    EXPECT_GT(st.sampling_seconds, 0.0);
    EXPECT_EQ(st.write_seconds, 0.0);                      // nothing was written
    ASSERT_NE(st.first_mapped_simulate_failure, nullptr);  // "" when none: never NULL
    EXPECT_STREQ(st.first_mapped_simulate_failure, "");
    const char* msg = nullptr;
    int count = 0;
    ASSERT_EQ(cadinterp_builder_infeasible_reason(b, 0, &msg, &count), CADINTERP_OK);
    EXPECT_NE(std::string(msg).find("fillet too large"), std::string::npos) << msg;
    EXPECT_EQ(count, c.infeasible_points);
    EXPECT_EQ(cadinterp_builder_infeasible_reason(b, 1, &msg, &count),
              CADINTERP_E_INVALID_ARGUMENT);
    // A caller compiled against a smaller struct gets only the bytes it knows.
    cadinterp_build_stages small;
    std::memset(&small, 0xab, sizeof small);
    small.struct_size = offsetof(cadinterp_build_stages, infeasible_reasons);
    ASSERT_EQ(cadinterp_builder_stages(b, &small), CADINTERP_OK);
    EXPECT_EQ(small.points_requested, st.points_requested);
    unsigned char untouched;
    std::memcpy(&untouched, reinterpret_cast<const unsigned char*>(&small) + small.struct_size, 1);
    EXPECT_EQ(untouched, 0xab);
    // The same for the report: a shorter struct gets its own bytes and nothing past them.
    cadinterp_build_report short_report;
    std::memset(&short_report, 0xab, sizeof short_report);
    short_report.struct_size = offsetof(cadinterp_build_report, infeasible_points);
    ASSERT_EQ(cadinterp_builder_report(b, &short_report), CADINTERP_OK);
    EXPECT_EQ(short_report.struct_size, offsetof(cadinterp_build_report, infeasible_points));
    EXPECT_EQ(short_report.host_evaluations, c.host_evaluations);
    EXPECT_EQ(short_report.store_hits, c.store_hits);
    std::memcpy(&untouched,
                reinterpret_cast<const unsigned char*>(&short_report) + short_report.struct_size,
                1);
    EXPECT_EQ(untouched, 0xab);
    cadinterp_builder_destroy(b);
    std::filesystem::remove(h.log_path);
  }
}

// A build with failures in part of the box succeeds; its reasons count exactly the host's calls
// in the failing corner (from the host's log), and the report equals the C one.
TEST(BuildReport, CountsReasonsOfAPartlyInfeasibleBuild) {
  BoxHost h(2);
  h.fail_corner = true;
  h.log_path = temp_path("partly.log");
  std::filesystem::remove(h.log_path);
  builder::BuildReport rep;
  const builder::BuildResult b = builder::build(mesh::Host(h.host), small_build_options(), &rep);
  const std::vector<std::vector<double>> calls = logged_calls(h.log_path);
  const int failing = static_cast<int>(std::count_if(calls.begin(), calls.end(), in_fail_corner));
  ASSERT_GT(failing, 0);
  ASSERT_LT(failing, static_cast<int>(calls.size()));
  EXPECT_TRUE(rep.failure.empty()) << rep.failure;
  EXPECT_EQ(rep.points_requested, static_cast<int>(calls.size()));
  EXPECT_EQ(rep.counts.host_evaluations, static_cast<int>(calls.size()));
  EXPECT_EQ(rep.counts.infeasible_points, failing);
  ASSERT_EQ(rep.infeasible_reasons.size(), 1u);
  EXPECT_EQ(rep.infeasible_reasons[0].count, failing);
  EXPECT_TRUE(in_fail_corner(rep.infeasible_reasons[0].first_x));
  EXPECT_NE(rep.infeasible_reasons[0].message.find("fillet too large"), std::string::npos);
  // The same report in the result, its C part field for field.
  EXPECT_EQ(b.details.points_requested, rep.points_requested);
  EXPECT_EQ(b.details.infeasible_reasons.size(), 1u);
  EXPECT_EQ(b.report.samples, rep.counts.samples);
  EXPECT_EQ(b.report.elements, rep.counts.elements);
  EXPECT_EQ(b.report.infeasible_points, rep.counts.infeasible_points);
  EXPECT_EQ(b.report.infeasible_elements, rep.counts.infeasible_elements);
  EXPECT_EQ(b.report.stored_meshes, rep.counts.stored_meshes);
  EXPECT_EQ(b.report.wall_seconds, rep.counts.wall_seconds);
  EXPECT_GT(rep.counts.stored_meshes, 0);
  EXPECT_GT(rep.counts.elements, rep.counts.infeasible_elements);
  EXPECT_GT(rep.elements_seconds, 0.0);
  std::filesystem::remove(h.log_path);
}

// A store that cannot be opened (its directory does not exist) and a cancelled build: the report
// names the failure and keeps what was done before it.
TEST(BuildReport, IsFilledWhenTheStoreFailsOrTheBuildIsCancelled) {
  BoxHost h(2);
  const mesh::Host host(h.host);
  builder::BuildOptions o = small_build_options();
  o.store_path = "/nonexistent-cadinterp-dir/store.sqlite";
  builder::BuildReport rep;
  EXPECT_THROW(builder::build(host, o, &rep), builder::StoreError);
  EXPECT_EQ(rep.failure.find("sample store: open"), 0u) << rep.failure;
  EXPECT_NE(rep.failure.find(o.store_path), std::string::npos) << rep.failure;
  EXPECT_EQ(rep.counts.host_evaluations, 0);
  EXPECT_EQ(rep.points_requested, 0);
  EXPECT_EQ(h.calls.load(), 0);
  EXPECT_GT(rep.counts.wall_seconds, 0.0);
  EXPECT_GE(rep.store_seconds, 0.0);

  o.store_path.clear();
  int seen = 0;
  o.progress = [&seen](const cadinterp_progress& p) {
    ++seen;
    return p.samples_done >= 6;
  };
  EXPECT_THROW(builder::build(host, o, &rep), builder::BuildCancelled);
  EXPECT_EQ(rep.failure, "build cancelled");
  EXPECT_GE(rep.counts.host_evaluations, 6);
  EXPECT_EQ(rep.counts.host_evaluations, h.calls.load());
  EXPECT_GE(rep.points_requested, rep.counts.host_evaluations);
  EXPECT_EQ(rep.counts.infeasible_points, 0);
  EXPECT_TRUE(rep.infeasible_reasons.empty());
  EXPECT_GT(rep.sampling_seconds, 0.0);
  EXPECT_GT(seen, 0);
}

// The element stage asks the callback too (between terms, on the calling thread): cancelled at
// the last call of a whole build, the build stops after its sampling finished, with every sample
// evaluated and no asset.
TEST(BuildReport, TheElementStageCanBeCancelled) {
  BoxHost h(2);
  const mesh::Host host(h.host);
  builder::BuildOptions o = small_build_options();
  o.threads = 1;  // one thread: the same calls in the same order on both builds
  int seen = 0, cancel_at = -1, after_sampling = 0;
  o.progress = [&](const cadinterp_progress& p) {
    after_sampling += p.samples_queued == 0 ? 1 : 0;
    return ++seen == cancel_at;
  };
  builder::BuildReport whole;
  builder::build(host, o, &whole);
  ASSERT_GT(whole.counts.elements, 1);
  EXPECT_GT(after_sampling, whole.counts.elements);  // at least one call per element
  cancel_at = seen;
  seen = 0;
  builder::BuildReport rep;
  EXPECT_THROW(builder::build(host, o, &rep), builder::BuildCancelled);
  EXPECT_EQ(seen, cancel_at);
  EXPECT_EQ(rep.failure, "build cancelled");
  EXPECT_EQ(rep.counts.elements, whole.counts.elements);
  EXPECT_EQ(rep.counts.host_evaluations, whole.counts.host_evaluations);
  EXPECT_GT(rep.elements_seconds, 0.0);
}

}  // namespace
