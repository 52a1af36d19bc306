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
  cadinterp_build_stages stages{};
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
  d.stages.struct_size = sizeof d.stages;
  cadinterp_builder_stages(b, &d.stages);
  d.stages.first_mapped_simulate_failure = nullptr;  // the builder's string goes with it
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

// simulate_mapped through a session: the mapped meshes come back as SIMULATE requests.
TEST(BuildSession, SimulateMappedRequestsGiveTheCallbackBuildsBytes) {
  const cadinterp_host* h = analytic("plate", "edge=16");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 24;
  o.canonical_refinement = 0;
  o.threads = 2;
  o.simulate_mapped = 1;
  const std::string ref = temp_path("sim_ref.cadi"), a = temp_path("sim_a.cadi");
  const auto r = cadinterp::builder::build_asset(*h, o, ref);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  ASSERT_GT(r.stages.mapped_simulated, 0);
  const Driven d = drive_session(*h, o, a, 3, Order::Shuffled);
  // One request per simulated term (the counts vary by a few between runs: two refinement
  // tests may map the same pair at once, and both simulate it; mesh_problem.h).
  EXPECT_GT(d.simulate_requests, 0);
  EXPECT_GE(d.simulate_requests, d.stages.mapped_simulated);
  EXPECT_LE(d.simulate_requests, d.stages.mapped_simulated + d.stages.mapped_simulate_failures);
  EXPECT_EQ(bytes_of(a), bytes_of(ref));
  for (const auto& p : {ref, a}) std::filesystem::remove(p);
}

// A host that must be called from the thread that created it (a CAD kernel's apartment): every
// callback checks its thread.
struct ThreadBoundHost {
  const cadinterp_host* inner = nullptr;
  std::thread::id owner = std::this_thread::get_id();
  std::atomic<int> calls{0}, foreign{0};
  cadinterp_host host{};

  explicit ThreadBoundHost(const cadinterp_host* h) : inner(h) {
    host = *h;
    host.user = this;
    host.regenerate = [](void* u, const double* x, cadinterp_sample* out) {
      auto* t = static_cast<ThreadBoundHost*>(u);
      t->check();
      return t->inner->regenerate(t->inner->user, x, out);
    };
    host.references = [](void* u, const double* x, cadinterp_sample* out) {
      auto* t = static_cast<ThreadBoundHost*>(u);
      t->check();
      return t->inner->references(t->inner->user, x, out);
    };
    host.simulate = [](void* u, const double* x, const cadinterp_host_mesh* m,
                       cadinterp_sample* out) {
      auto* t = static_cast<ThreadBoundHost*>(u);
      t->check();
      return t->inner->simulate(t->inner->user, x, m, out);
    };
  }
  void check() {
    ++calls;
    if (std::this_thread::get_id() != owner) ++foreign;
  }
};

TEST(BuildSession, CallingThreadModeCallsTheHostOnlyFromTheCallingThread) {
  const cadinterp_host* h = analytic("plate", "edge=16");
  ASSERT_NE(h, nullptr);
  ThreadBoundHost bound(h);
  ASSERT_TRUE(bound.host.thread_safe);  // the builder may not lean on a serializing host
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 24;
  o.canonical_refinement = 0;
  o.threads = 4;
  o.simulate_mapped = 1;
  std::atomic<int> progress_foreign{0};
  struct P {
    std::thread::id owner;
    std::atomic<int>* foreign;
  } pu{std::this_thread::get_id(), &progress_foreign};
  o.progress_user = &pu;
  o.progress = [](void* u, const cadinterp_progress*) {
    auto* p = static_cast<P*>(u);
    if (std::this_thread::get_id() != p->owner) ++*p->foreign;
    return 0;
  };
  const std::string ref = temp_path("ct_ref.cadi"), a = temp_path("ct_a.cadi");
  const auto r = cadinterp::builder::build_asset(*h, o, ref);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  o.host_on_calling_thread = 1;
  const auto c = cadinterp::builder::build_asset(bound.host, o, a);
  ASSERT_EQ(c.status, CADINTERP_OK) << c.error;
  EXPECT_GT(bound.calls.load(), 0);
  EXPECT_EQ(bound.foreign.load(), 0);
  EXPECT_EQ(progress_foreign.load(), 0);
  EXPECT_GT(c.stages.mapped_simulated, 0);
  EXPECT_EQ(c.report.host_evaluations, r.report.host_evaluations);
  EXPECT_EQ(bytes_of(a), bytes_of(ref));
  for (const auto& p : {ref, a}) std::filesystem::remove(p);
}

