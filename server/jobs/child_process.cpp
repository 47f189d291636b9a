#include "server/jobs/child_process.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <stdexcept>

extern char** environ;

namespace mm::service {
namespace {

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error(what + ": " + std::strerror(errno));
}

void write_message(int fd, const char* text) {
  ssize_t ignored = ::write(fd, text, std::strlen(text));
  (void)ignored;
}

}  // namespace

ChildProcess::ChildProcess(const ChildOptions& options) {
  if (options.argv.empty()) throw std::runtime_error("ChildProcess: no program given");
  // Everything the child needs is built before fork: between fork and exec
  // in a threaded program only async-signal-safe calls are allowed.
  std::vector<char*> argv;
  for (const auto& arg : options.argv) argv.push_back(const_cast<char*>(arg.c_str()));
  argv.push_back(nullptr);
  std::vector<std::string> environment;
  for (char** e = environ; *e != nullptr; ++e) {
    if (std::strncmp(*e, "OMP_NUM_THREADS=", 16) != 0) environment.emplace_back(*e);
  }
  environment.push_back("OMP_NUM_THREADS=" + std::to_string(options.threads > 0 ? options.threads : 1));
  std::vector<char*> envp;
  for (auto& entry : environment) envp.push_back(entry.data());
  envp.push_back(nullptr);

  const int log_fd = ::open(options.log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log_fd < 0) fail("cannot open " + options.log_path);
  const int null_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  int pipe_fds[2] = {-1, -1};
  if (options.stdout_to_pipe && ::pipe2(pipe_fds, O_CLOEXEC) != 0) {
    ::close(log_fd);
    ::close(null_fd);
    fail("pipe");
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(log_fd);
    ::close(null_fd);
    if (pipe_fds[0] >= 0) ::close(pipe_fds[0]), ::close(pipe_fds[1]);
    fail("fork");
  }
  if (pid == 0) {
    // The child. Die with the thread that started us; if the parent is
    // already gone the signal will never come, so leave at once.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    // Lowest priority: SCHED_IDLE runs only when nothing else wants the
    // CPU; nice 19 is the fallback where SCHED_IDLE is not permitted.
    if (options.lowest_priority) {
      struct sched_param param {};
      param.sched_priority = 0;
      ::sched_setscheduler(0, SCHED_IDLE, &param);
      ::setpriority(PRIO_PROCESS, 0, 19);
    }
    // Signal masks and ignored signals survive exec: the tool must see
    // SIGTERM (to checkpoint and stop) whatever the server's threads block.
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    struct sigaction default_action {};
    default_action.sa_handler = SIG_DFL;
    for (int s : {SIGTERM, SIGINT, SIGPIPE, SIGHUP}) ::sigaction(s, &default_action, nullptr);
    if (null_fd >= 0) ::dup2(null_fd, STDIN_FILENO);
    ::dup2(options.stdout_to_pipe ? pipe_fds[1] : log_fd, STDOUT_FILENO);
    ::dup2(log_fd, STDERR_FILENO);
    ::execve(argv[0], argv.data(), envp.data());
    // strerror is not async-signal-safe; the common causes are named instead.
    write_message(STDERR_FILENO, "cannot execute ");
    write_message(STDERR_FILENO, argv[0]);
    write_message(STDERR_FILENO, errno == ENOENT ? ": no such file\n"
                                 : errno == EACCES ? ": permission denied\n" : ": exec failed\n");
    ::_exit(127);
  }
  pid_ = pid;
  ::close(log_fd);
  if (null_fd >= 0) ::close(null_fd);
  if (options.stdout_to_pipe) {
    ::close(pipe_fds[1]);
    stdout_fd_ = pipe_fds[0];
  }
}

ChildProcess::~ChildProcess() {
  if (!reaped_) {
    ::kill(pid_, SIGKILL);
    wait();
  }
  if (stdout_fd_ >= 0) ::close(stdout_fd_);
}

bool ChildProcess::read_lines(int timeout_ms, std::vector<std::string>& lines) {
  if (stdout_fd_ < 0) return false;
  struct pollfd p {};
  p.fd = stdout_fd_;
  p.events = POLLIN;
  const int ready = ::poll(&p, 1, timeout_ms);
  if (ready < 0 && errno != EINTR) fail("poll");
  if (ready <= 0) return true;
  char buffer[8192];
  const ssize_t n = ::read(stdout_fd_, buffer, sizeof buffer);
  if (n < 0) {
    if (errno == EINTR || errno == EAGAIN) return true;
    fail("read");
  }
  if (n == 0) {  // end of stdout: hand out an unterminated last line too
    if (!pending_.empty()) lines.push_back(std::move(pending_));
    pending_.clear();
    ::close(stdout_fd_);
    stdout_fd_ = -1;
    return false;
  }
  pending_.append(buffer, static_cast<size_t>(n));
  size_t start = 0;
  for (size_t end; (end = pending_.find('\n', start)) != std::string::npos; start = end + 1) {
    lines.push_back(pending_.substr(start, end - start));
  }
  pending_.erase(0, start);
  return true;
}

void ChildProcess::signal(int signal_number) {
  if (!reaped_) ::kill(pid_, signal_number);
}

int ChildProcess::wait() {
  if (reaped_) return status_;
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0) {
    if (errno != EINTR) fail("waitpid");
  }
  reaped_ = true;
  status_ = status;
  return status_;
}

std::string describe_wait_status(int status) {
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    return "was killed by signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
  }
  return "ended with wait status " + std::to_string(status);
}

}  // namespace mm::service
