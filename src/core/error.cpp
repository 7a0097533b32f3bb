#include "core/error.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <string_view>
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
  const std::string message = what + " '" + shortened(path) + "': " + std::generic_category().message(error);
  if (error == ENOSPC || error == EDQUOT) throw OutputStorageError(message, "make room");
  if (error == EFBIG) throw OutputStorageError(message, "allow larger files (ulimit -f)");
  if (error == EROFS || error == EACCES || error == EPERM) {
    throw OutputStorageError(message, "make the output writable");
  }
  throw InputError(message);
}

std::string shortened(const std::string& text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return text;
  std::size_t cut = max_bytes;
  // Never inside a UTF-8 sequence.
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return text.substr(0, cut) + "... (" + std::to_string(text.size()) + " bytes)";
}

namespace {

bool isIn(char c, const char* set) { return c != '\0' && std::strchr(set, c) != nullptr; }

// Whether the quote at `at` opens a value: first in the text, or after a
// space or an opening bracket; an apostrophe inside a word ("GDAL's") does not.
bool opensQuote(const std::string& text, std::size_t at) { return at == 0 || isIn(text[at - 1], " ([{=,:"); }

// Whether the quote at `at` closes one: last, or before a space or punctuation.
bool closesQuote(const std::string& text, std::size_t at) {
  return at + 1 == text.size() || isIn(text[at + 1], " )]},;:.?!");
}

// Whether text[at, end) is a cut made already: shortened()'s "... (N
// bytes)" ends it (a quoted value) or follows it (a word), and a second cut
// would give the length of the first.
bool isCutAlready(const std::string& text, std::size_t at, std::size_t end) {
  const std::string_view part(text.data() + at, end - at);
  const std::size_t dots = part.rfind("...");
  if (dots == std::string_view::npos || dots > 160) return false;
  std::string_view rest = std::string_view(text).substr(at + dots + 3);
  if (rest.substr(0, 2) != " (") return false;
  rest.remove_prefix(2);
  std::size_t digits = 0;
  while (digits < rest.size() && std::isdigit(static_cast<unsigned char>(rest[digits]))) ++digits;
  return digits > 0 && rest.substr(digits, 7) == " bytes)";
}

}  // namespace

std::string messageLine(const std::string& text) {
  const std::string line = oneLine(text);
  std::string out;
  out.reserve(std::min(line.size(), kMaxMessageBytes));
  std::size_t at = 0;
  while (at < line.size()) {
    if (line[at] == '\'' && opensQuote(line, at)) {
      std::size_t close = at + 1;
      while (close < line.size() && !(line[close] == '\'' && closesQuote(line, close))) ++close;
      if (close < line.size()) {
        const std::string value = line.substr(at + 1, close - at - 1);
        out += "'" + (isCutAlready(line, at + 1, close) ? value : shortened(value)) + "'";
        at = close + 1;
        continue;
      }
    }
    if (line[at] != ' ' && (at == 0 || line[at - 1] == ' ')) {
      std::size_t end = line.find(' ', at);
      if (end == std::string::npos) end = line.size();
      if (end - at > 160 && !isCutAlready(line, at, end)) {
        out += shortened(line.substr(at, end - at));
        at = end;
        continue;
      }
    }
    out += line[at++];
  }
  return shortened(out, kMaxMessageBytes);
}

}  // namespace terrabake
