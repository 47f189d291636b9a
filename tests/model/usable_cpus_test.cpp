// The CPUs a process may use: the cgroup quota read from folders laid out as
// cgroup v2 and v1 mount them (the smallest quota on the way to the root,
// "max" as none), and the count never above the affinity mask.
#include <gtest/gtest.h>
#include <sched.h>

#include <filesystem>
#include <fstream>

#include "model/usable_cpus.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

TEST(UsableCpus, CgroupV2QuotaIsTheSmallestOnThePathToTheRoot) {
  test::ScratchDir root;
  write(root.path() / "cpu.max", "max 100000\n");
  write(root.path() / "pods" / "cpu.max", "300000 100000\n");
  write(root.path() / "pods" / "server" / "cpu.max", "150000 100000\n");
  EXPECT_DOUBLE_EQ(cgroup_cpu_quota(root.path().string(), "0::/pods/server\n"), 1.5);
  EXPECT_DOUBLE_EQ(cgroup_cpu_quota(root.path().string(), "0::/pods\n"), 3.0);
  EXPECT_DOUBLE_EQ(cgroup_cpu_quota(root.path().string(), "0::/\n"), 0.0);  // "max": no quota
}

TEST(UsableCpus, CgroupV1QuotaIsReadFromTheCpuController) {
  test::ScratchDir root;
  write(root.path() / "cpu,cpuacct" / "docker" / "c1" / "cpu.cfs_quota_us", "50000\n");
  write(root.path() / "cpu,cpuacct" / "docker" / "c1" / "cpu.cfs_period_us", "100000\n");
  write(root.path() / "cpu,cpuacct" / "cpu.cfs_quota_us", "-1\n");
  write(root.path() / "cpu,cpuacct" / "cpu.cfs_period_us", "100000\n");
  const std::string membership = "12:memory:/docker/c1\n4:cpu,cpuacct:/docker/c1\n0::/\n";
  EXPECT_DOUBLE_EQ(cgroup_cpu_quota(root.path().string(), membership), 0.5);
}

TEST(UsableCpus, NeverMoreThanTheAffinityMaskAllows) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
  const int count = usable_cpu_count();
  EXPECT_GE(count, 1);
  EXPECT_LE(count, CPU_COUNT(&allowed));
}

}  // namespace
}  // namespace mm
