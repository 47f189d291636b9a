// What a process (the server under test) has used so far, read from
// /proc/PID/stat and /proc/PID/status: the CPU time of all its threads, the
// peak and current resident memory and its thread count. Tests compare two
// readings to show what a request cost the server, not the client.
#pragma once

#include <sys/types.h>
#include <unistd.h>

#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

namespace mm::test {

struct ProcessCost {
  double cpu_seconds = 0;
  long peak_rss_kib = 0;
  long rss_kib = 0;
  int threads = 0;
};

inline ProcessCost process_cost(pid_t pid) {
  ProcessCost cost;
  std::ifstream stat_file("/proc/" + std::to_string(pid) + "/stat");
  const std::string stat((std::istreambuf_iterator<char>(stat_file)), {});
  // The name in parentheses may hold spaces; fields 14 and 15 (utime,
  // stime, in clock ticks) are the 12th and 13th after it.
  std::istringstream fields(stat.substr(stat.rfind(')') + 1));
  std::vector<std::string> after_name{std::istream_iterator<std::string>(fields), {}};
  if (after_name.size() > 12) {
    cost.cpu_seconds = static_cast<double>(std::stoll(after_name[11]) + std::stoll(after_name[12])) /
                       static_cast<double>(sysconf(_SC_CLK_TCK));
  }
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) cost.peak_rss_kib = std::stol(line.substr(6));
    if (line.rfind("VmRSS:", 0) == 0) cost.rss_kib = std::stol(line.substr(6));
    if (line.rfind("Threads:", 0) == 0) cost.threads = std::stoi(line.substr(8));
  }
  return cost;
}

}  // namespace mm::test
