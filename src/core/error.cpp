#include "core/error.hpp"

#include <algorithm>
#include <cerrno>
#include <system_error>

namespace terrabake {

std::string oneLine(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  std::replace(text.begin(), text.end(), '\r', ' ');
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

void throwIoError(const std::string& what, const std::string& path, int error) {
  const std::string message = what + " '" + path + "': " + std::generic_category().message(error);
  if (error == ENOSPC || error == EDQUOT || error == EROFS) throw OutputStorageError(message);
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
