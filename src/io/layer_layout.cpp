#include "io/layer_layout.hpp"

#include <filesystem>

#include "io/tile_files.hpp"

namespace terrabake::io {

std::string_view extensionOf(TileFormat format) {
  switch (format) {
    case TileFormat::kPng: return "png";
    case TileFormat::kGlb: return "glb";
    case TileFormat::kHighResGlb: return "hires.glb";
  }
  return "";
}

std::optional<TileFormat> formatOfExtension(std::string_view extension) {
  for (const TileFormat format : {TileFormat::kPng, TileFormat::kGlb, TileFormat::kHighResGlb}) {
    if (extensionOf(format) == extension) return format;
  }
  return std::nullopt;
}

std::string relativeTilePath(const TileId& tile, TileFormat format) {
  return tile.str() + "." + std::string(extensionOf(format));
}

std::string tilePath(const std::string& layer_dir, const TileId& tile, TileFormat format) {
  return layer_dir + "/" + relativeTilePath(tile, format);
}

std::string layerLocation(const std::string& output_dir, const std::string& layer, OutputFormat format) {
  const std::string folder = (std::filesystem::path(output_dir) / layer).lexically_normal().string();
  return format == OutputFormat::kMbtiles ? folder + kMbtilesExtension : folder;
}

void writeTileFiles(const std::string& layer_dir, const TileId& tile, const TileFiles& files) {
  writeFileAtomically(tilePath(layer_dir, tile, TileFormat::kPng), files.png);
  writeFileAtomically(tilePath(layer_dir, tile, TileFormat::kGlb), files.glb);
  if (!files.high_res_glb.empty()) {
    writeFileAtomically(tilePath(layer_dir, tile, TileFormat::kHighResGlb), files.high_res_glb);
  }
}

TileFormat lastWrittenFormat(bool high_res_mesh) {
  return high_res_mesh ? TileFormat::kHighResGlb : TileFormat::kGlb;
}

}  // namespace terrabake::io
