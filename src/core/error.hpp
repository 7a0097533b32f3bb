#pragma once
// Errors carry the process exit code they map to, so every layer can throw
// and only main() decides how the process ends.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>

namespace terrabake {

// Documented in README.md ("Exit codes"); keep both in step.
enum class ExitCode : int {
  kOk = 0,
  kUsage = 2,        // bad command line or configuration file
  kInput = 3,        // unreadable DEM, unwritable output, no GL context...
  kTilesFailed = 4,  // the run finished but some tiles could not be made
  kNothingMade = 5,  // the job holds no tile with data: nothing was written (the reason is logged)
  // `tile` stopped by a signal, as shells report one: 128 + its number (129
  // SIGHUP, 130 SIGINT, 143 SIGTERM). The tiles written are whole, --resume
  // makes the rest.
  kStoppedBySignal = 128,
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

// A problem the tiles after it would meet too, each with its own error line:
// a run stops at the first; `remedy` says what to do before running it again
// ("make room").
struct RunStoppingError : InputError {
  RunStoppingError(const std::string& message, std::string what_to_do)
      : InputError(message), remedy(std::move(what_to_do)) {}
  std::string remedy;
};

// A write the output's storage refuses, and will refuse for every tile after
// it: no space left, over quota, read-only, not ours to write.
struct OutputStorageError : RunStoppingError {
  using RunStoppingError::RunStoppingError;
};

// A DEM file that opened but whose pixels cannot be read: a GeoTIFF cut
// short, a VRT whose source file is gone.
struct UnreadableDemError : RunStoppingError {
  explicit UnreadableDemError(const std::string& message) : RunStoppingError(message, "repair or replace the file") {}
};

// Throws OutputStorageError for an errno value of that kind (ENOSPC, EDQUOT,
// EFBIG: a file larger than ulimit -f or the file system allows; EROFS,
// EACCES, EPERM), else InputError: "<what> '<path>': <the error's
// description>", the path shortened().
[[noreturn]] void throwIoError(const std::string& what, const std::string& path, int error);

// A job that cannot make any tile, for a reason that is not an error of the
// command line or of the files (all its DEM samples are voids, the DEM lies
// beyond the scheme's latitudes, the bbox misses the DEM): main() logs the
// reason as a warning and exits with kNothingMade.
struct NothingToMake : Error {
  explicit NothingToMake(const std::string& message) : Error(ExitCode::kNothingMade, message) {}
};

// Folds line breaks and tabs into spaces so that every error reaches the
// user as one line, and writes other control characters as \xNN.
std::string oneLine(const std::string& text);

// `text` as quoted in a message: whole when short, else its start and how
// long it was ("aaaa... (10485760 bytes)"), so no value floods a log line.
std::string shortened(const std::string& text, std::size_t max_bytes = 160);

// The longest message main() prints; longer ones are cut the same way.
inline constexpr std::size_t kMaxMessageBytes = 2000;

// A message as main() prints it: one line (oneLine), each quoted value
// ('...', the quotes opening after a space or bracket and closing before
// one or before punctuation) and each other word longer than 160 bytes
// shortened(), and the whole at most kMaxMessageBytes. So a long path never
// hides the reason after it.
std::string messageLine(const std::string& text);

}  // namespace terrabake
