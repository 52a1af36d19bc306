#include "mpi_driver.h"

#include <mpi.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <deque>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "host_request_codec.h"

namespace cadinterp::tools::mpi {

namespace {

// Message tags. Rank 0 keeps at most one request in flight per rank, so an answer's request is
// known from its source: answers carry the sample's bytes alone (probe for the size, receive).
enum Tag : int {
  kHello = 1,       // rank -> 0: name, identity and K of the host it loaded
  kLoadFailed = 2,  // rank -> 0: why it could not load the host
  kRequest = 3,     // 0 -> rank: a request, request_codec::encode's bytes (host_request_codec.h)
  kResult = 5,      // rank -> 0: the serialized sample
  kFailed = 6,      // rank -> 0: int32 status, then a message (no bytes could be produced)
  kStop = 7         // 0 -> rank: no more requests
};

using Clock = std::chrono::steady_clock;

double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

/// Polls with a growing pause (20 us up to 1 ms) instead of MPI_Probe: Open MPI's blocking calls
/// spin a core, which on a node running more ranks than cores takes it from the ranks that run
/// the host. The pause adds at most 1 ms to an answer, against seconds to minutes per sample.
class Backoff {
 public:
  void reset() { pause_us_ = 20; }
  void pause() {
    std::this_thread::sleep_for(std::chrono::microseconds(pause_us_));
    pause_us_ = std::min(2 * pause_us_, 1000);
  }