// A session abandoned after some answers, then a new one on the same store: it asks only for
// the points not stored, and writes the callback build's bytes.
TEST(BuildSession, AbandonedSessionResumesFromItsStore) {
  const cadinterp_host* h = analytic("bracket", "cells=1");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 40;
  o.threads = 2;
  const std::string ref = temp_path("res_ref.cadi"), a = temp_path("res_a.cadi");
  const std::string store = temp_path("res.sqlite");
  std::filesystem::remove(store);
  const auto r = cadinterp::builder::build_asset(*h, o, ref);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  ASSERT_GT(r.report.host_evaluations, 14);
  o.store_path = store.c_str();

  constexpr int kAnswered = 12;
  cadinterp_builder* b = nullptr;
  ASSERT_EQ(cadinterp_builder_create(h, &o, &b), CADINTERP_OK);
  cadinterp_build_session* s = nullptr;
  ASSERT_EQ(cadinterp_build_session_create(b, &s), CADINTERP_OK) << cadinterp_builder_error(b);
  int answered = 0;
  while (answered < kAnswered) {
    cadinterp_build_request req[kAnswered];
    size_t n = 0;
    int done = 0;
    ASSERT_EQ(cadinterp_build_session_next_requests(s, req, kAnswered - answered, -1, &n, &done),
              CADINTERP_OK);
    ASSERT_FALSE(done);
    for (size_t i = 0; i < n; ++i, ++answered)
      ASSERT_EQ(cadinterp_build_session_submit(s, req[i].id, answer_written(*h, s, req[i])),
                CADINTERP_OK);
  }
  cadinterp_build_session_destroy(s);  // abandoned: cancelled, the answers stay stored
  cadinterp_build_report rep{};
  rep.struct_size = sizeof rep;
  ASSERT_EQ(cadinterp_builder_report(b, &rep), CADINTERP_OK);
  EXPECT_EQ(rep.host_evaluations, kAnswered);
  EXPECT_STREQ(cadinterp_builder_error(b), "build cancelled");
  cadinterp_builder_destroy(b);

  const Driven d = drive_session(*h, o, a, 3, Order::Reverse);
  EXPECT_EQ(d.report.store_hits, kAnswered);
  EXPECT_EQ(d.requests, r.report.host_evaluations - kAnswered);
  EXPECT_EQ(d.report.host_evaluations, d.requests);
  EXPECT_EQ(bytes_of(a), bytes_of(ref));
  for (const auto& p : {ref, a, store}) std::filesystem::remove(p);
}

// The progress callback runs on the threads that call the session (here this one) and cancels
// it with a nonzero return; what was answered is in the report.
TEST(BuildSession, ProgressCancelsTheSession) {
  const cadinterp_host* h = analytic("bracket", "cells=1");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 40;
  struct P {
    std::thread::id owner = std::this_thread::get_id();
    int calls = 0, foreign = 0;
  } pu;
  o.progress_user = &pu;
  o.progress = [](void* u, const cadinterp_progress* p) {
    auto* q = static_cast<P*>(u);
    ++q->calls;
    if (std::this_thread::get_id() != q->owner) ++q->foreign;
    return p->samples_done >= 5 ? 1 : 0;
  };
  cadinterp_builder* b = nullptr;
  ASSERT_EQ(cadinterp_builder_create(h, &o, &b), CADINTERP_OK);
  cadinterp_build_session* s = nullptr;
  ASSERT_EQ(cadinterp_build_session_create(b, &s), CADINTERP_OK);
  int answered = 0;
  for (;;) {
    cadinterp_build_request r[2];
    size_t n = 0;
    int done = 0;
    ASSERT_EQ(cadinterp_build_session_next_requests(s, r, 2, -1, &n, &done), CADINTERP_OK);
    if (done) break;
    for (size_t i = 0; i < n; ++i)
      if (cadinterp_build_session_submit(s, r[i].id, answer_written(*h, s, r[i])) == CADINTERP_OK)
        ++answered;
  }
  EXPECT_EQ(cadinterp_build_session_finish(s, temp_path("cancelled.cadi").c_str()),
            CADINTERP_E_CANCELLED);
  cadinterp_build_session_destroy(s);
  cadinterp_build_report rep{};
  rep.struct_size = sizeof rep;
  ASSERT_EQ(cadinterp_builder_report(b, &rep), CADINTERP_OK);
  EXPECT_EQ(answered, 5);
  EXPECT_EQ(rep.host_evaluations, 5);
  EXPECT_GE(pu.calls, 5);
  EXPECT_EQ(pu.foreign, 0);
  cadinterp_builder_destroy(b);
}

