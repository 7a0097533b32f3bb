#include "core/suggestion.hpp"

#include <algorithm>
#include <cstddef>

namespace terrabake {
namespace {

// Two edits catch a typo or a swapped pair without suggesting unrelated names.
constexpr std::size_t kMaxSuggestionDistance = 2;
// Names longer than any key or flag are not compared.
constexpr std::size_t kMaxSuggestedNameLength = 64;

std::size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

std::string nearestName(std::string_view name, const std::vector<std::string_view>& candidates) {
  if (name.size() > kMaxSuggestedNameLength) return "";
  std::string_view best;
  std::size_t best_distance = kMaxSuggestionDistance + 1;
  for (const std::string_view candidate : candidates) {
    const std::size_t distance = editDistance(name, candidate);
    if (distance > 0 && distance < best_distance) {
      best = candidate;
      best_distance = distance;
    }
  }
  return std::string(best);
}

}  // namespace terrabake
