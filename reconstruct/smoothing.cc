// Gaussian smoothing of moment images over valid pixels (thesis §8.5).
#include "transient/reconstruct/smoothing.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "absl/strings/str_cat.h"
#include "kernels_internal.h"
#include "separable_passes.h"

namespace transient {
namespace {

// The separable passes, row by row (separable_passes.h): out(p) = sum_d k[|d|] in(p + d) along
// the row, then along the column, with pixels outside the image counting as 0 (their weight is 0
// in the denominator too, which is what renormalises the borders: zero padding in the row,
// a row of zeros for the rows beyond the top and bottom). Output row y needs the row-passed
// input rows y - r .. y + r, which a ring of 2r + 1 rows holds: each input row is read and
// row-passed once, just before the first output row that needs it. Input row y + r is read
// before output row y is written, so `emit` may write over the input in place.
struct RowScratch {
  std::vector<float> padded, ring, zeros, out;
  std::vector<const float*> sources;
};

template <typename Fill, typename Emit>
void SmoothRows(const std::vector<float>& kernel, int width, int height, RowScratch& s, Fill fill,
                Emit emit) {
  const int radius = static_cast<int>(kernel.size()) - 1;
  const int rows = 2 * radius + 1;
  s.padded.assign(static_cast<size_t>(width + 2 * radius), 0.0f);
  s.ring.resize(static_cast<size_t>(rows) * width);
  s.zeros.assign(static_cast<size_t>(width), 0.0f);
  s.out.resize(static_cast<size_t>(width));
  s.sources.resize(static_cast<size_t>(rows));
  float* const center = s.padded.data() + radius;
  const auto ring_row = [&](int y) {
    return s.ring.data() + static_cast<int64_t>(y % rows) * width;
  };
  const auto row_pass = [&](int y) {
    fill(y, center);  // width values; the padding stays 0
    internal::RowPass(kernel.data(), radius, center, width, ring_row(y));
  };
  for (int y = 0; y < std::min(radius, height); ++y) row_pass(y);
  for (int y = 0; y < height; ++y) {
    if (y + radius < height) row_pass(y + radius);
    for (int d = -radius; d <= radius; ++d) {
      const bool inside = y + d >= 0 && y + d < height;
      s.sources[static_cast<size_t>(d + radius)] = inside ? ring_row(y + d) : s.zeros.data();
    }
    internal::ColumnPass(kernel.data(), radius, s.sources.data(), width, s.out.data());
    emit(y, static_cast<const float*>(s.out.data()));
  }
}

}  // namespace

int GaussianRadius(double sigma_px) {
  assert(sigma_px > 0.0);
  return static_cast<int>(std::ceil(3.0 * sigma_px));
}

std::vector<double> GaussianHalfKernel(double sigma_px) {
  assert(sigma_px > 0.0 && std::isfinite(sigma_px));
  std::vector<double> kernel(static_cast<size_t>(GaussianRadius(sigma_px) + 1));
  kernel[0] = 1.0;  // not exp(-0 / sigma^2): a sigma^2 that underflows to 0 would give NaN
  for (size_t d = 1; d < kernel.size(); ++d) {
    const double dd = static_cast<double>(d);
    kernel[d] = std::exp(-0.5 * (dd * dd) / (sigma_px * sigma_px));
  }
  return kernel;
}

absl::Status ValidateSmoothingSigma(double sigma_px) {
  if (!(sigma_px >= 0.0 && sigma_px <= kMaxSmoothingSigmaPx)) {
    return absl::InvalidArgumentError(
        absl::StrCat("sigma_px = ", sigma_px,
                     ". Violated constraint: finite and 0 <= sigma_px <= ", kMaxSmoothingSigmaPx));
  }
  return absl::OkStatus();
}

absl::Status GaussianSmooth(double sigma_px, MomentImage* moments, std::span<const int> planes) {
  if (absl::Status status = ValidateSmoothingSigma(sigma_px); !status.ok()) return status;
  if (absl::Status status = moments->Validate(); !status.ok()) return status;
  if (sigma_px == 0.0) return absl::OkStatus();

  const int width = moments->geometry.width;
  const int height = moments->geometry.height;
  const int64_t pixels = moments->geometry.pixel_count();
  const int m = moments->order;
  const std::vector<double> half_kernel = GaussianHalfKernel(sigma_px);
  const std::vector<float> kernel(half_kernel.begin(), half_kernel.end());

  // The planes to smooth, each on its own: in parallel on KernelThreads() threads, each with
  // its scratch planes, the same arithmetic whatever the number of threads. The daemon smooths
  // every frame: its buffers (a VGA plane is 1.2 MB) are kept from call to call, per thread.
  std::vector<float*> targets;
  auto add_both = [&](int j) {
    targets.push_back(moments->real_plane(j));
    targets.push_back(moments->imag_plane(j));
  };
  if (planes.empty()) {
    for (int j = 0; j <= m; ++j) add_both(j);
  }
  for (int j : planes) {
    assert(j >= 0 && j <= m);
    add_both(j);
  }
  // Each thread's scratch rows, kept from call to call: a thread_local named in the parallel
  // bodies below is the running thread's own. So the weights and their norm, shared by every
  // thread, are passed to them as pointers.
  thread_local RowScratch scratch;
  thread_local std::vector<float> weight, norm;
  weight.resize(static_cast<size_t>(pixels));
  norm.resize(static_cast<size_t>(pixels));
  float* const weights = weight.data();
  float* const norms = norm.data();
  // Weights: valid and finite in every plane (a NaN in a "valid" pixel must not spread). Plane
  // by plane, so that the loops vectorize (|v| <= the largest float is isfinite(v), false for
  // NaN and infinities, in a form GCC vectorizes).
  internal::ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
    const uint8_t* valid = moments->valid.empty() ? nullptr : moments->valid.data();
    for (int64_t p = begin; p < end; ++p) {
      weights[p] = valid == nullptr || valid[p] != 0 ? 1.0f : 0.0f;
    }
    constexpr float kLargest = std::numeric_limits<float>::max();
    for (int j = 0; j <= m; ++j) {
      const float* re = moments->real_plane(j);
      const float* im = moments->imag_plane(j);
      for (int64_t p = begin; p < end; ++p) {
        const float real_finite = std::abs(re[p]) <= kLargest ? weights[p] : 0.0f;
        weights[p] = std::abs(im[p]) <= kLargest ? real_finite : 0.0f;
      }
    }
  });
  const auto row_of = [width](auto* plane, int y) {
    return plane + static_cast<int64_t>(y) * width;
  };
  SmoothRows(
      kernel, width, height, scratch,
      [&](int y, float* row) { std::copy_n(row_of(weights, y), width, row); },
      [&](int y, const float* smoothed) { std::copy_n(smoothed, width, row_of(norms, y)); });
  internal::ParallelBlocks(
      static_cast<int64_t>(targets.size()),
      [&](int64_t begin, int64_t end) {
        RowScratch& s = scratch;  // this thread's
        for (int64_t t = begin; t < end; ++t) {
          float* plane = targets[static_cast<size_t>(t)];
          SmoothRows(
              kernel, width, height, s,
              [&](int y, float* row) {
                const float* w = row_of(weights, y);
                const float* in = row_of(plane, y);
#pragma omp simd
                for (int x = 0; x < width; ++x) {
                  const float value = in[x];
                  row[x] = w[x] != 0.0f ? value : 0.0f;
                }
              },
              [&](int y, const float* smoothed) {
                const float* w = row_of(weights, y);
                const float* n = row_of(norms, y);
                // Divided everywhere, then selected (a division under a condition stays scalar).
                float* out = row_of(plane, y);
#pragma omp simd
                for (int x = 0; x < width; ++x) {
                  const float value = smoothed[x] / n[x], before = out[x];
                  out[x] = w[x] != 0.0f ? value : before;
                }
              });
        }
      },
      1);
  return absl::OkStatus();
}

}  // namespace transient
