#include "model/usable_cpus.h"

#include <sched.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace mm {

namespace {

namespace fs = std::filesystem;

std::string file_text(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// cgroup v2's cpu.max ("max 100000" or "150000 100000"), or v1's pair of
// cfs files; 0 when the folder sets no quota.
double quota_of(const fs::path& folder) {
  std::istringstream v2(file_text(folder / "cpu.max"));
  std::string quota;
  double period = 0;
  if (v2 >> quota >> period) return quota == "max" || period <= 0 ? 0 : std::stod(quota) / period;
  std::istringstream v1_quota(file_text(folder / "cpu.cfs_quota_us")), v1_period(file_text(folder / "cpu.cfs_period_us"));
  double microseconds = 0;
  if (v1_quota >> microseconds && v1_period >> period && microseconds > 0 && period > 0) return microseconds / period;
  return 0;
}

}  // namespace

double cgroup_cpu_quota(const std::string& cgroup_root, const std::string& membership) {
  // Lines of /proc/self/cgroup: "0::/path" (v2) or "4:cpu,cpuacct:/path" (v1).
  std::istringstream lines(membership);
  double smallest = 0;
  for (std::string line; std::getline(lines, line);) {
    const size_t first = line.find(':'), second = line.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1);
    fs::path base = cgroup_root;
    if (!controllers.empty()) {
      if (controllers.find("cpu") == std::string::npos) continue;
      base /= controllers;
    }
    // Inside a container the cgroup namespace makes the own cgroup "/", and
    // the root folder is the container's own.
    fs::path folder = base / fs::path(line.substr(second + 1)).relative_path();
    while (true) {
      const double quota = quota_of(folder);
      if (quota > 0 && (smallest == 0 || quota < smallest)) smallest = quota;
      if (folder == base || !folder.has_parent_path() || folder.parent_path() == folder) break;
      folder = folder.parent_path();
    }
  }
  return smallest;
}

int usable_cpu_count() {
  int cpus = static_cast<int>(std::thread::hardware_concurrency());
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof allowed, &allowed) == 0) cpus = CPU_COUNT(&allowed);
  const double quota = cgroup_cpu_quota("/sys/fs/cgroup", file_text("/proc/self/cgroup"));
  if (quota > 0) cpus = std::min(cpus, static_cast<int>(std::ceil(quota - 1e-9)));
  return std::max(1, cpus);
}

}  // namespace mm
