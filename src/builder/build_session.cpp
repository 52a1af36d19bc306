// The build session (build_session.h): build() on the session's thread, its host calls turned
// into requests, and the drivers of cadinterp_builder_run over it.
#include "builder/build_session.h"

#include <algorithm>
#include <chrono>
#include <new>
#include <stdexcept>
#include <utility>

#include "format/asset_format.h"

namespace cadinterp::builder {

// One request: what it asks, the sample its answer is written into, and its answer. Heap-held
// (requests_ owns it), so the pointers handed out stay put while the map changes.
struct BuildSession::Req {
  enum class State { Queued, Out, Answering, Answered, Taken };
  std::uint64_t id = 0;
  int kind = CADINTERP_REQUEST_SAMPLE;
  std::vector<double> x;
  Sample mesh;  // SIMULATE: the mesh to simulate on
  cadinterp_host_mesh host_mesh{};
  cadinterp_sample out;
  State state = State::Queued;
  std::size_t index = 0;  // SAMPLE: the point's index in its wave
  Clock::time_point handed_out;
  Sample answer;
};

class BuildSession::SessionExecutor final : public Executor {
 public:
  SessionExecutor(BuildSession& s, int concurrency) : s_(s), concurrency_(concurrency) {}
  bool run(const std::vector<std::vector<double>>& points,
           const std::function<void(std::size_t, Sample&&)>& done,
           const std::function<bool()>& cancelled) override {
    return s_.run_wave(points, done, cancelled);
  }
  Sample simulate(const std::vector<double>& x, const Sample& mesh) override {
    return s_.simulate(x, mesh);
  }
  int concurrency() const override { return concurrency_; }