TEST(BuildSession, RefusesBadCallsWithNamedStatuses) {
  const cadinterp_host* h = analytic("bracket", "cells=1");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 20;
  const std::string path = temp_path("err.cadi");
  cadinterp_builder* b = nullptr;
  ASSERT_EQ(cadinterp_builder_create(h, &o, &b), CADINTERP_OK);
  cadinterp_build_session* s = reinterpret_cast<cadinterp_build_session*>(&o);
  EXPECT_EQ(cadinterp_build_session_create(nullptr, &s), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(s, nullptr);
  EXPECT_EQ(cadinterp_build_session_create(b, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  ASSERT_EQ(cadinterp_build_session_create(b, &s), CADINTERP_OK);
  cadinterp_build_session* second = nullptr;
  EXPECT_EQ(cadinterp_build_session_create(b, &second), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(second, nullptr);
  EXPECT_EQ(cadinterp_builder_run(b, path.c_str()), CADINTERP_E_INVALID_ARGUMENT);

  cadinterp_build_request req[4];
  size_t n = 0;
  int done = 0;
  EXPECT_EQ(cadinterp_build_session_next_requests(nullptr, req, 4, 0, &n, &done),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_next_requests(s, nullptr, 4, 0, &n, &done),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_next_requests(s, req, 4, 0, nullptr, &done),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_next_requests(s, req, 4, 0, &n, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  ASSERT_EQ(cadinterp_build_session_next_requests(s, req, 2, -1, &n, &done), CADINTERP_OK);
  ASSERT_EQ(n, 2u);
  EXPECT_NE(req[0].id, 0u);
  EXPECT_NE(req[0].id, req[1].id);
  EXPECT_EQ(req[0].kind, CADINTERP_REQUEST_SAMPLE);
  EXPECT_EQ(req[0].mesh, nullptr);

  cadinterp_sample* out = nullptr;
  const uint64_t unknown = req[0].id + req[1].id + 1000;
  EXPECT_EQ(cadinterp_build_session_sample(s, unknown, &out), CADINTERP_E_NOT_FOUND);
  EXPECT_EQ(cadinterp_build_session_sample(s, req[0].id, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_sample(nullptr, req[0].id, &out), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_submit(s, unknown, CADINTERP_OK), CADINTERP_E_NOT_FOUND);
  EXPECT_EQ(cadinterp_build_session_submit(nullptr, req[0].id, CADINTERP_OK),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_submit_serialized(s, req[0].id, nullptr, 0),
            CADINTERP_E_INVALID_ARGUMENT);

  // Malformed bytes leave the request open: it is answered properly afterwards.
  const unsigned char junk[7] = {1, 2, 3, 4, 5, 6, 7};
  EXPECT_EQ(cadinterp_build_session_submit_serialized(s, req[0].id, junk, sizeof junk),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_sample(s, req[0].id, &out), CADINTERP_OK);
  // The answer's bytes are kept for a second answer: the request's x is the session's, valid
  // only until the request is answered.
  void* bytes = nullptr;
  size_t size = 0;
  ASSERT_EQ(cadinterp_host_evaluate_serialized(h, req[0].x, &bytes, &size), CADINTERP_OK);
  EXPECT_EQ(cadinterp_build_session_submit_serialized(s, req[0].id, bytes, size), CADINTERP_OK);
  EXPECT_EQ(cadinterp_build_session_submit_serialized(s, req[0].id, bytes, size),
            CADINTERP_E_NOT_FOUND);  // a second answer
  cadinterp_bytes_free(bytes);
  EXPECT_EQ(cadinterp_build_session_submit(s, req[0].id, CADINTERP_OK), CADINTERP_E_NOT_FOUND);
  EXPECT_EQ(cadinterp_build_session_sample(s, req[0].id, &out), CADINTERP_E_NOT_FOUND);

  EXPECT_EQ(cadinterp_build_session_cancel(nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_cancel(s), CADINTERP_OK);
  EXPECT_EQ(cadinterp_build_session_cancel(s), CADINTERP_OK);  // idempotent
  EXPECT_EQ(cadinterp_build_session_submit(s, req[1].id, answer_written(*h, s, req[1])),
            CADINTERP_E_CANCELLED);
  ASSERT_EQ(cadinterp_build_session_next_requests(s, req, 4, -1, &n, &done), CADINTERP_OK);
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(done, 1);
  EXPECT_EQ(cadinterp_build_session_finish(nullptr, path.c_str()), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_finish(s, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_build_session_finish(s, path.c_str()), CADINTERP_E_CANCELLED);
  EXPECT_EQ(cadinterp_build_session_finish(s, path.c_str()), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_STREQ(cadinterp_builder_error(b), "build cancelled");
  cadinterp_build_session_destroy(s);
  cadinterp_build_session_destroy(nullptr);

  // The builder is free again: a run works.
  EXPECT_EQ(cadinterp_builder_run(b, path.c_str()), CADINTERP_OK) << cadinterp_builder_error(b);
  cadinterp_builder_destroy(b);
  std::filesystem::remove(path);

  // A store that cannot be opened fails create itself, and leaves the builder free.
  const std::string bad_store = temp_path("missing_dir") + "/s.sqlite";
  o.store_path = bad_store.c_str();
  ASSERT_EQ(cadinterp_builder_create(h, &o, &b), CADINTERP_OK);
  s = reinterpret_cast<cadinterp_build_session*>(&o);
  EXPECT_EQ(cadinterp_build_session_create(b, &s), CADINTERP_E_IO);
  EXPECT_EQ(s, nullptr);
  EXPECT_NE(std::string(cadinterp_builder_error(b)), "");
  EXPECT_EQ(cadinterp_builder_run(b, path.c_str()), CADINTERP_E_IO);  // not refused as busy
  cadinterp_builder_destroy(b);
}

}  // namespace