 private:
  int pause_us_ = 20;
};

/// Receives the message `status` announced; its bytes go to `buffer` (8-byte aligned storage, so
/// doubles and integers inside can be read in place). Returns the byte count.
std::size_t receive(const MPI_Status& status, std::vector<std::uint64_t>& buffer) {
  int count = 0;
  MPI_Get_count(&status, MPI_BYTE, &count);
  buffer.resize(static_cast<std::size_t>(count) / 8 + 1);
  MPI_Recv(buffer.data(), count, MPI_BYTE, status.MPI_SOURCE, status.MPI_TAG, MPI_COMM_WORLD,
           MPI_STATUS_IGNORE);
  return static_cast<std::size_t>(count);
}

MPI_Status wait_message(int source) {
  Backoff backoff;
  for (;;) {
    int flag = 0;
    MPI_Status status;
    MPI_Iprobe(source, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
    if (flag) return status;
    backoff.pause();
  }
}

void send_bytes(const void* data, std::size_t size, int to, int tag) {
  if (size > static_cast<std::size_t>(INT_MAX))
    throw std::runtime_error("an MPI message of " + std::to_string(size) +
                             " bytes is over the 2 GiB a single send carries");
  MPI_Send(data, static_cast<int>(size), MPI_BYTE, to, tag, MPI_COMM_WORLD);
}

void send_text(const std::string& text, int to, int tag) {
  send_bytes(text.data(), text.size(), to, tag);
}

std::string host_description(const cadinterp_host* host) {
  return std::string(host->name ? host->name : "") + " '" + (host->identity ? host->identity : "") +
         "' (" + std::to_string(host->parameter_count) + " parameters)";
}

struct SessionDestroyer {
  void operator()(cadinterp_build_session* s) const { cadinterp_build_session_destroy(s); }
};

/// Rank 0's side: one request in flight per rank, answers handed to the session as they come.
class Dispatcher {
 public:
  Dispatcher(cadinterp_build_session* session, int ranks)
      : session_(session), in_flight_(static_cast<std::size_t>(ranks), 0) {}

  /// Drives the session until it is done and every rank's answer is in, or *stop is set (its
  /// value is returned; 0 otherwise).
  int run(const volatile std::sig_atomic_t* stop);
  int answers_received() const { return received_; }

 private:
  bool receive_answers();
  bool fetch(int timeout_ms);
  bool dispatch();
  void answer_failure(std::uint64_t id, int source, std::size_t size);
  int busy_ranks() const {
    return static_cast<int>(std::count_if(in_flight_.begin() + 1, in_flight_.end(),
                                          [](std::uint64_t id) { return id != 0; }));
  }
  int idle_ranks() const { return static_cast<int>(in_flight_.size()) - 1 - busy_ranks(); }

  cadinterp_build_session* session_;
  std::vector<std::uint64_t> in_flight_;       // per rank: the request id it works on, 0 when idle
  std::deque<cadinterp_build_request> queue_;  // handed out by the session, not sent yet
  std::vector<std::uint64_t> buffer_;
  bool done_ = false;
  int received_ = 0;
};

int Dispatcher::run(const volatile std::sig_atomic_t* stop) {
  Backoff backoff;
  for (;;) {
    if (*stop) {
      cadinterp_build_session_cancel(session_);
      return static_cast<int>(*stop);
    }
    bool active = receive_answers();
    if (!done_) active = fetch(0) || active;
    active = dispatch() || active;
    if (done_ && busy_ranks() == 0) return 0;
    if (active) {
      backoff.reset();
    } else if (busy_ranks() == 0 && !done_) {
      // Every rank idle: only the builder's own work (mapping, refinement between waves) is
      // pending, so wait on the session itself. The bound keeps *stop checked.
      fetch(20);
    } else {
      backoff.pause();
    }
  }
}

bool Dispatcher::receive_answers() {
  bool any = false;
  for (;;) {
    int flag = 0;
    MPI_Status status;
    MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
    if (!flag) return any;
    any = true;
    const int source = status.MPI_SOURCE;
    const std::size_t size = receive(status, buffer_);
    const std::uint64_t id = in_flight_[static_cast<std::size_t>(source)];
    if (id == 0 || (status.MPI_TAG != kResult && status.MPI_TAG != kFailed))
      throw std::runtime_error("rank " + std::to_string(source) + " sent message " +
                               std::to_string(status.MPI_TAG) + " with no request in flight");
    in_flight_[static_cast<std::size_t>(source)] = 0;
    if (status.MPI_TAG == kFailed) {
      answer_failure(id, source, size);
      continue;
    }
    const cadinterp_status s =
        cadinterp_build_session_submit_serialized(session_, id, buffer_.data(), size);
    if (s == CADINTERP_OK) {
      ++received_;
    } else if (s == CADINTERP_E_INVALID_ARGUMENT) {
      throw std::runtime_error("rank " + std::to_string(source) +
                               " sent bytes that are not a serialized sample (a rank running "
                               "another cadinterp version?)");
    }
    // Any other status: the session was cancelled or failed (it then reports done, and its
    // error says why); the answer is dropped.
  }
}

/// A rank that could produce no bytes (out of memory, a request it could not read): the point
/// becomes infeasible with the rank's message, as a failing host callback would make it.
void Dispatcher::answer_failure(std::uint64_t id, int source, std::size_t size) {
  std::int32_t status = CADINTERP_E_INTERNAL;
  std::string message;
  if (size >= sizeof status) {
    std::memcpy(&status, buffer_.data(), sizeof status);
    message.assign(reinterpret_cast<const char*>(buffer_.data()) + sizeof status,
                   size - sizeof status);
  }
  cadinterp_sample* out = nullptr;
  if (cadinterp_build_session_sample(session_, id, &out) != CADINTERP_OK) return;
  cadinterp_sample_set_message(out, ("rank " + std::to_string(source) + ": " + message).c_str());
  cadinterp_build_session_submit(
      session_, id,
      status == CADINTERP_OK ? CADINTERP_E_INTERNAL : static_cast<cadinterp_status>(status));
}

/// Asks the session for as many requests as there are idle ranks without one queued.
bool Dispatcher::fetch(int timeout_ms) {
  const int want = idle_ranks() - static_cast<int>(queue_.size());
  if (want <= 0 || done_) return false;
  std::vector<cadinterp_build_request> got(static_cast<std::size_t>(want));
  std::size_t n = 0;
  int done = 0;
  cadinterp_build_session_next_requests(session_, got.data(), got.size(), timeout_ms, &n, &done);
  done_ = done != 0;
  queue_.insert(queue_.end(), got.begin(), got.begin() + static_cast<std::ptrdiff_t>(n));
  // Requests of a session that is done were cancelled with it: none will be answered.
  if (done_) queue_.clear();
  return n > 0;
}

bool Dispatcher::dispatch() {
  bool any = false;
  for (std::size_t rank = 1; rank < in_flight_.size() && !queue_.empty(); ++rank) {
    if (in_flight_[rank] != 0) continue;
    const cadinterp_build_request r = queue_.front();
    queue_.pop_front();
    const std::vector<std::uint8_t> bytes =
        request_codec::encode(r.kind, r.x, static_cast<std::size_t>(r.parameter_count), r.mesh);
    send_bytes(bytes.data(), bytes.size(), static_cast<int>(rank), kRequest);
    in_flight_[rank] = r.id;
    any = true;
  }
  return any;
}

/// Every rank says which host it loaded; all must match rank 0's.
void check_ranks(const World& world, const cadinterp_host* host) {
  const std::string mine = host_description(host);
  std::string problems;
  std::vector<std::uint64_t> buffer;
  for (int rank = 1; rank < world.size(); ++rank) {
    const MPI_Status status = wait_message(rank);
    const std::size_t size = receive(status, buffer);
    const std::string text(reinterpret_cast<const char*>(buffer.data()), size);
    if (status.MPI_TAG == kLoadFailed) {
      problems += "\n  rank " + std::to_string(rank) + ": " + text;
    } else if (status.MPI_TAG != kHello || text != mine) {
      problems +=
          "\n  rank " + std::to_string(rank) + " loaded " + text + "\n  rank 0 loaded " + mine;
    }
  }
  if (!problems.empty())
    throw std::runtime_error("every rank must load the same host (library, model, options):" +
                             problems);
}

/// One request on a rank: the serialized sample, or a kFailed message when there are no bytes.
void answer(const cadinterp_host* host, int tag, const std::vector<std::uint64_t>& request,
            std::size_t size) {
  void* bytes = nullptr;
  std::size_t n = 0;
  cadinterp_status s = CADINTERP_E_INVALID_ARGUMENT;
  std::string message = "a message this rank cannot read (another cadinterp version on rank 0?)";
  request_codec::Request decoded;
  const request_codec::DecodeError e =
      tag == kRequest
          ? request_codec::decode(request.data(), size,
                                  static_cast<std::size_t>(host->parameter_count), &decoded)
          : request_codec::DecodeError::kWrongKind;
  if (e != request_codec::DecodeError::kNone) {
    message = std::string(request_codec::describe(e)) + ": " + message;
  } else {
    s = request_codec::answer(*host, decoded, &bytes, &n);
    message = "the host's serialized answer failed";
  }
  if (s == CADINTERP_OK && n <= static_cast<std::size_t>(INT_MAX)) {
    send_bytes(bytes, n, 0, kResult);
  } else {
    if (s == CADINTERP_OK) {
      s = CADINTERP_E_OUT_OF_MEMORY;
      message = "the serialized sample (" + std::to_string(n) +
                " bytes) is over the 2 GiB one MPI message carries";
    } else {
      message = message + ": " + cadinterp_status_string(s);
    }
    std::string payload(sizeof(std::int32_t), '\0');
    const std::int32_t code = s;
    std::memcpy(payload.data(), &code, sizeof code);
    send_text(payload + message, 0, kFailed);
  }
  cadinterp_bytes_free(bytes);
}

}  // namespace

World::World() {
  int provided = 0;
  if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Init_thread failed");
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

World::~World() {
  if (abandoned_) return;
  if (rank_ == 0) stop_workers();
  MPI_Finalize();
}

void World::stop_workers() {
  if (rank_ != 0 || workers_stopped_) return;
  workers_stopped_ = true;
  for (int rank = 1; rank < size_; ++rank)
    MPI_Send(nullptr, 0, MPI_BYTE, rank, kStop, MPI_COMM_WORLD);
}

DriveResult drive(World& world, cadinterp_builder* builder, const cadinterp_host* host,
                  const std::string& output_path, const volatile std::sig_atomic_t* stop) {
  DriveResult result;
  result.worker_ranks = world.size() - 1;
  check_ranks(world, host);
  const auto t0 = Clock::now();
  const double cpu0 = process_cpu_seconds();
  cadinterp_build_session* raw = nullptr;
  result.status = cadinterp_build_session_create(builder, &raw);
  if (result.status != CADINTERP_OK) return result;
  std::unique_ptr<cadinterp_build_session, SessionDestroyer> session(raw);
  Dispatcher dispatcher(session.get(), world.size());
  result.stop_signal = dispatcher.run(stop);
  result.answers_received = dispatcher.answers_received();
  if (result.stop_signal != 0) {
    result.status = CADINTERP_E_CANCELLED;
    // Said before the session is destroyed: mpirun's SIGKILL follows its SIGTERM within a second.
    std::fprintf(stderr,
                 "mpi: stopped by %s (mpirun ends the whole job when a rank dies); %d answers "
                 "from the ranks were accepted in this run\n",
                 result.stop_signal == SIGTERM ? "SIGTERM" : "SIGINT", result.answers_received);
    std::fflush(stderr);
  } else {
    world.stop_workers();
    result.status = cadinterp_build_session_finish(session.get(), output_path.c_str());
    // A signal while the session finished (the progress callback cancels it then).
    if (result.status == CADINTERP_E_CANCELLED) result.stop_signal = static_cast<int>(*stop);
  }
  session.reset();
  result.wall_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  result.cpu_seconds = process_cpu_seconds() - cpu0;
  return result;
}

int serve(const World& world, const cadinterp_host* host, const std::string& load_error) {
  (void)world;
  if (host)
    send_text(host_description(host), 0, kHello);
  else
    send_text(load_error, 0, kLoadFailed);
  std::vector<std::uint64_t> request;
  int answered = 0;
  for (;;) {
    const MPI_Status status = wait_message(0);
    const std::size_t size = receive(status, request);
    if (status.MPI_TAG == kStop) return answered;
    if (!host) continue;  // rank 0 stops a job whose ranks could not all load the host
    answer(host, status.MPI_TAG, request, size);
    ++answered;
  }
}

}  // namespace cadinterp::tools::mpi
