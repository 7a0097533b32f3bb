#include "core/error.hpp"

#include <cerrno>
#include <system_error>

namespace terrabake {

std::string oneLine(const std::string& text) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string line;
  line.reserve(text.size());
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '\n' || c == '\r' || c == '\t') {
      line += ' ';
    } else if (byte < 0x20 || byte == 0x7f) {
      // Shown, not sent: an escape sequence in a value must not drive the terminal.
      line += {'\\', 'x', kHex[byte >> 4], kHex[byte & 15]};
    } else {
      line += c;
    }
  }
  while (!line.empty() && line.back() == ' ') line.pop_back();
  return line;
}

void throwIoError(const std::string& what, const std::string& path, int error) {
  const std::string message = what + " '" + path + "': " + std::generic_category().message(error);
  if (error == ENOSPC || error == EDQUOT || error == EROFS || error == EFBIG) throw OutputStorageError(message);
  throw InputError(message);
}

std::string shortened(const std::string& text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return text;
  std::size_t cut = max_bytes;
  // Never inside a UTF-8 sequence.
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return text.substr(0, cut) + "... (" + std::to_string(text.size()) + " bytes)";
}

}  // namespace terrabake
