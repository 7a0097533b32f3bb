// The CPU quota a process's cgroups allow, read from cgroup file systems
// laid out as Linux mounts them (v2, and v1's cpu controller).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>

#include "core/usable_cores.hpp"
#include "test_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;

// What cgroupCpuQuota reads from a tree of `files` (path: text) for a
// process whose /proc/self/cgroup says `own`.
std::optional<double> quotaOf(const std::map<std::string, std::string>& files, const std::string& own) {
  const fs::path root = test::caseDir();
  for (const auto& [path, text] : files) {
    fs::create_directories((root / path).parent_path());
    std::ofstream(root / path) << text;
  }
  return cgroupCpuQuota(root.string(), own);
}

TEST(CgroupQuota, TheSmallestQuotaOfTheCgroupAndThoseAboveItCounts) {
  EXPECT_EQ(quotaOf({{"kubepods/pod1/app/cpu.max", "max 100000\n"},
                     {"kubepods/pod1/cpu.max", "150000 100000\n"},
                     {"kubepods/cpu.max", "800000 100000\n"}},
                    "0::/kubepods/pod1/app\n"),
            1.5);
}

TEST(CgroupQuota, AContainerSeesItsOwnCgroupAtTheRoot) {
  // /proc/self/cgroup names the host's path, which the container's mount lacks.
  EXPECT_EQ(quotaOf({{"cpu.max", "200000 100000\n"}}, "0::/system.slice/docker-abc.scope\n"), 2.0);
}

TEST(CgroupQuota, CgroupV1ReadsTheCfsQuotaOverItsPeriod) {
  EXPECT_EQ(quotaOf({{"cpu,cpuacct/docker/abc/cpu.cfs_quota_us", "-1\n"},
                     {"cpu,cpuacct/docker/abc/cpu.cfs_period_us", "100000\n"},
                     {"cpu,cpuacct/docker/cpu.cfs_quota_us", "400000\n"},
                     {"cpu,cpuacct/docker/cpu.cfs_period_us", "100000\n"}},
                    "12:memory:/docker/abc\n3:cpu,cpuacct:/docker/abc\n1:name=systemd:/docker/abc\n"),
            4.0);
}

TEST(CgroupQuota, NoLimitOrUnreadableFilesGiveNone) {
  const std::map<std::string, std::string> unlimited = {{"cpu.max", "max 100000\n"},
                                                        {"a/cpu.max", "garbage\n"},
                                                        {"cpu/cpu.cfs_quota_us", "-1\n"},
                                                        {"cpu/cpu.cfs_period_us", "100000\n"}};
  EXPECT_EQ(quotaOf(unlimited, "0::/a\n1:cpu:/\n"), std::nullopt);
  EXPECT_EQ(quotaOf(unlimited, "not a cgroup line\n"), std::nullopt);
  EXPECT_EQ(quotaOf({}, "0::/\n"), std::nullopt);
}

TEST(UsableCores, AtLeastOneAndNoMoreThanTheMachineHas) {
  const UsableCores& cores = usableCores();
  EXPECT_GE(cores.count, 1);
  EXPECT_LE(cores.count, ::sysconf(_SC_NPROCESSORS_ONLN));
  EXPECT_EQ(cores.limited_by.empty(), cores.count == ::sysconf(_SC_NPROCESSORS_ONLN)) << cores.limited_by;
}

}  // namespace
}  // namespace terrabake
