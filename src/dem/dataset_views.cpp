#include "dem/dataset_views.hpp"

#include <gdal_vrt.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

namespace terrabake::dem {
namespace {

// A file whose rows are stored south-up or whose columns run east to west
// (a negative pixel height or width), seen north-up: one band, the chosen
// one, read through a mirror, with the geotransform of the same pixels in
// north-up order. Every later step then sees the terrain as in any north-up
// file, so both give the same tiles.
class MirroredDataset final : public GDALDataset {
 public:
  MirroredDataset(DatasetPtr source, int band, bool flip_x, bool flip_y, const double* north_up_gt);
  CPLErr GetGeoTransform(double* gt) override {
    std::copy(m_gt, m_gt + 6, gt);
    return CE_None;
  }
  const OGRSpatialReference* GetSpatialRef() const override { return m_source->GetSpatialRef(); }

 private:
  DatasetPtr m_source;
  double m_gt[6];
};

class MirroredBand final : public GDALRasterBand {
 public:
  MirroredBand(MirroredDataset* owner, GDALRasterBand* source, bool flip_x, bool flip_y)
      : m_source(source), m_flip_x(flip_x), m_flip_y(flip_y) {
    poDS = owner;
    nBand = 1;
    nRasterXSize = source->GetXSize();
    nRasterYSize = source->GetYSize();
    eDataType = source->GetRasterDataType();
    nBlockXSize = std::min(nRasterXSize, 256);
    nBlockYSize = std::min(nRasterYSize, 256);
  }
  double GetNoDataValue(int* has_nodata) override { return m_source->GetNoDataValue(has_nodata); }

 protected:
  CPLErr IReadBlock(int block_x, int block_y, void* data) override {
    const int x = block_x * nBlockXSize, y = block_y * nBlockYSize;
    const int w = std::min(nBlockXSize, nRasterXSize - x), h = std::min(nBlockYSize, nRasterYSize - y);
    const int size = GDALGetDataTypeSizeBytes(eDataType);
    return IRasterIO(GF_Read, x, y, w, h, data, w, h, eDataType, size, GSpacing(size) * nBlockXSize, nullptr);
  }

  // The mirrored window of the source, read into the buffer, then mirrored
  // in place: columns reversed within each row, rows in reverse order.
  CPLErr IRasterIO(GDALRWFlag flag, int x, int y, int w, int h, void* data, int buffer_w, int buffer_h,
                   GDALDataType type, GSpacing pixel_space, GSpacing line_space, GDALRasterIOExtraArg*) override {
    if (flag != GF_Read) return CE_Failure;
    const int source_x = m_flip_x ? nRasterXSize - x - w : x;
    const int source_y = m_flip_y ? nRasterYSize - y - h : y;
    const CPLErr read = m_source->RasterIO(GF_Read, source_x, source_y, w, h, data, buffer_w, buffer_h, type,
                                           pixel_space, line_space, nullptr);
    if (read != CE_None) return read;
    const std::size_t size = std::size_t(GDALGetDataTypeSizeBytes(type));
    auto* bytes = static_cast<GByte*>(data);
    unsigned char swap[16];
    const auto exchange = [&](GByte* a, GByte* b) {
      std::memcpy(swap, a, size);
      std::memcpy(a, b, size);
      std::memcpy(b, swap, size);
    };
    if (m_flip_x) {
      for (int r = 0; r < buffer_h; ++r) {
        GByte* row = bytes + r * line_space;
        for (int a = 0, b = buffer_w - 1; a < b; ++a, --b) exchange(row + a * pixel_space, row + b * pixel_space);
      }
    }
    if (m_flip_y) {
      for (int a = 0, b = buffer_h - 1; a < b; ++a, --b) {
        for (int c = 0; c < buffer_w; ++c) {
          exchange(bytes + a * line_space + c * pixel_space, bytes + b * line_space + c * pixel_space);
        }
      }
    }
    return CE_None;
  }

 private:
  GDALRasterBand* m_source;
  bool m_flip_x, m_flip_y;
};

MirroredDataset::MirroredDataset(DatasetPtr source, int band, bool flip_x, bool flip_y, const double* north_up_gt)
    : m_source(std::move(source)) {
  nRasterXSize = m_source->GetRasterXSize();
  nRasterYSize = m_source->GetRasterYSize();
  std::copy(north_up_gt, north_up_gt + 6, m_gt);
  SetBand(1, new MirroredBand(this, m_source->GetRasterBand(band), flip_x, flip_y));
}

// Blocks of a masked band are at most this many pixels a side: a driver
// that reads its raster as one block would otherwise make one of the whole
// file.
constexpr int kMaxMaskedBlockSide = 1024;

// maskedView's: NaN where the mask band reads 0, or no covered box holds
// the pixel's centre.
class MaskedDataset final : public GDALDataset {
 public:
  MaskedDataset(DatasetPtr source, int band, NoDataMask mask, bool signed_bytes);
  CPLErr GetGeoTransform(double* gt) override { return m_source->GetGeoTransform(gt); }
  const OGRSpatialReference* GetSpatialRef() const override { return m_source->GetSpatialRef(); }