 private:
  BuildSession& s_;
  int concurrency_;
};

BuildSession::BuildSession(const Host& host, const BuildOptions& options, int concurrency)
    : host_(host), options_(options), user_progress_(options.progress) {
  if (!options_.store && !options_.store_path.empty()) {
    const auto t0 = Clock::now();
    store_ = std::make_unique<SampleStore>(options_.store_path, store_fingerprint(host));
    store_seconds_ = seconds_since(t0);
    options_.store = store_.get();
  }
  exec_ = std::make_unique<SessionExecutor>(*this, std::max(1, concurrency));
  options_.executor = exec_.get();
  options_.progress = [this](const cadinterp_progress& p) { return on_build_progress(p); };
  thread_ = std::thread([this] { build_thread(); });
}

BuildSession::~BuildSession() {
  cancel();
  if (thread_.joinable()) thread_.join();
}

void BuildSession::build_thread() {
  cadinterp_status failure = CADINTERP_OK;
  try {
    result_ = build(host_, options_, &details_);
  } catch (const StoreError& e) {
    failure = e.kind == StoreError::Kind::Io ? CADINTERP_E_IO : CADINTERP_E_STORE_MISMATCH;
    error_ = std::current_exception();
  } catch (const BuildCancelled&) {
    failure = CADINTERP_E_CANCELLED;
    error_ = std::current_exception();
  } catch (const std::bad_alloc&) {
    failure = CADINTERP_E_OUT_OF_MEMORY;
    error_ = std::current_exception();
  } catch (...) {
    failure = CADINTERP_E_INTERNAL;
    error_ = std::current_exception();
  }
  std::lock_guard<std::mutex> lock(mu_);
  ended_ = true;
  store_released_ = true;
  failure_ = failure;
  cv_.notify_all();
}

BuildSession::Req* BuildSession::publish(int kind, const double* x, const Sample* mesh) {
  auto r = std::make_unique<Req>();
  r->id = next_id_++;
  r->kind = kind;
  r->x.assign(x, x + host_.dim());
  if (mesh) {
    Sample& m = r->mesh;
    m.vertices = mesh->vertices;
    m.tets = mesh->tets;
    m.triangles = mesh->triangles;
    m.triangle_tags = mesh->triangle_tags;
    m.feasible = true;
    r->host_mesh = {m.vertex_count(),   m.vertices.data(),  m.tet_count(),         m.tets.data(),
                    m.triangle_count(), m.triangles.data(), m.triangle_tags.data()};
    // The answer carries this mesh, as mesh::Host::simulate's does.
    r->out.sample.vertices = m.vertices;
    r->out.sample.tets = m.tets;
    r->out.sample.triangles = m.triangles;
    r->out.sample.triangle_tags = m.triangle_tags;
    r->out.mesh_set = true;
  }
  Req* raw = r.get();
  requests_.emplace(raw->id, std::move(r));
  queue_.push_back(raw);
  return raw;
}

// Executor::run over requests: publishes the wave, then delivers answers on the build's thread
// as they come (the sampler stores each one), until all are in or the session is cancelled.
// Answers already given are delivered even after a cancel, so the store keeps them.
bool BuildSession::run_wave(const std::vector<std::vector<double>>& points,
                            const std::function<void(std::size_t, Sample&&)>& done,
                            const std::function<bool()>& cancelled) {
  const std::size_t n = points.size();
  if (n == 0) return true;
  std::unique_lock<std::mutex> lock(mu_);
  if (cancelled_) {
    store_released_ = true;
    return false;
  }
  for (std::size_t i = 0; i < n; ++i)
    publish(CADINTERP_REQUEST_SAMPLE, points[i].data(), nullptr)->index = i;
  cv_.notify_all();
  std::size_t delivered = 0;
  const auto deliver_answered = [&] {
    while (!answered_.empty()) {
      Req* r = answered_.front();
      answered_.pop_front();
      lock.unlock();
      done(r->index, std::move(r->answer));
      lock.lock();
      r->state = Req::State::Taken;
      ++delivered;
      cv_.notify_all();
    }
  };
  while (delivered < n && !cancelled_) {
    cv_.wait(lock, [&] { return !answered_.empty() || cancelled_; });
    deliver_answered();
    if (cancelled_) break;
    lock.unlock();
    const bool stop = cancelled && cancelled();
    lock.lock();
    if (stop) cancelled_ = true;  // the sampler's own cancel ends the session too
  }
  // After a cancel no answer is accepted any more (answer() checks under mu_): the ones given
  // before it are delivered, so that the store keeps them.
  deliver_answered();
  if (delivered < n) store_released_ = true;  // the build throws BuildCancelled next
  cv_.notify_all();
  return delivered == n;
}

Sample BuildSession::simulate(const std::vector<double>& x, const Sample& mesh) {
  std::unique_lock<std::mutex> lock(mu_);
  if (cancelled_) throw BuildCancelled();
  Req* r = publish(CADINTERP_REQUEST_SIMULATE, x.data(), &mesh);
  cv_.notify_all();
  cv_.wait(lock, [&] { return r->state == Req::State::Answered || cancelled_; });
  // A request handed out stays allocated after a cancel (its answer may still be being written);
  // the session frees it when it ends.
  if (r->state != Req::State::Answered) throw BuildCancelled();
  Sample s = std::move(r->answer);
  requests_.erase(r->id);
  return s;
}

bool BuildSession::on_build_progress(const cadinterp_progress& p) {
  std::lock_guard<std::mutex> lock(mu_);
  progress_ = p;
  ++progress_seq_;
  return cancelled_;
}

std::size_t BuildSession::next_requests(Request* out, std::size_t capacity, int timeout_ms,
                                        bool& done) {
  std::unique_lock<std::mutex> lock(mu_);
  const auto ready = [&] { return !queue_.empty() || ended_ || cancelled_; };
  if (timeout_ms < 0)
    cv_.wait(lock, ready);
  else if (timeout_ms > 0)
    cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms), ready);
  std::size_t n = 0;
  const auto now = Clock::now();
  while (!cancelled_ && n < capacity && !queue_.empty()) {
    Req* r = queue_.front();
    queue_.pop_front();
    r->state = Req::State::Out;
    r->handed_out = now;
    Request& q = out[n++];
    q.c.id = r->id;
    q.c.kind = r->kind;
    q.c.parameter_count = host_.dim();
    q.c.x = r->x.data();
    q.c.mesh = r->kind == CADINTERP_REQUEST_SIMULATE ? &r->host_mesh : nullptr;
    q.mesh = r->kind == CADINTERP_REQUEST_SIMULATE ? &r->mesh : nullptr;
  }
  done = ended_ || cancelled_;
  return n;
}

