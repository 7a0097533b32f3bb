#pragma once
// The named choices of a tile job. Each has one word table: the config
// parser, --help, config/README.md's check and tilejson all spell a choice
// through it, so no module compares strings.
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace terrabake {

enum class SchemeKind { kWebMercator, kGeodetic, kNative };
enum class Green { kUp, kDown };  // +Y of tangent space north (OpenGL, glTF) or south (DirectX)
enum class OutputFormat { kFiles, kMbtiles, kPmtiles };
// Elevation tiles written beside the normal maps, for MapLibre's raster-dem sources.
enum class Elevation {
  kNone,
  kTerrarium,  // height = R * 256 + G + B / 256 - 32768
  kMapbox,     // Mapbox Terrain-RGB: height = -10000 + (R * 65536 + G * 256 + B) * 0.1
};
// What a tile shows where the DEM has no sample (voids, beyond its edge).
enum class NodataSurface {
  kContinue,  // the surface runs on from the data, fading into a coarse backdrop
  kCut,       // nothing: alpha 0 and no triangle there
};
// The low-poly mesh of each tile.
enum class LowPolyMesh {
  kAdaptive,  // a triangulation of the samples within a distance bound, crack-free
  kGrid,      // a regular grid of low_poly.grid vertices a side
};
// Walls under each low-poly mesh's edges, against gaps between levels.
enum class Skirts {
  kAuto,  // on when output.tileset is, else off
  kOn,
  kOff,
};
enum class Backend {
  kAuto,    // a hardware GPU through EGL when there is one, else OSMesa
  kOsMesa,  // Mesa's offscreen llvmpipe renderer
  kEgl,     // EGL: a hardware device if any, else Mesa's surfaceless llvmpipe
  kCpu,     // the CPU baker, no GL at all
};

template <class E>
struct Words;  // Words<E>::table: every value of E with its word, in the order docs list them

template <>
struct Words<SchemeKind> {
  static constexpr std::array<std::pair<SchemeKind, std::string_view>, 3> table{
      {{SchemeKind::kWebMercator, "webmercator"}, {SchemeKind::kGeodetic, "geodetic"}, {SchemeKind::kNative, "native"}}};
};
template <>
struct Words<Green> {
  static constexpr std::array<std::pair<Green, std::string_view>, 2> table{{{Green::kUp, "up"}, {Green::kDown, "down"}}};
};
template <>
struct Words<OutputFormat> {
  static constexpr std::array<std::pair<OutputFormat, std::string_view>, 3> table{
      {{OutputFormat::kFiles, "files"}, {OutputFormat::kMbtiles, "mbtiles"}, {OutputFormat::kPmtiles, "pmtiles"}}};
};
template <>
struct Words<Elevation> {
  static constexpr std::array<std::pair<Elevation, std::string_view>, 3> table{
      {{Elevation::kNone, "none"}, {Elevation::kTerrarium, "terrarium"}, {Elevation::kMapbox, "mapbox"}}};
};
template <>
struct Words<NodataSurface> {
  static constexpr std::array<std::pair<NodataSurface, std::string_view>, 2> table{
      {{NodataSurface::kContinue, "continue"}, {NodataSurface::kCut, "cut"}}};
};
template <>
struct Words<LowPolyMesh> {
  static constexpr std::array<std::pair<LowPolyMesh, std::string_view>, 2> table{
      {{LowPolyMesh::kAdaptive, "adaptive"}, {LowPolyMesh::kGrid, "grid"}}};
};
template <>
struct Words<Skirts> {
  static constexpr std::array<std::pair<Skirts, std::string_view>, 3> table{
      {{Skirts::kAuto, "auto"}, {Skirts::kOn, "on"}, {Skirts::kOff, "off"}}};
};
template <>
struct Words<Backend> {
  static constexpr std::array<std::pair<Backend, std::string_view>, 4> table{
      {{Backend::kAuto, "auto"}, {Backend::kOsMesa, "osmesa"}, {Backend::kEgl, "egl"}, {Backend::kCpu, "cpu"}}};
};

template <class E>
constexpr std::string_view wordOf(E value) {
  for (const auto& [candidate, word] : Words<E>::table) {
    if (candidate == value) return word;
  }
  return {};
}

template <class E>
std::optional<E> choiceOf(std::string_view word) {
  for (const auto& [value, candidate] : Words<E>::table) {
    if (candidate == word) return value;
  }
  return std::nullopt;
}

template <class E>
std::vector<std::string> wordsOf() {
  std::vector<std::string> words;
  for (const auto& entry : Words<E>::table) words.emplace_back(entry.second);
  return words;
}

}  // namespace terrabake
