#pragma once
// Boxes gathered into groups that keep apart: where boxes meet, one box that
// holds them. Plans with it give a list of far-apart DEM files an area
// round each file or group of neighbours, rather than one box over all.
#include <cstddef>
#include <vector>

#include "core/types.hpp"

namespace terrabake {

// The bounding boxes of the groups of `boxes` that meet (overlap or touch,
// edges included), merged again until no two of them meet: each box lies in
// exactly one result. Sorted by north edge (max_y, highest first), then by
// west edge, so the result does not depend on the boxes' order. Runs in
// about n log n for boxes that meet few others (the files of a mosaic).
std::vector<Extent> mergeMeeting(std::vector<Extent> boxes);

// The index in `merged` (mergeMeeting's result) of the box that holds `box`,
// one of the boxes merged.
std::size_t holderOf(const std::vector<Extent>& merged, const Extent& box);

}  // namespace terrabake
