// Build sessions (cadinterp_builder.h, "Build sessions") on the analytic host: driven by several
// threads answering out of order, some answers serialized as a worker process would send them,
// the asset byte-identical to the callback build; simulate_mapped's requests; the calling-thread
// mode; a session abandoned halfway and resumed from its store; and the refusals.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "analytic_host.h"
#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp_builder.h"
#include "mesh/host_call.h"

namespace {

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("cadinterp_session_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

std::vector<char> bytes_of(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(f), {});
}

const cadinterp_host* analytic(const char* model, const char* options) {
  const char* err = nullptr;
  const cadinterp_host* h = cadinterp_host_entry(model, options, &err);
  EXPECT_NE(h, nullptr) << (err ? err : "");
  return h;
}

// The host's answer to one request written into the request's sample, as a host's own loop
// would: regenerate, references and simulate for a SAMPLE, simulate alone for a SIMULATE.
cadinterp_status answer_written(const cadinterp_host& h, cadinterp_build_session* s,
                                const cadinterp_build_request& r) {
  cadinterp_sample* out = nullptr;
  EXPECT_EQ(cadinterp_build_session_sample(s, r.id, &out), CADINTERP_OK);
  if (r.kind == CADINTERP_REQUEST_SIMULATE) return h.simulate(h.user, r.x, r.mesh, out);
  cadinterp_status st = h.regenerate(h.user, r.x, out);
  if (st == CADINTERP_OK && h.references) st = h.references(h.user, r.x, out);
  if (st == CADINTERP_OK && h.simulate) {
    const cadinterp::mesh::Sample& m = out->sample;
    const cadinterp_host_mesh mesh{m.vertex_count(),      m.vertices.data(),  m.tet_count(),
                                   m.tets.data(),         m.triangle_count(), m.triangles.data(),
                                   m.triangle_tags.data()};
    st = h.simulate(h.user, r.x, &mesh, out);
  }
  return st;
}

// The same answer computed "elsewhere" and shipped as bytes.
cadinterp_status submit_serialized(const cadinterp_host& h, cadinterp_build_session* s,
                                   const cadinterp_build_request& r) {
  void* bytes = nullptr;
  size_t size = 0;
  const cadinterp_status made =
      r.kind == CADINTERP_REQUEST_SIMULATE
          ? cadinterp_host_simulate_serialized(&h, r.x, r.mesh, &bytes, &size)
          : cadinterp_host_evaluate_serialized(&h, r.x, &bytes, &size);
  EXPECT_EQ(made, CADINTERP_OK);
  const cadinterp_status st = cadinterp_build_session_submit_serialized(s, r.id, bytes, size);
  cadinterp_bytes_free(bytes);
  return st;
}

enum class Order { Reverse, Shuffled };

struct Driven {
  cadinterp_status status = CADINTERP_E_INTERNAL;
  cadinterp_build_report report{};
  int requests = 0, simulate_requests = 0, serialized = 0;
};

// A session on `h` driven by `threads` threads, each answering the batch it took in `order`;
// every third request is answered with serialized bytes.
Driven drive_session(const cadinterp_host& h, const cadinterp_build_options& o,
                     const std::string& path, int threads, Order order) {
  Driven d;
  cadinterp_builder* b = nullptr;
  EXPECT_EQ(cadinterp_builder_create(&h, &o, &b), CADINTERP_OK) << cadinterp_builder_create_error();
  cadinterp_build_session* s = nullptr;
  EXPECT_EQ(cadinterp_build_session_create(b, &s), CADINTERP_OK) << cadinterp_builder_error(b);
  std::atomic<int> requests{0}, simulates{0}, serialized{0};
  auto work = [&](unsigned seed) {
    std::mt19937 rng(seed);
    for (;;) {
      cadinterp_build_request r[6];
      size_t n = 0;
      int done = 0;
      EXPECT_EQ(cadinterp_build_session_next_requests(s, r, 6, 20, &n, &done), CADINTERP_OK);
      if (n == 0) {
        if (done) return;
        continue;
      }
      std::vector<size_t> idx(n);
      for (size_t i = 0; i < n; ++i) idx[i] = i;
      if (order == Order::Reverse)
        std::reverse(idx.begin(), idx.end());
      else
        std::shuffle(idx.begin(), idx.end(), rng);
      for (size_t i : idx) {
        ++requests;
        if (r[i].kind == CADINTERP_REQUEST_SIMULATE) ++simulates;
        if (r[i].id % 3 == 0) {
          ++serialized;
          EXPECT_EQ(submit_serialized(h, s, r[i]), CADINTERP_OK);
        } else {
          const cadinterp_status st = answer_written(h, s, r[i]);
          EXPECT_EQ(cadinterp_build_session_submit(s, r[i].id, st), CADINTERP_OK);
        }
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work, 17u + static_cast<unsigned>(t));
  for (auto& t : pool) t.join();
  d.status = cadinterp_build_session_finish(s, path.c_str());
  EXPECT_EQ(d.status, CADINTERP_OK) << cadinterp_builder_error(b);
  cadinterp_build_session_destroy(s);
  d.report.struct_size = sizeof d.report;
  cadinterp_builder_report(b, &d.report);
  cadinterp_builder_destroy(b);
  d.requests = requests;
  d.simulate_requests = simulates;
  d.serialized = serialized;
  return d;
}

TEST(BuildSession, OutOfOrderConcurrentAnswersGiveTheCallbackBuildsBytes) {
  const cadinterp_host* h = analytic("bracket", "cells=1");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 40;
  o.threads = 2;
  const std::string ref = temp_path("ref.cadi"), a = temp_path("a.cadi"), c = temp_path("c.cadi");
  const auto r = cadinterp::builder::build_asset(*h, o, ref);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  const Driven reversed = drive_session(*h, o, a, 3, Order::Reverse);
  const Driven shuffled = drive_session(*h, o, c, 4, Order::Shuffled);
  EXPECT_EQ(reversed.requests, r.report.host_evaluations);
  EXPECT_GT(reversed.requests, 10);
  EXPECT_GT(reversed.serialized, 0);
  EXPECT_EQ(shuffled.report.host_evaluations, r.report.host_evaluations);
  EXPECT_EQ(bytes_of(a), bytes_of(ref));
  EXPECT_EQ(bytes_of(c), bytes_of(ref));
  for (const auto& p : {ref, a, c}) std::filesystem::remove(p);
}

}  // namespace
