// cadinterp-host-worker and its protocol on their own (host_worker_process.h): the worker's
// answers are the bytes the host gives in process, and a worker that crashes, aborts, hangs,
// leaks or is killed mid-request is reported as such, by the signal's number and name.
#include <gtest/gtest.h>
#include <signal.h>
#include <stdlib.h>

#include <string>
#include <vector>

#include "cadinterp/cadinterp_builder.h"
#include "host_library.h"
#include "host_worker_process.h"

namespace cadinterp::tools {
namespace {

using Read = HostWorker::Read;

WorkerSpec faulty_spec(const std::string& options) {
  WorkerSpec spec;
  spec.executable = HOST_WORKER_EXE;
  spec.library = FAULTY_HOST_SO;
  spec.options = options;
  return spec;
}

// x with the first parameter at fraction t of its range, the others mid-range.
std::vector<double> point(const cadinterp_host& host, double t) {
  std::vector<double> x;
  for (int i = 0; i < host.parameter_count; ++i) {
    const cadinterp_parameter_desc& p = host.parameters[i];
    x.push_back(p.lower + (i == 0 ? t : 0.5) * (p.upper - p.lower));
  }
  return x;
}

std::vector<std::uint8_t> in_process(const cadinterp_host* host, const std::vector<double>& x,
                                     const cadinterp_host_mesh* mesh) {
  void* bytes = nullptr;
  size_t size = 0;
  const cadinterp_status s =
      mesh ? cadinterp_host_simulate_serialized(host, x.data(), mesh, &bytes, &size)
           : cadinterp_host_evaluate_serialized(host, x.data(), &bytes, &size);
  EXPECT_EQ(s, CADINTERP_OK);
  std::vector<std::uint8_t> out(static_cast<std::uint8_t*>(bytes),
                                static_cast<std::uint8_t*>(bytes) + size);
  cadinterp_bytes_free(bytes);
  return out;
}

class HostWorkerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // Sanitized builds: the workers inherit this, so a SIGSEGV stays a signal (CMakeLists.txt).
    if (SANITIZED) setenv("ASAN_OPTIONS", "handle_segv=0:detect_leaks=0", 1);
    analytic_ = library_.load(ANALYTIC_HOST_SO, "", "");
  }
  HostLibrary library_;
  const cadinterp_host* analytic_ = nullptr;
};

