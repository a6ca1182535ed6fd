// Gaussian and summed-area-table filtering of moment depth maps (assignment "Filter the shadow
// map"; thesis §6.2).
#include "transient/reconstruct/moment_filter.h"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>

#include "absl/strings/str_cat.h"
#include "separable_passes.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/smoothing.h"

namespace transient {
namespace {


// True when any of values[0, count) is NaN or infinite: an all-ones exponent, tested on the bits
// so that the loop vectorizes (std::isfinite does not under GCC without -ffinite-math).
bool AnyNonFinite(const float* values, int64_t count) {
  uint32_t bad = 0;
#pragma omp simd reduction(| : bad)
  for (int64_t i = 0; i < count; ++i) {
    const uint32_t exponent = std::bit_cast<uint32_t>(values[i]) & 0x7f800000u;
    bad |= static_cast<uint32_t>(exponent == 0x7f800000u);
  }
  return bad != 0;
}

// InvalidArgument naming the first non-finite value of `planes`, or OK. Rows in parallel; the
// slow search for the culprit runs only when there is one.
absl::Status CheckFinite(ImageGeometry geometry, int channels, std::span<const float> planes) {
  const int64_t rows = int64_t{channels} * geometry.height;
  const int width = geometry.width;
  int bad_rows = 0;
#pragma omp parallel for num_threads(KernelThreads()) schedule(static) reduction(+ : bad_rows)
  for (int64_t row = 0; row < rows; ++row) {
    bad_rows += AnyNonFinite(planes.data() + row * width, width) ? 1 : 0;
  }
  if (bad_rows == 0) return absl::OkStatus();
  const int64_t pixels = geometry.pixel_count();
  for (int64_t i = 0; i < static_cast<int64_t>(planes.size()); ++i) {
    if (!std::isfinite(planes[static_cast<size_t>(i)])) {
      const int64_t p = i % pixels;
      return absl::InvalidArgumentError(absl::StrCat(
          "input value ", planes[static_cast<size_t>(i)], " at channel ", i / pixels, ", pixel (x ",
          p % width, ", y ", p / width, "). Violated constraint: every value finite (mark pixels ",
          "without data with zero moments and weight 0 instead of NaN)"));
    }
  }
  assert(false && "a non-finite row without a non-finite value");
  return absl::InternalError("non-finite check disagrees with std::isfinite");
}

absl::Status CheckOutputSize(ImageGeometry geometry, int channels, std::span<float> out) {
  const int64_t expected = int64_t{channels} * geometry.pixel_count();
  if (static_cast<int64_t>(out.size()) != expected) {
    return absl::InvalidArgumentError(absl::StrCat(
        "output size = ", out.size(), ". Violated constraint: channels * width * height = ",
        channels, " * ", geometry.width, " * ", geometry.height, " = ", expected));
  }
  return absl::OkStatus();
}

// The separable passes' rows (RowPass, ColumnPass) are separable_passes.h's, shared with the
// smoothing of moment images (smoothing.cc).
using internal::ColumnPass;
using internal::RowPass;

// Rows [y, y + kRows) of one channel's table: table row y + 1 + i = table row y + i + the prefix
// sums of image row y + i (thesis §6.2's row pass then column pass, fused so that the table is
// written once). The rows are interleaved so that their running sums (serial chains of double
// additions) overlap in the pipeline. `table` points at table row y.
template <int kRows>
void SatRows(const float* in, int width, double* table, int64_t table_stride) {
  double running[kRows] = {};
  for (int i = 0; i < kRows; ++i) table[(i + 1) * table_stride] = 0.0;
  for (int x = 0; x < width; ++x) {
    for (int i = 0; i < kRows; ++i) {
      running[i] += static_cast<double>(in[int64_t{i} * width + x]);
      table[(i + 1) * table_stride + x + 1] = table[i * table_stride + x + 1] + running[i];
    }
  }
}

}  // namespace

absl::Status ValidatePlanes(ImageGeometry geometry, int channels, std::span<const float> planes) {
  if (geometry.width <= 0 || geometry.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("image size = ", geometry.width, " x ",
                                                   geometry.height,
                                                   ". Violated constraint: width, height > 0"));
  }
  if (channels < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("channels = ", channels, ". Violated constraint: channels >= 1"));
  }
  const int64_t expected = int64_t{channels} * geometry.pixel_count();
  if (static_cast<int64_t>(planes.size()) != expected) {
    return absl::InvalidArgumentError(absl::StrCat(
        "input size = ", planes.size(), ". Violated constraint: channels * width * height = ",
        channels, " * ", geometry.width, " * ", geometry.height, " = ", expected));
  }
  return absl::OkStatus();
}

