#include "core/extent_groups.hpp"

#include <algorithm>
#include <numeric>
#include <tuple>

namespace terrabake {
namespace {

bool meet(const Extent& a, const Extent& b) {
  return a.min_x <= b.max_x && b.min_x <= a.max_x && a.min_y <= b.max_y && b.min_y <= a.max_y;
}

// One round: the bounding box of each group of boxes linked by meeting.
std::vector<Extent> mergeOnce(const std::vector<Extent>& boxes) {
  std::vector<std::size_t> group(boxes.size());
  std::iota(group.begin(), group.end(), std::size_t(0));
  const auto root = [&](std::size_t i) {
    while (group[i] != i) i = group[i] = group[group[i]];
    return i;
  };
  // Swept from west to east: a box meets only those still open at its west edge.
  std::vector<std::size_t> by_west(boxes.size());
  std::iota(by_west.begin(), by_west.end(), std::size_t(0));
  std::sort(by_west.begin(), by_west.end(), [&](std::size_t a, std::size_t b) { return boxes[a].min_x < boxes[b].min_x; });
  std::vector<std::size_t> open;
  for (const std::size_t i : by_west) {
    open.erase(std::remove_if(open.begin(), open.end(), [&](std::size_t j) { return boxes[j].max_x < boxes[i].min_x; }),
               open.end());
    for (const std::size_t j : open) {
      if (meet(boxes[i], boxes[j])) group[root(i)] = root(j);
    }
    open.push_back(i);
  }
  std::vector<Extent> merged;
  std::vector<long> slot(boxes.size(), -1);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const std::size_t r = root(i);
    if (slot[r] < 0) {
      slot[r] = long(merged.size());
      merged.push_back(boxes[i]);
    } else {
      merged[std::size_t(slot[r])] = merged[std::size_t(slot[r])].united(boxes[i]);
    }
  }
  return merged;
}

}  // namespace

std::vector<Extent> mergeMeeting(std::vector<Extent> boxes) {
  // Repeats once: at coarse zooms thousands of areas fall in the same few
  // tiles, and the sweep would compare each with all the others.
  const auto key = [](const Extent& e) { return std::tie(e.min_x, e.min_y, e.max_x, e.max_y); };
  std::sort(boxes.begin(), boxes.end(), [&](const Extent& a, const Extent& b) { return key(a) < key(b); });
  const auto same = [&](const Extent& a, const Extent& b) { return key(a) == key(b); };
  boxes.erase(std::unique(boxes.begin(), boxes.end(), same), boxes.end());
  // A group's box may reach boxes none of its members met: merge again.
  for (std::size_t count = 0; count != boxes.size();) {
    count = boxes.size();
    boxes = mergeOnce(boxes);
  }
  std::sort(boxes.begin(), boxes.end(), [](const Extent& a, const Extent& b) {
    return a.max_y != b.max_y ? a.max_y > b.max_y : a.min_x < b.min_x;
  });
  return boxes;
}

std::size_t holderOf(const std::vector<Extent>& merged, const Extent& box) {
  std::size_t m = 0;
  while (!(merged[m].min_x <= box.min_x && box.max_x <= merged[m].max_x && merged[m].min_y <= box.min_y &&
           box.max_y <= merged[m].max_y)) {
    ++m;
  }
  return m;
}

}  // namespace terrabake
