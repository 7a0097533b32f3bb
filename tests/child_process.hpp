#pragma once
// The terrabake executable as a child process for tests: started without a
// shell, stdout and stderr on pipes, and always reaped, so a hang fails a test
// instead of blocking the run.
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "sanitizers.hpp"

extern char** environ;

namespace terrabake::test {

// Resource limits for the child, set between fork and exec (0: inherited).
struct ChildLimits {
  rlim_t open_files = 0;  // RLIMIT_NOFILE
  // RLIMIT_AS, bytes. Not set under AddressSanitizer, whose shadow memory
  // reserves terabytes of address space at start: such a run checks what
  // the child does and how fast, and the plain build its memory bound.
  rlim_t address_space = 0;
  // The child runs on the first this many of the CPUs it would run on
  // (its affinity), as under taskset.
  int cpus = 0;
};

class ChildProcess {
 public:
  explicit ChildProcess(const std::vector<std::string>& args, const ChildLimits& limits = {}) {
    int out_pipe[2], err_pipe[2];
    // CLOEXEC: only the dup2'ed copies reach the child, so EOF comes when it exits.
    if (::pipe2(out_pipe, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe2: ") + std::strerror(errno));
    if (::pipe2(err_pipe, O_CLOEXEC) != 0) {
      ::close(out_pipe[0]);
      ::close(out_pipe[1]);
      throw std::runtime_error(std::string("pipe2: ") + std::strerror(errno));
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, out_pipe[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions, err_pipe[1], STDERR_FILENO);
    std::vector<std::string> words = {TERRABAKE_EXE};
    words.insert(words.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& word : words) argv.push_back(word.data());
    argv.push_back(nullptr);
    int error = 0;
    if (limits.open_files == 0 && limits.address_space == 0 && limits.cpus == 0) {
      error = ::posix_spawn(&m_pid, TERRABAKE_EXE, &actions, nullptr, argv.data(), environ);
    } else {
      // posix_spawn cannot set limits: fork, and only async-signal-safe calls before exec.
      m_pid = ::fork();
      if (m_pid == 0) {
        const auto limit = [](int resource, rlim_t value) {
          if (value == 0) return;
          rlimit r{value, value};
          if (::setrlimit(resource, &r) != 0) ::_exit(126);
        };
        limit(RLIMIT_NOFILE, limits.open_files);
        if (!kAddressSanitizer) limit(RLIMIT_AS, limits.address_space);
        cpu_set_t cpus;
        if (limits.cpus > 0 && ::sched_getaffinity(0, sizeof cpus, &cpus) == 0) {
          for (int cpu = 0, kept = 0; cpu < CPU_SETSIZE; ++cpu) {
            if (CPU_ISSET(cpu, &cpus) && ++kept > limits.cpus) CPU_CLR(cpu, &cpus);
          }
          if (::sched_setaffinity(0, sizeof cpus, &cpus) != 0) ::_exit(126);
        }
        const int null_fd = ::open("/dev/null", O_RDONLY);
        if (null_fd < 0 || ::dup2(null_fd, STDIN_FILENO) < 0 || ::dup2(out_pipe[1], STDOUT_FILENO) < 0 ||
            ::dup2(err_pipe[1], STDERR_FILENO) < 0) {
          ::_exit(126);
        }
        ::execve(TERRABAKE_EXE, argv.data(), environ);
        ::_exit(127);
      }
      if (m_pid < 0) error = errno;
    }
    posix_spawn_file_actions_destroy(&actions);
    ::close(out_pipe[1]);
    ::close(err_pipe[1]);
    m_fds[0] = out_pipe[0];
    m_fds[1] = err_pipe[0];
    if (error != 0) {
      m_pid = 0;
      throw std::runtime_error(std::string("cannot start " TERRABAKE_EXE ": ") + std::strerror(error));
    }
  }

  ~ChildProcess() {
    if (m_pid > 0) {
      ::kill(m_pid, SIGKILL);
      ::waitpid(m_pid, nullptr, 0);
    }
    for (int fd : m_fds) {
      if (fd >= 0) ::close(fd);
    }
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  void signal(int sig) const {
    if (m_pid > 0) ::kill(m_pid, sig);
  }

  // The first line on stdout, "" when none comes in time or the process ends.
  std::string firstLine(std::chrono::milliseconds limit) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    while (m_out.find('\n') == std::string::npos && pump(deadline)) {
    }
    const std::size_t end = m_out.find('\n');
    return end == std::string::npos ? "" : m_out.substr(0, end + 1);
  }

  // False once the process has exited (it is reaped then; wait() still
  // collects its output and returns its exit code). For polling loops, which
  // must not wait on a child that is gone.
  bool running() {
    if (m_pid <= 0) return false;
    int status = 0;
    if (::waitpid(m_pid, &status, WNOHANG) != m_pid) return true;
    m_pid = 0;
    m_exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return false;
  }

  // Collects both pipes until the process exits. Its exit code, or -1 when it
  // died of a signal or outlived `limit` (then it is killed: timedOut()).
  int wait(std::chrono::milliseconds limit) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    while (pump(deadline)) {
    }
    int status = 0;
    while (m_pid > 0) {
      const pid_t done = ::waitpid(m_pid, &status, WNOHANG);
      if (done == m_pid) {
        m_pid = 0;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      }
      if (std::chrono::steady_clock::now() >= deadline) {
        m_timed_out = true;
        ::kill(m_pid, SIGKILL);
        ::waitpid(m_pid, nullptr, 0);
        m_pid = 0;
        return -1;
      }
      ::usleep(5000);
    }
    return m_exit_code;
  }

  bool timedOut() const { return m_timed_out; }
  const std::string& out() const { return m_out; }
  const std::string& err() const { return m_err; }

 private:
  // Reads whatever either pipe has; false once both are closed or the
  // deadline has passed. Both are drained together, so a chatty child cannot
  // block on a full pipe while the other is read.
  bool pump(std::chrono::steady_clock::time_point deadline) {
    pollfd fds[2] = {{m_fds[0], POLLIN, 0}, {m_fds[1], POLLIN, 0}};
    if (m_fds[0] < 0 && m_fds[1] < 0) return false;
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) return false;
    const int ready = ::poll(fds, 2, int(left));
    if (ready < 0) return errno == EINTR;
    std::string* sinks[2] = {&m_out, &m_err};
    for (int i = 0; i < 2; ++i) {
      if (fds[i].fd < 0 || fds[i].revents == 0) continue;
      char buffer[4096];
      const ssize_t got = ::read(fds[i].fd, buffer, sizeof buffer);
      if (got > 0) {
        sinks[i]->append(buffer, std::size_t(got));
      } else if (got == 0 || errno != EINTR) {
        ::close(m_fds[i]);
        m_fds[i] = -1;
      }
    }
    return true;
  }

  pid_t m_pid = 0;
  int m_fds[2] = {-1, -1};
  std::string m_out, m_err;
  bool m_timed_out = false;
  int m_exit_code = -1;  // once running() has reaped the process
};

}  // namespace terrabake::test
