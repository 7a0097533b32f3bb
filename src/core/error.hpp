#pragma once
// Errors carry the process exit code they map to, so every layer can throw
// and only main() decides how the process ends.
#include <stdexcept>
#include <string>

namespace terrabake {

// Documented in README.md ("Exit codes"); keep both in step.
enum class ExitCode : int {
  kOk = 0,
  kUsage = 2,        // bad command line or configuration file
  kInput = 3,        // unreadable DEM, unwritable output, no GL context...
  kTilesFailed = 4,  // the run finished but some tiles could not be made
};

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message)
      : std::runtime_error(message), m_code(code) {}
  ExitCode code() const { return m_code; }

 private:
  ExitCode m_code;
};

// A configuration or command-line problem: the user must change what they asked for.
struct UsageError : Error {
  explicit UsageError(const std::string& message) : Error(ExitCode::kUsage, message) {}
};

// A problem with the files or the machine: input data, output folder, GL.
struct InputError : Error {
  explicit InputError(const std::string& message) : Error(ExitCode::kInput, message) {}
};

// Folds line breaks so that every error reaches the user as one line.
std::string oneLine(std::string text);

}  // namespace terrabake