// --- Gaussian ---------------------------------------------------------------------------------

GaussianMomentFilter::GaussianMomentFilter(double sigma_px, ImageGeometry geometry, int channels)
    : sigma_px_(sigma_px), geometry_(geometry), channels_(channels) {
  const std::vector<double> half = GaussianHalfKernel(sigma_px);
  double sum = half[0];
  for (size_t d = 1; d < half.size(); ++d) sum += 2.0 * half[d];
  kernel_.resize(half.size());
  for (size_t d = 0; d < half.size(); ++d) kernel_[d] = static_cast<float>(half[d] / sum);
}

absl::StatusOr<GaussianMomentFilter> GaussianMomentFilter::Create(double sigma_px,
                                                                  ImageGeometry geometry,
                                                                  int channels) {
  if (!(sigma_px > 0.0 && std::isfinite(sigma_px))) {
    return absl::InvalidArgumentError(
        absl::StrCat("sigma_px = ", sigma_px, ". Violated constraint: finite and sigma_px > 0"));
  }
  if (geometry.width <= 0 || geometry.height <= 0 || channels < 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "image size = ", geometry.width, " x ", geometry.height, ", channels = ", channels,
        ". Violated constraint: width, height > 0 and channels >= 1"));
  }
  // In double first: a huge sigma must not overflow the int radius.
  const double width_px = 2.0 * std::ceil(3.0 * sigma_px) + 1.0;
  if (width_px > std::min(geometry.width, geometry.height)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "sigma_px = ", sigma_px, " gives a filter of 2 * ceil(3 * sigma) + 1 = ", width_px,
        " px, wider than the image of ", geometry.width, " x ", geometry.height,
        " px. Violated constraint: 2 * ceil(3 * sigma_px) + 1 <= min(width, height)"));
  }
  return GaussianMomentFilter(sigma_px, geometry, channels);
}

absl::Status GaussianMomentFilter::CheckInput(std::span<const float> in,
                                              std::span<float> out) const {
  if (absl::Status status = ValidatePlanes(geometry_, channels_, in); !status.ok()) return status;
  if (absl::Status status = CheckOutputSize(geometry_, channels_, out); !status.ok()) {
    return status;
  }
  return CheckFinite(geometry_, channels_, in);
}

