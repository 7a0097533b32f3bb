#pragma once
// Coarser copies of a DEM file that has no overviews, made once per job and
// kept in memory, internal to the dem module: a coarse zoom then averages a
// few pixels of a reduced level per texel instead of thousands of the file's,
// so every zoom costs about what a tile of the deepest does.
//
// Level i is `factor(i)` times coarser than the file, each level made from
// the one below it (as GDAL makes overviews): a pixel is the mean of the
// valid pixels below it, void (NaN) where none is. The finest level is the
// first whose levels together fit the file's share of kMaxBytes, so memory
// stays bounded whatever the files' sizes; coarser ones go on halving down
// to a tile's size.
#include <gdal_priv.h>

#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "dem/dataset_views.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {

class ReducedLevels {
 public:
  // Files above this many pixels are not reduced (building reads the whole
  // file once: about half a second for 16384 x 16384 on two cores); their coarse zooms
  // read decimated instead.
  static constexpr double kMaxSourcePixels = double(1L << 28);
  // Every level of a job's files together, in memory, shared by the job's
  // readers: room for all of them from half resolution on while the files
  // hold kMaxSourcePixels (a third of that in floats, 341 MiB), so that no
  // zoom's texels span more than two pixels of what they read. With a
  // quarter of that, a 16384 x 16384 file kept levels from a quarter on
  // only, and the zoom whose texels span 2-4 of its pixels averaged the file
  // itself: 1.5-1.8 times the time of a tile of the deepest zoom.
  static constexpr std::size_t kMaxBytes = std::size_t(384) << 20;

  // A handle of the file (north-up) and its band of heights, for one
  // thread: a GDAL handle is read by one thread at a time.
  using BandOpener = std::function<std::pair<DatasetPtr, int>()>;

  // The widths of the levels a file of `width` x `height` pixels gets within
  // `max_bytes`, finest first; none when it is too large or too small to
  // gain from them. What build makes, known before it reads a pixel.
  static std::vector<int> widthsFor(int width, int height, std::size_t max_bytes);

  // The levels of the file `open_band` opens within `max_bytes`, or nullptr
  // when widthsFor gives none: means of the heights `voids` makes of the
  // samples it does not call voids (NaN where a block has none); the
  // implausible ones are counted into `voids`. Reads with up to a thread per
  // core, each on a handle of its own. Throws InputError when GDAL cannot
  // read the file.
  static std::shared_ptr<const ReducedLevels> build(const BandOpener& open_band, const VoidRule& voids,
                                                    const std::string& path, std::size_t max_bytes = kMaxBytes);
  std::size_t count() const { return m_levels.size(); }
  int widthOf(std::size_t level) const { return m_levels[level].width; }

  // A dataset of its own over level `level`'s shared pixels, for one reader,
  // georeferenced from the file's north-up geotransform and CRS (WKT).
  GDALDataset* open(std::size_t level, const double* file_gt, const std::string& wkt) const;

 private:
  struct Level {
    int factor = 1;
    int width = 0, height = 0;
    std::vector<float> heights;
  };
  std::vector<Level> m_levels;
};

}  // namespace terrabake::dem
