// The CPU quota a process's cgroups allow, read from cgroup file systems
// laid out as Linux mounts them (v2, and v1's cpu controller).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/usable_cores.hpp"
#include "test_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

TEST(CgroupQuota, TheSmallestQuotaOfTheCgroupAndThoseAboveItCounts) {
  const fs::path root = test::caseDir();
  write(root / "kubepods/pod1/app/cpu.max", "max 100000\n");
  write(root / "kubepods/pod1/cpu.max", "150000 100000\n");
  write(root / "kubepods/cpu.max", "800000 100000\n");
  const std::optional<double> quota = cgroupCpuQuota(root.string(), "0::/kubepods/pod1/app\n");
  ASSERT_TRUE(quota);
  EXPECT_DOUBLE_EQ(*quota, 1.5);
}

TEST(CgroupQuota, AContainerSeesItsOwnCgroupAtTheRoot) {
  // /proc/self/cgroup names the host's path, which the container's mount lacks.
  const fs::path root = test::caseDir();
  write(root / "cpu.max", "200000 100000\n");
  const std::optional<double> quota = cgroupCpuQuota(root.string(), "0::/system.slice/docker-abc.scope\n");
  ASSERT_TRUE(quota);
  EXPECT_DOUBLE_EQ(*quota, 2);
}

TEST(CgroupQuota, CgroupV1ReadsTheCfsQuotaOverItsPeriod) {
  const fs::path root = test::caseDir();
  write(root / "cpu,cpuacct/docker/abc/cpu.cfs_quota_us", "-1\n");
  write(root / "cpu,cpuacct/docker/abc/cpu.cfs_period_us", "100000\n");
  write(root / "cpu,cpuacct/docker/cpu.cfs_quota_us", "400000\n");
  write(root / "cpu,cpuacct/docker/cpu.cfs_period_us", "100000\n");
  const std::string own = "12:memory:/docker/abc\n3:cpu,cpuacct:/docker/abc\n1:name=systemd:/docker/abc\n";
  const std::optional<double> quota = cgroupCpuQuota(root.string(), own);
  ASSERT_TRUE(quota);
  EXPECT_DOUBLE_EQ(*quota, 4);
}

TEST(CgroupQuota, NoLimitOrUnreadableFilesGiveNone) {
  const fs::path root = test::caseDir();
  write(root / "cpu.max", "max 100000\n");
  write(root / "a/cpu.max", "garbage\n");
  write(root / "cpu/cpu.cfs_quota_us", "-1\n");
  write(root / "cpu/cpu.cfs_period_us", "100000\n");
  EXPECT_FALSE(cgroupCpuQuota(root.string(), "0::/a\n1:cpu:/\n"));
  EXPECT_FALSE(cgroupCpuQuota(root.string(), "not a cgroup line\n"));
  EXPECT_FALSE(cgroupCpuQuota((root / "missing").string(), "0::/\n"));
}

TEST(UsableCores, AtLeastOneAndNoMoreThanTheMachineHas) {
  const UsableCores& cores = usableCores();
  EXPECT_GE(cores.count, 1);
  EXPECT_LE(cores.count, ::sysconf(_SC_NPROCESSORS_ONLN));
  EXPECT_EQ(cores.limited_by.empty(), cores.count == ::sysconf(_SC_NPROCESSORS_ONLN)) << cores.limited_by;
}

}  // namespace
}  // namespace terrabake
