#include "io/layer_layout.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "core/text.hpp"
#include "io/tile_files.hpp"

namespace terrabake::io {

std::string_view extensionOf(TileFormat format) {
  switch (format) {
    case TileFormat::kPng: return "png";
    case TileFormat::kGlb: return "glb";
    case TileFormat::kHighResGlb: return "hires.glb";
    case TileFormat::kElevationPng: return "elevation.png";
  }
  return "";
}

std::optional<TileFormat> formatOfExtension(std::string_view extension) {
  for (const TileFormat format :
       {TileFormat::kPng, TileFormat::kGlb, TileFormat::kHighResGlb, TileFormat::kElevationPng}) {
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
  switch (format) {
    case OutputFormat::kMbtiles: return folder + kMbtilesExtension;
    case OutputFormat::kPmtiles: return folder + kPmtilesExtension;
    case OutputFormat::kFiles: break;
  }
  return folder;
}

namespace {

// The middle of a companion archive's name: "<layer>.<kind>.pmtiles".
std::string_view pmtilesKind(TileFormat format) {
  switch (format) {
    case TileFormat::kPng: return "";
    case TileFormat::kGlb: return "meshes";
    case TileFormat::kHighResGlb: return "hires";
    case TileFormat::kElevationPng: return "elevation";
  }
  return "";
}

}  // namespace

std::string pmtilesArchive(const std::string& normals_archive, TileFormat format) {
  const std::string_view kind = pmtilesKind(format);
  if (kind.empty()) return normals_archive;
  const std::string base = normals_archive.substr(0, normals_archive.size() - std::string_view(kPmtilesExtension).size());
  return base + "." + std::string(kind) + kPmtilesExtension;
}

bool isPmtilesCompanion(const std::string& file_name) {
  for (const TileFormat format : {TileFormat::kGlb, TileFormat::kHighResGlb, TileFormat::kElevationPng}) {
    if (endsWith(file_name, "." + std::string(pmtilesKind(format)) + kPmtilesExtension)) return true;
  }
  return false;
}

void writeTileFiles(const std::string& layer_dir, const TileId& tile, const TileFiles& files) {
  const std::pair<TileFormat, const std::vector<std::uint8_t>*> in_order[] = {
      {TileFormat::kPng, &files.png},
      {TileFormat::kElevationPng, &files.elevation_png},
      {TileFormat::kGlb, &files.glb},
      {TileFormat::kHighResGlb, &files.high_res_glb}};
  try {
    for (const auto& [format, bytes] : in_order) {
      if (format == TileFormat::kPng || format == TileFormat::kGlb || !bytes->empty()) {
        writeFileAtomically(tilePath(layer_dir, tile, format), *bytes);
      }
    }
  } catch (...) {
    // A tile is whole or absent: its files written so far, and any of an
    // earlier run that this one was replacing, go, the meshes first. A
    // --resume run then makes the tile again.
    for (auto it = std::rbegin(in_order); it != std::rend(in_order); ++it) {
      std::error_code ignored;
      std::filesystem::remove(tilePath(layer_dir, tile, it->first), ignored);
    }
    throw;
  }
}

std::string jobRecordOf(const std::string& layer_dir) {
  const std::string record = (std::filesystem::path(layer_dir) / kJobFile).string();
  std::error_code ec;
  if (!std::filesystem::exists(record, ec)) return "";
  if (std::filesystem::is_directory(record, ec)) throw InputError("'" + record + "' is a folder, not a job record");
  std::ifstream in(record, std::ios::binary);
  std::string recorded{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (!in.eof() && !in) throw InputError("cannot read '" + record + "'");
  return recorded;
}

std::string recordJob(const std::string& layer_dir, const std::string& fingerprint) {
  // One there already is read without writing anything: a resumed run on a
  // full disk fails at its first tile to write, not at the record.
  const std::string recorded = jobRecordOf(layer_dir);
  if (!recorded.empty()) return recorded;
  const std::string record = (std::filesystem::path(layer_dir) / kJobFile).string();
  const std::vector<std::uint8_t> bytes(fingerprint.begin(), fingerprint.end());
  if (writeFileExclusively(record, bytes)) return fingerprint;
  return jobRecordOf(layer_dir);
}

std::optional<std::string> foreignEntry(const std::string& layer_dir) {
  namespace fs = std::filesystem;
  const fs::path record = fs::path(layer_dir) / kJobFile;
  std::error_code ec;
  if (fs::exists(record, ec)) return std::nullopt;
  std::optional<std::string> found;
  for (fs::directory_iterator it(layer_dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.front() != '.') {
      found = name;
      break;
    }
  }
  if (found && fs::exists(record, ec)) return std::nullopt;
  return found;
}

std::vector<TileFormat> tileFormats(bool high_res_mesh, bool elevation) {
  std::vector<TileFormat> formats{TileFormat::kPng};
  if (elevation) formats.push_back(TileFormat::kElevationPng);
  formats.push_back(TileFormat::kGlb);
  if (high_res_mesh) formats.push_back(TileFormat::kHighResGlb);
  return formats;
}

}  // namespace terrabake::io