absl::Status GaussianMomentFilter::Apply(std::span<const float> in, std::span<float> out) const {
  if (absl::Status status = CheckInput(in, out); !status.ok()) return status;
  assert(in.data() + in.size() <= out.data() || out.data() + out.size() <= in.data());
  const int width = geometry_.width;
  const int height = geometry_.height;
  const int64_t pixels = geometry_.pixel_count();
  const int r = radius();
  const int window = 2 * r + 1;
  const float* kernel = kernel_.data();
  // Work items are bands of output rows of one channel, about four per thread. Each keeps the
  // row-filtered source rows its column pass needs in a ring of 2r + 1 rows (L1/L2-resident),
  // so the intermediate image never travels to memory; a band re-filters the r rows beyond
  // each of its ends (4r rows per band of height / bands, a few percent).
  const int threads = KernelThreads();
  const int bands_per_channel =
      std::clamp((4 * threads + channels_ - 1) / channels_, 1, std::max(1, height / window));
  const int band_height = (height + bands_per_channel - 1) / bands_per_channel;
  const int items = channels_ * bands_per_channel;

#pragma omp parallel num_threads(threads)
  {
    std::vector<float> padded(static_cast<size_t>(width + 2 * r));
    std::vector<float> ring(static_cast<size_t>(window) * width);
    std::vector<const float*> rows(static_cast<size_t>(window));
    auto slot = [&](int source_y) {  // ring row of (unclamped) source row source_y
      return ring.data() + int64_t{((source_y % window) + window) % window} * width;
    };
#pragma omp for schedule(dynamic, 1)
    for (int item = 0; item < items; ++item) {
      const int64_t channel = item / bands_per_channel;
      const int y_begin = (item % bands_per_channel) * band_height;
      const int y_end = std::min(height, y_begin + band_height);
      const float* plane = in.data() + channel * pixels;
      // Row pass of source row source_y (clamped to the image) into its ring slot.
      auto filter_row = [&](int source_y) {
        const float* src = plane + int64_t{std::clamp(source_y, 0, height - 1)} * width;
        std::fill_n(padded.begin(), r, src[0]);
        std::copy_n(src, width, padded.begin() + r);
        std::fill_n(padded.begin() + r + width, r, src[width - 1]);
        RowPass(kernel, r, padded.data() + r, width, slot(source_y));
      };
      for (int source_y = y_begin - r; source_y < y_begin + r; ++source_y) filter_row(source_y);
      for (int y = y_begin; y < y_end; ++y) {
        filter_row(y + r);  // overwrites y - r - 1, which no output row from y on needs
        for (int d = -r; d <= r; ++d) rows[static_cast<size_t>(d + r)] = slot(y + d);
        ColumnPass(kernel, r, rows.data(), width,
                   out.data() + channel * pixels + int64_t{y} * width);
      }
    }
  }
  return absl::OkStatus();
}

absl::Status GaussianMomentFilter::ApplyReference(std::span<const float> in,
                                                  std::span<float> out) const {
  if (absl::Status status = CheckInput(in, out); !status.ok()) return status;
  const int width = geometry_.width;
  const int height = geometry_.height;
  const int64_t pixels = geometry_.pixel_count();
  const int r = radius();
  const int size = 2 * r + 1;
  // The 2-D weights straight from the Gaussian, not as a product of the 1-D kernels.
  std::vector<double> weights(static_cast<size_t>(size * size));
  double total = 0.0;
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const double w = std::exp(-(dx * dx + dy * dy) / (2.0 * sigma_px_ * sigma_px_));
      weights[static_cast<size_t>((dy + r) * size + dx + r)] = w;
      total += w;
    }
  }
  for (int k = 0; k < channels_; ++k) {
    const float* plane = in.data() + k * pixels;
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        double sum = 0.0;
        for (int dy = -r; dy <= r; ++dy) {
          const int64_t source_row = int64_t{std::clamp(y + dy, 0, height - 1)} * width;
          for (int dx = -r; dx <= r; ++dx) {
            sum += weights[static_cast<size_t>((dy + r) * size + dx + r)] *
                   plane[source_row + std::clamp(x + dx, 0, width - 1)];
          }
        }
        out[static_cast<size_t>(k * pixels + int64_t{y} * width + x)] =
            static_cast<float>(sum / total);
      }
    }
  }
  return absl::OkStatus();
}

// --- Summed-area table ------------------------------------------------------------------------

