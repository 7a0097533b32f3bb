#pragma once
// Small text helpers shared by the config reader, the layer layout and the
// HTTP rules.
#include <optional>
#include <string>
#include <string_view>

namespace terrabake {

inline bool endsWith(std::string_view text, std::string_view end) {
  return text.size() >= end.size() && text.substr(text.size() - end.size()) == end;
}

// `text` without the spaces and tabs at either end.
inline std::string_view trim(std::string_view text) {
  const std::size_t first = text.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

// A tile number as tile paths spell it: decimal digits, no sign, no leading
// zero ("12", not "012" or "+12"), at most nine of them (they fit an int).
inline std::optional<int> tileNumber(std::string_view text) {
  constexpr std::size_t kMaxDigits = 9;
  if (text.empty() || text.size() > kMaxDigits || (text.size() > 1 && text.front() == '0')) return std::nullopt;
  int value = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + (c - '0');
  }
  return value;
}

// Appends `value` in lower-case hex digits, at least `width` of them.
inline void appendHex(std::string& text, unsigned long long value, int width = 1) {
  char digits[16];
  int count = 0;
  do {
    digits[count++] = "0123456789abcdef"[value & 15];
    value >>= 4;
  } while (value != 0);
  for (; count < width; --width) text += '0';
  while (count > 0) text += digits[--count];
}

}  // namespace terrabake