cadinterp_sample* BuildSession::sample(std::uint64_t id) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = requests_.find(id);
  return it != requests_.end() && it->second->state == Req::State::Out ? &it->second->out : nullptr;
}

BuildSession::Req* BuildSession::claim(std::uint64_t id) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = requests_.find(id);
  if (it == requests_.end() || it->second->state != Req::State::Out) return nullptr;
  it->second->state = Req::State::Answering;
  return it->second.get();
}

cadinterp_status BuildSession::answer(Req* r, Sample&& s) {
  std::unique_lock<std::mutex> lock(mu_);
  if (cancelled_ || ended_) {
    // Dropped by the build; a sample still goes into the store once the build has let go of it
    // (it leaves its wave at once after a cancel), so that a resumed build does not ask for it
    // again: an evaluation under way when the build was cancelled is not lost.
    if (r->kind == CADINTERP_REQUEST_SAMPLE && store_) {
      cv_.wait(lock, [&] { return store_released_; });
      try {
        store_->put(r->x, s);
      } catch (const StoreError&) {
        return CADINTERP_E_IO;
      }
    }
    return CADINTERP_E_CANCELLED;
  }
  r->answer = std::move(s);
  r->state = Req::State::Answered;
  if (r->kind == CADINTERP_REQUEST_SIMULATE) {
    cv_.notify_all();  // the waiting simulate() takes it and frees the request
    return CADINTERP_OK;
  }
  answered_.push_back(r);
  cv_.notify_all();
  // Returns once the build has taken (and stored) the sample, so that a submit that returned OK
  // is in the store, and a store that cannot be written fails this submit.
  cv_.wait(lock, [&] { return r->state == Req::State::Taken || ended_; });
  if (r->state != Req::State::Taken)
    return failure_ == CADINTERP_E_IO || failure_ == CADINTERP_E_OUT_OF_MEMORY
               ? failure_
               : CADINTERP_E_CANCELLED;
  requests_.erase(r->id);
  return CADINTERP_OK;
}

cadinterp_status BuildSession::submit(std::uint64_t id, Sample&& s) {
  Req* r = claim(id);
  return r ? answer(r, std::move(s)) : CADINTERP_E_NOT_FOUND;
}

cadinterp_status BuildSession::submit_written(std::uint64_t id, cadinterp_status host_status) {
  Req* r = claim(id);
  if (!r) return CADINTERP_E_NOT_FOUND;
  // As mesh::Host's guard does for callbacks: a failure keeps only its message, an answer is
  // validated. host_seconds is the time the request was out (the host's time as seen here).
  Sample s = std::move(r->out.sample);
  std::string err;
  if (host_status != CADINTERP_OK) {
    err = s.message;
    if (err.empty())
      err = host_status > CADINTERP_OK && host_status <= CADINTERP_E_INTERNAL
                ? std::string("the host failed (") +
                      format::status_name(static_cast<format::Status>(host_status)) + ")"
                : "the host failed (status " + std::to_string(static_cast<int>(host_status)) + ")";
  } else if (!r->out.mesh_set) {
    err = "the answer has no mesh (cadinterp_sample_set_mesh was not called)";
  }
  s = mesh::settle(std::move(s), std::move(err));
  s.host_seconds = seconds_since(r->handed_out);
  return answer(r, std::move(s));
}

