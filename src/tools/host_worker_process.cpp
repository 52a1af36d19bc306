#include "host_worker_process.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>

#include "host_request_codec.h"
#include "host_worker_protocol.h"

namespace cadinterp::tools {

namespace wp = worker_protocol;

namespace {

using Clock = std::chrono::steady_clock;

std::string describe_wait_status(int status) {
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const char* name = strsignal(sig);
    return "killed by signal " + std::to_string(sig) + " (" + (name ? name : "unknown") + ")";
  }
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  return "ended (wait status " + std::to_string(status) + ")";
}

// Milliseconds left until `deadline` for poll (-1: no deadline), rounded up so that a poll never
// returns just before it.
int poll_ms(bool has_deadline, Clock::time_point deadline) {
  if (!has_deadline) return -1;
  const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return left < 0 ? 0 : static_cast<int>(left);
}

}  // namespace

HostWorker::HostWorker(const WorkerSpec& spec, double startup_seconds) {
  if (access(spec.executable.c_str(), X_OK) != 0)
    throw WorkerError("cannot run the host worker " + spec.executable + ": " +
                      std::strerror(errno) +
                      " (it is installed beside the cadinterp tool; CADINTERP_HOST_WORKER names "
                      "another)");
  std::signal(SIGPIPE, SIG_IGN);
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
    throw WorkerError(std::string("cannot create the worker's socket: ") + std::strerror(errno));
  // Everything the child needs is prepared before fork: after it only async-signal-safe calls.
  std::vector<std::string> args{spec.executable, spec.library, spec.model, spec.options};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  rlimit limit{};
  limit.rlim_cur = limit.rlim_max = static_cast<rlim_t>(spec.memory_mb) << 20;
  const pid_t parent = getpid();
  pid_ = fork();
  if (pid_ < 0) {
    const int e = errno;
    close(sv[0]);
    close(sv[1]);
    throw WorkerError(std::string("cannot start a host worker: ") + std::strerror(e));
  }
  if (pid_ == 0) {
    // The worker dies with the build (even a kill -9 of it), and a Ctrl-C in the terminal goes
    // to the build alone, which stops its workers itself: a worker killed by SIGINT would look
    // like a crashed host.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(126);
    signal(SIGINT, SIG_IGN);
    signal(SIGPIPE, SIG_DFL);
    if (spec.memory_mb > 0) setrlimit(RLIMIT_AS, &limit);
    if (dup2(sv[1], 0) < 0 || dup2(sv[1], 1) < 0) _exit(126);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(sv[1]);
  fd_ = sv[0];
  fcntl(fd_, F_SETFL, fcntl(fd_, F_GETFL) | O_NONBLOCK);
  const std::string problem = wait_hello(startup_seconds);
  if (!problem.empty()) {
    kill_and_reap();
    close(fd_);
    fd_ = -1;
    throw WorkerError(problem);
  }
}

// "" when the worker said hello; else why it is not usable.
std::string HostWorker::wait_hello(double seconds) {
  busy_ = true;  // until the hello, the worker is loading its host
  const Read r = wait_for_answer(*this, seconds);
  if (r == Read::kPending)
    return "the host worker did not start within " + std::to_string(seconds) + " s";
  if (r == Read::kClosed)
    return "the host worker " + std::string(kill_and_reap()) + " before it was ready";
  if (r == Read::kError) return std::string(payload_.begin(), payload_.end());
  const auto nul = std::find(payload_.begin(), payload_.end(), std::uint8_t{0});
  if (nul == payload_.end()) return "the host worker's hello is malformed";
  name_.assign(payload_.begin(), nul);
  identity_.assign(nul + 1, payload_.end());
  return "";
}

HostWorker::~HostWorker() {
  if (busy_) kill_and_reap();
  if (fd_ >= 0) close(fd_);
  // An idle worker exits on end-of-file, letting its host clean up; one that does not within a
  // second is killed.
  for (int i = 0; i < 100 && pid_ > 0; ++i) {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_)
      pid_ = -1;
    else
      usleep(10000);
  }
  kill_and_reap();
}

bool HostWorker::send_all(const void* p, std::size_t n) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  while (n > 0) {
    const ssize_t w = ::send(fd_, b, n, MSG_NOSIGNAL);
    if (w < 0 && errno == EINTR) continue;
    if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      // The worker reads the whole request before it does anything else, so this wait ends;
      // a worker that died ends it with POLLHUP or POLLERR, and the next send fails.
      pollfd pfd{fd_, POLLOUT, 0};
      poll(&pfd, 1, -1);
      continue;
    }
    if (w <= 0) return false;
    b += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

bool HostWorker::send(const std::vector<double>& x, const cadinterp_host_mesh* mesh) {
  const std::vector<std::uint8_t> payload = request_codec::encode(
      mesh ? CADINTERP_REQUEST_SIMULATE : CADINTERP_REQUEST_SAMPLE, x.data(), x.size(), mesh);
  const std::vector<std::uint8_t> h = wp::header(wp::kRequest, payload.size());
  busy_ = true;
  return send_all(h.data(), h.size()) && send_all(payload.data(), payload.size());
}

HostWorker::Read HostWorker::read_available() {
  // A worker may write its last frame and exit at once (a host that does not load): what it
  // wrote is read before its end-of-file counts.
  bool ended = false;
  for (;;) {
    std::uint8_t chunk[65536];
    const ssize_t r = read(fd_, chunk, sizeof chunk);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    if (r <= 0) {
      ended = true;
      break;
    }
    buffer_.insert(buffer_.end(), chunk, chunk + r);
  }
  if (buffer_.size() < wp::kHeaderSize) return ended ? Read::kClosed : Read::kPending;
  std::uint32_t type = 0;
  std::uint64_t size = 0;
  if (!wp::parse_header(buffer_.data(), &type, &size) ||
      (type != wp::kResult && type != wp::kError && type != wp::kHello))
    return Read::kClosed;
  if (buffer_.size() < wp::kHeaderSize + size) return ended ? Read::kClosed : Read::kPending;
  // One request is outstanding at a time, so a complete frame is all the buffer holds.
  if (buffer_.size() != wp::kHeaderSize + size) return Read::kClosed;
  payload_.assign(buffer_.begin() + wp::kHeaderSize, buffer_.end());
  buffer_.clear();
  busy_ = false;
  return type == wp::kError ? Read::kError : Read::kResult;
}

std::string HostWorker::kill_and_reap() {
  if (pid_ > 0) {
    int status = 0;
    pid_t r = waitpid(pid_, &status, WNOHANG);
    if (r == 0) {
      kill(pid_, SIGKILL);
      do r = waitpid(pid_, &status, 0);
      while (r < 0 && errno == EINTR);
    }
    ended_ = r == pid_ ? describe_wait_status(status) : "ended (not reaped)";
    pid_ = -1;
    busy_ = false;
  }
  return ended_;
}

HostWorker::Read wait_for_answer(HostWorker& worker, double seconds) {
  const bool has_deadline = seconds >= 0;
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(has_deadline ? seconds : 0));
  for (;;) {
    const HostWorker::Read r = worker.read_available();
    if (r != HostWorker::Read::kPending) return r;
    const int ms = poll_ms(has_deadline, deadline);
    if (has_deadline && ms == 0) return r;
    pollfd pfd{worker.fd(), POLLIN, 0};
    if (poll(&pfd, 1, ms) < 0 && errno != EINTR) return HostWorker::Read::kClosed;
  }
}

}  // namespace cadinterp::tools
