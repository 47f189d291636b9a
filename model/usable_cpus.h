// How many CPUs this process may really use: the CPUs its affinity mask
// allows, bounded by the CPU quota of its cgroup (a container's --cpus, a
// Kubernetes CPU limit), rounded up. std::thread::hardware_concurrency()
// counts the machine's CPUs instead, so a server given 1 CPU of 16 would run
// 16 OpenMP threads that wait on each other at every barrier.
//
// Linux; torch-free. Thread safety: reads the file system, no state.
#pragma once

#include <string>

namespace mm {

int usable_cpu_count();

// The cgroup CPU quota in CPUs (quota / period) that `cgroup_root` and the
// membership text of /proc/self/cgroup (`membership`) give, the smallest on
// the path from the process's cgroup up to the root; 0 when none is set.
// Split out so that it can be tested on a folder made to look like a cgroup.
double cgroup_cpu_quota(const std::string& cgroup_root, const std::string& membership);

}  // namespace mm