absl::StatusOr<SummedAreaTable> SummedAreaTable::Build(ImageGeometry geometry, int channels,
                                                       std::span<const float> planes) {
  if (absl::Status status = ValidatePlanes(geometry, channels, planes); !status.ok()) {
    return status;
  }
  if (absl::Status status = CheckFinite(geometry, channels, planes); !status.ok()) return status;
  SummedAreaTable sat;
  sat.geometry_ = geometry;
  sat.channels_ = channels;
  const int width = geometry.width;
  const int height = geometry.height;
  const int64_t stride = int64_t{width} + 1;
  sat.plane_size_ = stride * (int64_t{height} + 1);
  // Every entry is written below (row 0 here, column 0 and the rest in SatRows): no zero fill.
  sat.table_ = std::vector<double>(static_cast<size_t>(channels * sat.plane_size_));
  const int64_t pixels = geometry.pixel_count();
  // Rows depend on the row above, channels do not: one thread per channel.
#pragma omp parallel for num_threads(std::min(KernelThreads(), channels)) schedule(static, 1)
  for (int k = 0; k < channels; ++k) {
    const float* in = planes.data() + k * pixels;
    double* table = sat.table_.data() + k * sat.plane_size_;
    std::fill_n(table, stride, 0.0);
    int y = 0;
    for (; y + 4 <= height; y += 4)
      SatRows<4>(in + int64_t{y} * width, width, table + y * stride, stride);
    for (; y < height; ++y) SatRows<1>(in + int64_t{y} * width, width, table + y * stride, stride);
  }
  return sat;
}

bool SummedAreaTable::Clamp(int x0, int y0, int x1, int y1, Box* box) const {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, geometry_.width - 1);
  y1 = std::min(y1, geometry_.height - 1);
  if (x1 < x0 || y1 < y0) return false;
  const int64_t stride = int64_t{geometry_.width} + 1;
  // Half-open table indices: [x0, x1 + 1) x [y0, y1 + 1).
  box->top_left = y0 * stride + x0;
  box->top_right = y0 * stride + x1 + 1;
  box->bottom_left = (int64_t{y1} + 1) * stride + x0;
  box->bottom_right = (int64_t{y1} + 1) * stride + x1 + 1;
  box->area = (int64_t{x1} - x0 + 1) * (int64_t{y1} - y0 + 1);
  return true;
}

int64_t SummedAreaTable::BoxArea(int x0, int y0, int x1, int y1) const {
  Box box;
  return Clamp(x0, y0, x1, y1, &box) ? box.area : 0;
}

double SummedAreaTable::BoxSum(int channel, int x0, int y0, int x1, int y1) const {
  assert(channel >= 0 && channel < channels_);
  Box box;
  if (!Clamp(x0, y0, x1, y1, &box)) return 0.0;
  const double* t = table_.data() + channel * plane_size_;
  return (t[box.bottom_right] - t[box.top_right]) - (t[box.bottom_left] - t[box.top_left]);
}

double SummedAreaTable::BoxMean(int channel, int x0, int y0, int x1, int y1) const {
  assert(channel >= 0 && channel < channels_);
  Box box;
  if (!Clamp(x0, y0, x1, y1, &box)) return 0.0;
  const double* t = table_.data() + channel * plane_size_;
  return ((t[box.bottom_right] - t[box.top_right]) - (t[box.bottom_left] - t[box.top_left])) /
         static_cast<double>(box.area);
}

int64_t SummedAreaTable::BoxMeans(int x0, int y0, int x1, int y1, std::span<double> means) const {
  assert(static_cast<int>(means.size()) >= channels_);
  Box box;
  if (!Clamp(x0, y0, x1, y1, &box)) {
    std::fill_n(means.begin(), channels_, 0.0);
    return 0;
  }
  const double inverse_area = 1.0 / static_cast<double>(box.area);
  for (int k = 0; k < channels_; ++k) {
    const double* t = table_.data() + k * plane_size_;
    means[static_cast<size_t>(k)] =
        ((t[box.bottom_right] - t[box.top_right]) - (t[box.bottom_left] - t[box.top_left])) *
        inverse_area;
  }
  return box.area;
}

}  // namespace transient