 private:
  DatasetPtr m_source;
};

class MaskedBand final : public GDALRasterBand {
 public:
  // `mask`: null where only `covered` marks the voids.
  MaskedBand(MaskedDataset* owner, GDALRasterBand* source, GDALRasterBand* mask, std::vector<Extent> covered,
             bool signed_bytes)
      : m_source(source), m_mask(mask), m_covered(std::move(covered)), m_signed_bytes(signed_bytes) {
    poDS = owner;
    nBand = 1;
    nRasterXSize = source->GetXSize();
    nRasterYSize = source->GetYSize();
    eDataType = GDT_Float32;
    source->GetBlockSize(&nBlockXSize, &nBlockYSize);
    nBlockXSize = std::clamp(nBlockXSize, 1, std::min(nRasterXSize, kMaxMaskedBlockSide));
    nBlockYSize = std::clamp(nBlockYSize, 1, std::min(nRasterYSize, kMaxMaskedBlockSide));
  }

 protected:
  CPLErr IReadBlock(int block_x, int block_y, void* data) override {
    const int x = block_x * nBlockXSize, y = block_y * nBlockYSize;
    const int w = std::min(nBlockXSize, nRasterXSize - x), h = std::min(nBlockYSize, nRasterYSize - y);
    return read(x, y, w, h, static_cast<float*>(data), w, h, std::size_t(nBlockXSize), nullptr);
  }

  // Every read goes to the source in one call, whatever its window: through
  // blocks, a VRT of many sources would walk them all once a block, and a
  // read sampling fewer pixels than its window would read every one.
  CPLErr IRasterIO(GDALRWFlag flag, int x, int y, int w, int h, void* data, int buffer_w, int buffer_h,
                   GDALDataType type, GSpacing pixel_space, GSpacing line_space, GDALRasterIOExtraArg* extra) override {
    if (flag != GF_Read) return CE_Failure;
    if (type == GDT_Float32 && pixel_space == GSpacing(sizeof(float)) && line_space % GSpacing(sizeof(float)) == 0) {
      return read(x, y, w, h, static_cast<float*>(data), buffer_w, buffer_h, std::size_t(line_space) / sizeof(float),
                  extra);
    }
    m_heights.resize(std::size_t(buffer_w) * std::size_t(buffer_h));
    if (read(x, y, w, h, m_heights.data(), buffer_w, buffer_h, std::size_t(buffer_w), extra) != CE_None) {
      return CE_Failure;
    }
    for (int r = 0; r < buffer_h; ++r) {
      GDALCopyWords(&m_heights[std::size_t(r) * std::size_t(buffer_w)], GDT_Float32, sizeof(float),
                    static_cast<GByte*>(data) + r * line_space, type, int(pixel_space), buffer_w);
    }
    return CE_None;
  }

 private:
  // The window at (x, y), w by h pixels, sampled onto buffer_w x buffer_h
  // heights at `out`, rows `stride` apart: NaN where there is no data.
  CPLErr read(int x, int y, int w, int h, float* out, int buffer_w, int buffer_h, std::size_t stride,
              GDALRasterIOExtraArg* extra) {
    if (m_source->RasterIO(GF_Read, x, y, w, h, out, buffer_w, buffer_h, GDT_Float32, sizeof(float),
                           GSpacing(stride * sizeof(float)), extra) != CE_None) {
      return CE_Failure;
    }
    // Of each sample, whether it holds data: an alpha band's partial
    // transparency still does.
    m_opacity.assign(std::size_t(buffer_w) * std::size_t(buffer_h), 255);
    if (m_mask &&
        m_mask->RasterIO(GF_Read, x, y, w, h, m_opacity.data(), buffer_w, buffer_h, GDT_Byte, 0, 0, extra) != CE_None) {
      return CE_Failure;
    }
    if (!m_covered.empty()) keepCovered(x, y, w, h, buffer_w, buffer_h);
    for (int r = 0; r < buffer_h; ++r) {
      float* const line = &out[std::size_t(r) * stride];
      const GByte* const opacity = &m_opacity[std::size_t(r) * std::size_t(buffer_w)];
      for (int c = 0; c < buffer_w; ++c) {
        if (m_signed_bytes && line[c] >= 128) line[c] -= 256;
        if (opacity[c] == 0) line[c] = NAN;
      }
    }
    return CE_None;
  }

