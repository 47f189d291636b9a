// ChildProcess: one run of an external program (the motion-manifold tool) as
// a child of the server, at the lowest CPU priority and with its threads
// bounded, so that training never starves serving on a small machine.
//
// The child runs with SCHED_IDLE and nice 19 (unless told to keep the
// server's priority, for a machine that does nothing but train), OMP_NUM_THREADS set, stdin from
// /dev/null, stderr appended to a log file, and stdout either into the same
// log or into a pipe read line by line. It is bound to the thread that
// started it by PR_SET_PDEATHSIG (SIGKILL): if that thread or the whole
// server dies, so does the child, and no orphaned training keeps running.
// The destructor kills (SIGKILL) and reaps a child still running.
//
// Thread safety: none. One thread owns a ChildProcess and must be the one
// that started it (the death signal follows the starting thread); other
// threads ask the owner to signal it rather than calling signal() (after
// the owner reaps the child its pid may belong to another process).
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace mm::service {

struct ChildOptions {
  std::vector<std::string> argv;  // argv[0] is the executable's path
  int threads = 1;                // OMP_NUM_THREADS
  std::string log_path;           // stderr is appended here
  bool stdout_to_pipe = false;    // read_line(); otherwise stdout joins the log
  bool lowest_priority = true;    // SCHED_IDLE and nice 19; false: the server's own
};

class ChildProcess {
 public:
  // Starts the program; std::runtime_error when the log cannot be opened or
  // fork fails. A program that cannot be executed exits 127 with the reason
  // in the log.
  explicit ChildProcess(const ChildOptions& options);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }

  // With stdout_to_pipe: waits up to `timeout_ms` for output and appends the
  // complete lines that arrived to `lines` (without their newline). Returns
  // false once stdout is closed (the child exited) and every line was handed
  // out.
  bool read_lines(int timeout_ms, std::vector<std::string>& lines);

  void signal(int signal_number);  // no-op once reaped
  // Waits for the child to exit; returns its wait status (see waitpid).
  int wait();

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string pending_;  // a partial line read so far
  bool reaped_ = false;
  int status_ = 0;
};

// "exited with status 2", "was killed by signal 9 (Killed)".
std::string describe_wait_status(int status);

}  // namespace mm::service