TEST_F(HostWorkerTest, AnswersAreTheInProcessBytes) {
  HostWorker worker(faulty_spec("segv=0.9:1"), 10);
  EXPECT_EQ(worker.host_name(), analytic_->name);
  EXPECT_NE(worker.host_identity().find("faulty(segv=0.9:1)"), std::string::npos);
  // Several requests on one worker, each answered with exactly the in-process bytes.
  for (const double t : {0.0, 0.25, 0.5}) {
    const std::vector<double> x = point(*analytic_, t);
    ASSERT_TRUE(worker.send(x, nullptr));
    ASSERT_EQ(wait_for_answer(worker, 10), Read::kResult) << "t=" << t;
    EXPECT_EQ(worker.payload(), in_process(analytic_, x, nullptr)) << "t=" << t;
  }
  // A simulate request carries its mesh: one tet with its four faces.
  const double vertices[] = {0, 0, 0, 10, 0, 0, 0, 10, 0, 0, 0, 10};
  const std::uint32_t tets[] = {0, 1, 2, 3};
  const std::uint32_t triangles[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  const std::int32_t tags[] = {1, 2, 3, 4};
  const cadinterp_host_mesh mesh{4, vertices, 1, tets, 4, triangles, tags};
  const std::vector<double> x = point(*analytic_, 0.75);
  ASSERT_TRUE(worker.send(x, &mesh));
  ASSERT_EQ(wait_for_answer(worker, 10), Read::kResult);
  EXPECT_EQ(worker.payload(), in_process(analytic_, x, &mesh));
  // The faulty window kills the worker, with its signal.
  ASSERT_TRUE(worker.send(point(*analytic_, 0.95), nullptr));
  EXPECT_EQ(wait_for_answer(worker, 10), Read::kClosed);
  EXPECT_EQ(worker.kill_and_reap(), "killed by signal 11 (Segmentation fault)");
}

TEST_F(HostWorkerTest, AbortHangAndLeakEndTheWorker) {
  WorkerSpec spec = faulty_spec("abort=0:0.2,hang=0.3:0.4,leak=0.6:0.7");
  if (!SANITIZED) spec.memory_mb = 64;  // the leak hits this limit, not the machine's memory
  {
    HostWorker worker(spec, 10);
    ASSERT_TRUE(worker.send(point(*analytic_, 0.1), nullptr));
    EXPECT_EQ(wait_for_answer(worker, 10), Read::kClosed);
    EXPECT_EQ(worker.kill_and_reap(), "killed by signal 6 (Aborted)");
  }
  {
    HostWorker worker(spec, 10);
    ASSERT_TRUE(worker.send(point(*analytic_, 0.35), nullptr));
    EXPECT_EQ(wait_for_answer(worker, 0.3), Read::kPending);  // hangs: the time runs out
    EXPECT_EQ(worker.kill_and_reap(), "killed by signal 9 (Killed)");
  }
  if (SANITIZED) return;  // no address-space limit fits ASan's shadow memory
  {
    HostWorker worker(spec, 10);
    ASSERT_TRUE(worker.send(point(*analytic_, 0.65), nullptr));
    EXPECT_EQ(wait_for_answer(worker, 30), Read::kClosed);
    EXPECT_EQ(worker.kill_and_reap(), "killed by signal 6 (Aborted)");
  }
}

TEST_F(HostWorkerTest, WorkerKilledMidRequest) {
  HostWorker worker(faulty_spec("hang=0.4:0.6"), 10);
  ASSERT_TRUE(worker.send(point(*analytic_, 0.5), nullptr));
  EXPECT_EQ(wait_for_answer(worker, 0.2), Read::kPending);
  ASSERT_EQ(kill(worker.pid(), SIGTERM), 0);
  EXPECT_EQ(wait_for_answer(worker, 10), Read::kClosed);
  EXPECT_EQ(worker.kill_and_reap(), "killed by signal 15 (Terminated)");
  // A second worker of the same spec serves the points outside the window.
  HostWorker fresh(faulty_spec("hang=0.4:0.6"), 10);
  const std::vector<double> x = point(*analytic_, 0.2);
  ASSERT_TRUE(fresh.send(x, nullptr));
  ASSERT_EQ(wait_for_answer(fresh, 10), Read::kResult);
  EXPECT_EQ(fresh.payload(), in_process(analytic_, x, nullptr));
}

// The WorkerError message of starting a worker with `spec` ("" when it started).
std::string start_error(const WorkerSpec& spec) {
  try {
    HostWorker w(spec, 10);
  } catch (const WorkerError& e) {
    return e.what();
  }
  return "";
}

TEST_F(HostWorkerTest, BadInputIsNamed) {
  WorkerSpec missing = faulty_spec("");
  missing.executable = "/nonexistent/cadinterp-host-worker";
  const std::string e1 = start_error(missing);
  EXPECT_NE(e1.find("cannot run the host worker /nonexistent/"), std::string::npos) << e1;
  WorkerSpec not_a_library = faulty_spec("");
  not_a_library.library = HOST_WORKER_EXE;  // an executable, not a shared library
  const std::string e2 = start_error(not_a_library);
  EXPECT_NE(e2.find("cannot load host library"), std::string::npos) << e2;
  const std::string e3 = start_error(faulty_spec("segv=nonsense"));
  EXPECT_NE(e3.find("a fault window is not LO:HI"), std::string::npos) << e3;
}

}  // namespace
}  // namespace cadinterp::tools
