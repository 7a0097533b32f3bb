#pragma once
// A zlib stream (RFC 1950) quick enough to write every tile: deflate blocks
// (RFC 1951) with Huffman codes fitted to each block, whose only matches are
// runs of a byte repeating the one before it. That is what a PNG filter's
// output calls for: its residuals are small numbers whose frequencies
// Huffman codes capture, with long runs of zeros where the image is flat,
// and searching for longer-range matches costs more time than it saves
// bytes (docs/performance.md, "PNG encoding").
#include <cstddef>
#include <cstdint>
#include <vector>

namespace terrabake::io {

std::vector<std::uint8_t> zlibCompress(const std::uint8_t* data, std::size_t size);

}  // namespace terrabake::io