  // Zeroes the opacity of the samples whose pixels' centres lie in no
  // covered box; a sample is of the pixel that holds its centre, as GDAL's
  // nearest sampling takes it.
  void keepCovered(int x, int y, int w, int h, int buffer_w, int buffer_h) {
    const auto sampled = [](int first, int count, int samples, std::vector<int>& pixels) {
      pixels.resize(std::size_t(samples));
      for (int k = 0; k < samples; ++k) pixels[std::size_t(k)] = first + int(std::floor((k + 0.5) * count / samples));
    };
    sampled(x, w, buffer_w, m_columns);
    sampled(y, h, buffer_h, m_rows);
    // The first sample whose pixel's centre lies at or past `edge`, a
    // fraction of `size` pixels.
    const auto firstFrom = [](const std::vector<int>& pixels, double edge, int size) {
      const int pixel = int(std::ceil(edge * size - 0.5));
      return int(std::lower_bound(pixels.begin(), pixels.end(), pixel) - pixels.begin());
    };
    m_in_box.assign(m_opacity.size(), 0);
    for (const Extent& box : m_covered) {
      const int c0 = firstFrom(m_columns, box.min_x, nRasterXSize), c1 = firstFrom(m_columns, box.max_x, nRasterXSize);
      const int r0 = firstFrom(m_rows, box.min_y, nRasterYSize), r1 = firstFrom(m_rows, box.max_y, nRasterYSize);
      for (int r = r0; r < r1 && c0 < c1; ++r) {
        std::fill_n(&m_in_box[std::size_t(r) * std::size_t(buffer_w) + std::size_t(c0)], c1 - c0, 1);
      }
    }
    for (std::size_t i = 0; i < m_opacity.size(); ++i) m_opacity[i] = m_in_box[i] ? m_opacity[i] : 0;
  }

  GDALRasterBand* m_source;
  GDALRasterBand* m_mask;
  std::vector<Extent> m_covered;
  bool m_signed_bytes;
  // Of the read in progress (a view is read by one thread):
  std::vector<float> m_heights;  // in Float32, where another type was asked for
  std::vector<GByte> m_opacity;
  std::vector<GByte> m_in_box;
  std::vector<int> m_columns, m_rows;  // the pixel each sample is of
};

MaskedDataset::MaskedDataset(DatasetPtr source, int band, NoDataMask mask, bool signed_bytes)
    : m_source(std::move(source)) {
  nRasterXSize = m_source->GetRasterXSize();
  nRasterYSize = m_source->GetRasterYSize();
  GDALRasterBand* heights = m_source->GetRasterBand(band);
  GDALRasterBand* mask_band = mask.alpha_band  ? m_source->GetRasterBand(mask.alpha_band)
                              : mask.mask_band ? heights->GetMaskBand()
                                               : nullptr;
  SetBand(1, new MaskedBand(this, heights, mask_band, std::move(mask.covered), signed_bytes));
}

}  // namespace

DatasetPtr mirroredView(DatasetPtr source, int band, bool flip_x, bool flip_y, const double* north_up_gt) {
  return DatasetPtr(new MirroredDataset(std::move(source), band, flip_x, flip_y, north_up_gt));
}

NoDataMask noDataMaskOf(GDALDataset& file, int band) {
  NoDataMask mask;
  for (int b = 1; b <= file.GetRasterCount() && !mask.alpha_band; ++b) {
    if (b != band && file.GetRasterBand(b)->GetColorInterpretation() == GCI_AlphaBand) mask.alpha_band = b;
  }
  // GDAL's mask of a band with a nodata value is that value, and one of a
  // band without any reads all valid.
  mask.mask_band = !mask.alpha_band && (file.GetRasterBand(band)->GetMaskFlags() & (GMF_ALL_VALID | GMF_NODATA)) == 0;
  return mask;
}

DatasetPtr maskedView(DatasetPtr source, int band, NoDataMask mask, bool signed_bytes) {
  return DatasetPtr(new MaskedDataset(std::move(source), band, std::move(mask), signed_bytes));
}

bool holdsSignedBytes(GDALDataset& file, int band) {
  GDALRasterBand* heights = file.GetRasterBand(band);
  const char* pixel_type = heights->GetMetadataItem("PIXELTYPE", "IMAGE_STRUCTURE");
  return heights->GetRasterDataType() == GDT_Byte && pixel_type && EQUAL(pixel_type, "SIGNEDBYTE");
}

DatasetPtr decimatedView(GDALDataset& level, int band, int factor) {
  const int width = level.GetRasterXSize(), height = level.GetRasterYSize();
  const int w = std::max(1, (width + factor - 1) / factor), h = std::max(1, (height + factor - 1) / factor);
  VRTDatasetH vrt = VRTCreate(w, h);
  if (!vrt) return nullptr;
  double gt[6];
  level.GetGeoTransform(gt);
  gt[1] *= double(width) / w;
  gt[5] *= double(height) / h;
  GDALSetGeoTransform(vrt, gt);
  GDALSetProjection(vrt, level.GetProjectionRef());
  GDALRasterBand* source = level.GetRasterBand(band);
  VRTAddBand(vrt, source->GetRasterDataType(), nullptr);
  if (VRTAddSimpleSource(GDALGetRasterBand(vrt, 1), GDALRasterBand::ToHandle(source), 0, 0, width, height, 0, 0,
                         w, h, "near", VRT_NODATA_UNSET) != CE_None) {
    GDALClose(vrt);
    return nullptr;
  }
  return DatasetPtr(GDALDataset::FromHandle(vrt));
}

}  // namespace terrabake::dem
