// Gaussian smoothing of moment images over valid pixels (thesis §8.5).
#include "transient/reconstruct/smoothing.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

#include "absl/strings/str_cat.h"
#include "kernels_internal.h"

namespace transient {
namespace {

// The separable passes: out(p) = sum_d k[|d|] in(p + d) along a row or a column, with pixels
// outside the image counting as 0 (their weight is 0 in the denominator too, which is what
// renormalises the borders). Written as sums of shifted rows so that the inner loops vectorize.
void HorizontalPass(const std::vector<float>& kernel, int width, int height, const float* in,
                    float* out, std::vector<float>& padded) {
  const int radius = static_cast<int>(kernel.size()) - 1;
  padded.assign(static_cast<size_t>(width + 2 * radius), 0.0f);
  for (int y = 0; y < height; ++y) {
    const float* row = in + static_cast<int64_t>(y) * width;
    float* dst = out + static_cast<int64_t>(y) * width;
    std::copy_n(row, width, padded.data() + radius);
    const float* center = padded.data() + radius;
    for (int x = 0; x < width; ++x) dst[x] = kernel[0] * center[x];
    for (int d = 1; d <= radius; ++d) {
      const float k = kernel[static_cast<size_t>(d)];
      for (int x = 0; x < width; ++x) dst[x] += k * (center[x - d] + center[x + d]);
    }
  }
}

void VerticalPass(const std::vector<float>& kernel, int width, int height, const float* in,
                  float* out) {
  const int radius = static_cast<int>(kernel.size()) - 1;
  for (int y = 0; y < height; ++y) {
    float* dst = out + static_cast<int64_t>(y) * width;
    const float* src = in + static_cast<int64_t>(y) * width;
    for (int x = 0; x < width; ++x) dst[x] = kernel[0] * src[x];
    for (int d = 1; d <= radius; ++d) {
      const float k = kernel[static_cast<size_t>(d)];
      if (y - d >= 0) {
        const float* up = in + static_cast<int64_t>(y - d) * width;
        for (int x = 0; x < width; ++x) dst[x] += k * up[x];
      }
      if (y + d < height) {
        const float* down = in + static_cast<int64_t>(y + d) * width;
        for (int x = 0; x < width; ++x) dst[x] += k * down[x];
      }
    }
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
  // Each thread's scratch, sized at its first use in a call: a thread_local named in the
  // parallel bodies below is the running thread's own. So the weights and their norm, shared by
  // every thread, are passed to them as pointers.
  struct Scratch {
    std::vector<float> masked, tmp, smooth, padded;
    void Reserve(int64_t pixels) {
      for (auto* v : {&masked, &tmp, &smooth}) v->resize(static_cast<size_t>(pixels));
    }
  };
  thread_local Scratch scratch;
  thread_local std::vector<float> weight, norm;
  weight.resize(static_cast<size_t>(pixels));
  norm.resize(static_cast<size_t>(pixels));
  float* const weights = weight.data();
  const float* const norms = norm.data();
  // Weights: valid and finite in every plane (a NaN in a "valid" pixel must not spread).
  internal::ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
    for (int64_t p = begin; p < end; ++p) {
      bool usable = moments->valid.empty() || moments->valid[static_cast<size_t>(p)] != 0;
      for (int j = 0; j <= m && usable; ++j) {
        usable =
            std::isfinite(moments->real_plane(j)[p]) && std::isfinite(moments->imag_plane(j)[p]);
      }
      weights[p] = usable ? 1.0f : 0.0f;
    }
  });
  scratch.Reserve(pixels);
  HorizontalPass(kernel, width, height, weights, scratch.tmp.data(), scratch.padded);
  VerticalPass(kernel, width, height, scratch.tmp.data(), norm.data());
  internal::ParallelBlocks(
      static_cast<int64_t>(targets.size()),
      [&](int64_t begin, int64_t end) {
        Scratch& s = scratch;  // this thread's
        s.Reserve(pixels);
        for (int64_t t = begin; t < end; ++t) {
          float* plane = targets[static_cast<size_t>(t)];
          for (int64_t p = 0; p < pixels; ++p) s.masked[p] = weights[p] != 0.0f ? plane[p] : 0.0f;
          HorizontalPass(kernel, width, height, s.masked.data(), s.tmp.data(), s.padded);
          VerticalPass(kernel, width, height, s.tmp.data(), s.smooth.data());
          for (int64_t p = 0; p < pixels; ++p) {
            if (weights[p] != 0.0f) plane[p] = s.smooth[p] / norms[p];
          }
        }
      },
      1);
  return absl::OkStatus();
}

}  // namespace transient