cadinterp_status BuildSession::submit_serialized(std::uint64_t id, const void* bytes,
                                                 std::size_t size) {
  Req* r = claim(id);
  if (!r) return CADINTERP_E_NOT_FOUND;
  Sample s;
  std::string bad;
  try {
    s = deserialize(static_cast<const std::uint8_t*>(bytes), size);
    if (s.feasible) bad = validate(s);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    bad = e.what();
  }
  if (!bad.empty()) {
    std::lock_guard<std::mutex> lock(mu_);
    r->state = Req::State::Out;  // the request stays open for another answer
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  s.host_seconds = seconds_since(r->handed_out);
  return answer(r, std::move(s));
}

void BuildSession::cancel() {
  std::lock_guard<std::mutex> lock(mu_);
  cancelled_ = true;
  cv_.notify_all();
}

bool BuildSession::report_progress() {
  std::lock_guard<std::mutex> serial(progress_mu_);
  cadinterp_progress p;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!user_progress_ || progress_seq_ == reported_seq_) return cancelled_;
    reported_seq_ = progress_seq_;
    p = progress_;
  }
  if (user_progress_(p)) cancel();
  std::lock_guard<std::mutex> lock(mu_);
  return cancelled_;
}

BuildResult BuildSession::finish(BuildReport& details) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (finished_) throw std::invalid_argument("the session is already finished");
    finished_ = true;
  }
  if (thread_.joinable()) thread_.join();
  details = details_;
  // The store was opened before build() started its clock.
  details.store_seconds += store_seconds_;
  details.counts.wall_seconds += store_seconds_;
  if (error_) std::rethrow_exception(error_);
  return std::move(result_);
}

namespace {

Sample host_answer(const Host& host, const BuildSession::Request& r) {
  return r.c.kind == CADINTERP_REQUEST_SIMULATE ? host.simulate(r.c.x, *r.mesh)
                                                : host.evaluate(r.c.x);
}

}  // namespace

void drive_on_calling_thread(BuildSession& session, const Host& host) {
  std::vector<BuildSession::Request> batch(16);
  for (;;) {
    bool done = false;
    const std::size_t n = session.next_requests(batch.data(), batch.size(), -1, done);
    for (std::size_t i = 0; i < n; ++i) {
      session.submit(batch[i].c.id, host_answer(host, batch[i]));
      session.report_progress();
    }
    if (n == 0) session.report_progress();
    if (n == 0 && done) return;
  }
}

// Workers take requests and evaluate them; the calling thread submits the answers and calls
// the progress callback, as the header promises cadinterp_builder_run's callers.
void drive_with_threads(BuildSession& session, const Host& host, int threads) {
  std::mutex mu;
  std::condition_variable cv;
  std::deque<std::pair<std::uint64_t, Sample>> answers;
  int running = std::max(1, threads);
  std::exception_ptr error;  // std::bad_alloc from Host::evaluate
  auto work = [&] {
    try {
      for (;;) {
        BuildSession::Request r;
        bool done = false;
        if (session.next_requests(&r, 1, -1, done) == 0) {
          if (done) break;
          continue;
        }
        Sample s = host_answer(host, r);
        std::lock_guard<std::mutex> lock(mu);
        answers.emplace_back(r.c.id, std::move(s));
        cv.notify_all();
      }
    } catch (...) {
      session.cancel();
      std::lock_guard<std::mutex> lock(mu);
      if (!error) error = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mu);
    --running;
    cv.notify_all();
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < running; ++t) pool.emplace_back(work);
  for (;;) {
    std::unique_lock<std::mutex> lock(mu);
    // Woken by an answer or the end; every 100 ms the progress of store reads and waves too.
    cv.wait_for(lock, std::chrono::milliseconds(100),
                [&] { return !answers.empty() || running == 0; });
    std::deque<std::pair<std::uint64_t, Sample>> batch;
    batch.swap(answers);
    const bool finished = running == 0;
    lock.unlock();
    try {
      for (auto& a : batch) {
        session.submit(a.first, std::move(a.second));  // refused after a cancel: dropped
        session.report_progress();
      }
      if (batch.empty()) session.report_progress();
    } catch (...) {  // out of memory, or the progress callback threw: the workers still end
      session.cancel();
      std::lock_guard<std::mutex> guard(mu);
      if (!error) error = std::current_exception();
    }
    if (finished && batch.empty()) break;
  }
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace cadinterp::builder
