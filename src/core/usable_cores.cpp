#include "core/usable_cores.hpp"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace terrabake {
namespace {

namespace fs = std::filesystem;

std::optional<std::string> readFile(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// A cgroup's folder and those above it, up to where the hierarchy is mounted.
// A container sees its own cgroup at the mount's root, whatever path
// /proc/self/cgroup names (the host's): the root is always looked at.
std::vector<fs::path> cgroupFolders(const fs::path& mount, const std::string& path) {
  std::vector<fs::path> folders;
  for (fs::path p = fs::path(path).relative_path(); !p.empty(); p = p.parent_path()) folders.push_back(mount / p);
  folders.push_back(mount);
  return folders;
}

// cgroup v2: "max 100000" (no limit) or "<quota> <period>".
std::optional<double> quotaV2(const fs::path& folder) {
  const std::optional<std::string> text = readFile(folder / "cpu.max");
  if (!text) return std::nullopt;
  std::istringstream in(*text);
  std::string quota;
  double period = 0;
  if (!(in >> quota >> period) || quota == "max" || period <= 0) return std::nullopt;
  try {
    return std::stod(quota) / period;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// cgroup v1: cpu.cfs_quota_us is -1 without a limit.
std::optional<double> quotaV1(const fs::path& folder) {
  const std::optional<std::string> quota = readFile(folder / "cpu.cfs_quota_us");
  const std::optional<std::string> period = readFile(folder / "cpu.cfs_period_us");
  if (!quota || !period) return std::nullopt;
  try {
    const double q = std::stod(*quota), p = std::stod(*period);
    if (q <= 0 || p <= 0) return std::nullopt;
    return q / p;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

UsableCores askTheSystem() {
  const long online = std::max(1L, ::sysconf(_SC_NPROCESSORS_ONLN));
  UsableCores cores;
  cores.count = int(online);
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (::sched_getaffinity(0, sizeof allowed, &allowed) == 0 && CPU_COUNT(&allowed) < cores.count) {
    cores.count = std::max(1, CPU_COUNT(&allowed));
    cores.limited_by = "its CPU affinity allows " + std::to_string(cores.count);
  }
  const std::optional<std::string> own = readFile("/proc/self/cgroup");
  const std::optional<double> quota = own ? cgroupCpuQuota("/sys/fs/cgroup", *own) : std::nullopt;
  if (quota && int(std::ceil(*quota)) < cores.count) {
    cores.count = std::max(1, int(std::ceil(*quota)));
    char text[96];
    std::snprintf(text, sizeof text, "its cgroup's CPU quota is %.3g", *quota);
    cores.limited_by = text;
  }
  if (!cores.limited_by.empty()) cores.limited_by += " of the " + std::to_string(online) + " online";
  return cores;
}

}  // namespace

std::optional<double> cgroupCpuQuota(const std::string& cgroup_root, const std::string& proc_self_cgroup) {
  std::optional<double> smallest;
  const auto keep = [&](std::optional<double> quota) {
    if (quota && (!smallest || *quota < *smallest)) smallest = quota;
  };
  std::istringstream lines(proc_self_cgroup);
  for (std::string line; std::getline(lines, line);) {
    // "hierarchy-ID:controllers:path"; v2's line is "0::path".
    const std::size_t first = line.find(':'), second = line.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1);
    const std::string path = line.substr(second + 1);
    if (controllers.empty()) {
      for (const fs::path& folder : cgroupFolders(cgroup_root, path)) keep(quotaV2(folder));
      continue;
    }
    std::istringstream names(controllers);
    for (std::string name; std::getline(names, name, ',');) {
      if (name != "cpu") continue;
      // v1 mounts the cpu controller as cpu,cpuacct, with cpu a link to it on
      // most systems.
      for (const char* mount : {"cpu,cpuacct", "cpu"}) {
        for (const fs::path& folder : cgroupFolders(fs::path(cgroup_root) / mount, path)) keep(quotaV1(folder));
      }
    }
  }
  return smallest;
}

const UsableCores& usableCores() {
  static const UsableCores cores = askTheSystem();
  return cores;
}

}  // namespace terrabake
