#pragma once
// How many cores this process may use, which is what "one per core" means
// for workers and threads: the CPUs it may run on (taskset, a container's
// cpuset) and its share of CPU time (a container's CPU limit, the cgroup's
// CFS quota). std::thread::hardware_concurrency counts the machine's: in a
// container limited to 2 CPUs on a 64-core node, 64 workers would wait on
// each other for the 2 and hold 32 times the memory.
#include <optional>
#include <string>

namespace terrabake {

struct UsableCores {
  int count = 1;
  // Why fewer than the machine's online cores ("its cgroup's CPU quota is
  // 1.5 of the 64 online"); empty when nothing limits them.
  std::string limited_by;
};

// Asked of the system once, then remembered.
const UsableCores& usableCores();

// The CPU time, in CPUs, that the cgroups of a process allow it, from the
// cgroup file system mounted at `cgroup_root` and the text of the process's
// /proc/self/cgroup: the smallest quota of its cgroup and the cgroups above
// it, cgroup v2 (cpu.max) or v1 (cpu.cfs_quota_us over cpu.cfs_period_us).
// nullopt when none sets one.
std::optional<double> cgroupCpuQuota(const std::string& cgroup_root, const std::string& proc_self_cgroup);

}  // namespace terrabake
