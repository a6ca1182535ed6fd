// The optimized kernels: the same products as reference_kernels.cc (the solve is in
// optimized_solve.cc, the MESE range in optimized_range.cc), computed with
// - the MESE denominator written as a real cosine series a_0 + sum_k (alpha_k cos k phi +
//   beta_k sin k phi) whose coefficients are computed once per pixel and whose cos/sin tables
//   are shared by all pixels (thesis eq. 8.4), so all pixels x all phases is a small matrix
//   product followed by a reciprocal, vectorized over pixels;
// - Pisarenko per pixel by PisarenkoByLevinson (optimized_pisarenko.cc), the reference's
//   Pisarenko() where that declines; the cumulative's logarithms as real log and atan
//   (MeseCumulative::Evaluate) with the phases' cosines and sines tabled once;
// - OpenMP threads over blocks of pixels for everything, including the per-pixel solvers
//   (Pisarenko, cumulative, bounds) that stay scalar.
// The series is summed in double: near a sharp peak it cancels to ~eps^2/(m+1)^2 of a_0, which
// float could not resolve; the final division is float (its operands are then exact to 1e-7).
#include <omp.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <vector>

#include "kernels_internal.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/mese.h"

namespace transient::optimized {
namespace {

// Per-pixel cosine-series coefficients of the MESE denominator, planar:
// D(phi) = scale / (a0 + sum_{k=1..m} alpha_k cos(k phi) + beta_k sin(k phi)).
// Invalid pixels get a0 = NaN, which makes every product NaN without a branch.
struct SeriesPlanes {
  int order = 0;
  int64_t pixels = 0;
  std::vector<double> a0, alpha, beta;  // alpha, beta: m planes
  std::vector<float> scale;             // q_0 / (2 pi)
};

// Fills `s` (reusing its buffers) for `solved`.
void MakeSeries(const SolvedImage& solved, SeriesPlanes& s) {
  s.order = solved.order;
  s.pixels = solved.geometry.pixel_count();
  const int m = s.order;
  s.a0.resize(s.pixels);
  s.alpha.resize(m * s.pixels);
  s.beta.resize(m * s.pixels);
  s.scale.resize(s.pixels);
  internal::ParallelBlocks(s.pixels, [&](int64_t begin, int64_t end) {
    std::array<Complex, kMaxMoments> q, a;
    const std::span<Complex> q_span(q.data(), m + 1), a_span(a.data(), m + 1);
    for (int64_t p = begin; p < end; ++p) {
      if (!solved.valid(p)) {
        s.a0[p] = std::numeric_limits<double>::quiet_NaN();
        s.scale[p] = kNaNf;
        for (int k = 0; k < m; ++k) s.alpha[k * s.pixels + p] = s.beta[k * s.pixels + p] = 0.0;
        continue;
      }
      solved.coefficients(p, q_span);
      MeseDenominatorSeries(q_span, a_span);  // 2 Re(a_k e^{ik phi}) = alpha cos + beta sin
      s.a0[p] = a[0].real();
      for (int k = 1; k <= m; ++k) {
        s.alpha[(k - 1) * s.pixels + p] = 2.0 * a[k].real();
        s.beta[(k - 1) * s.pixels + p] = -2.0 * a[k].imag();
      }
      s.scale[p] = static_cast<float>(q[0].real() / kTwoPi);
    }
  });
}

// cos(k phi_n), sin(k phi_n) for k = 1..m: table[n * m + k - 1].
void MakeTables(std::span<const double> phases, int m, std::vector<double>* cosines,
                std::vector<double>* sines) {
  cosines->resize(phases.size() * m);
  sines->resize(phases.size() * m);
  for (size_t n = 0; n < phases.size(); ++n) {
    for (int k = 1; k <= m; ++k) {
      (*cosines)[n * m + k - 1] = std::cos(k * phases[n]);
      (*sines)[n * m + k - 1] = std::sin(k * phases[n]);
    }
  }
}

// out[n * stride + p] = scale[p] / (a0[p] + sum_k alpha_k[p] C[n][k] + beta_k[p] S[n][k]) for
// p in [begin, end), with m a compile-time constant so the sum unrolls into registers, one
// SIMD lane per pixel (Ceres-style fixed sizes).
template <int M>
__attribute__((always_inline)) inline void DensityBlockFixed(const SeriesPlanes& s,
                                                             const double* cosines,
                                                             const double* sines, int64_t phases,
                                                             int64_t begin, int64_t end,
                                                             float* out) {
  const int64_t stride = s.pixels;
  const int64_t count = end - begin;
  const double* a0 = s.a0.data() + begin;
  const double* alpha = s.alpha.data() + begin;
  const double* beta = s.beta.data() + begin;
  const float* scale = s.scale.data() + begin;
  for (int64_t n = 0; n < phases; ++n) {
    double c[M], si[M];
    for (int k = 0; k < M; ++k) {
      c[k] = cosines[n * M + k];
      si[k] = sines[n * M + k];
    }
    float* row = out + n * stride + begin;
#pragma omp simd
    for (int64_t i = 0; i < count; ++i) {
      double denominator = a0[i];
      for (int k = 0; k < M; ++k) {
        denominator += alpha[k * stride + i] * c[k] + beta[k * stride + i] * si[k];
      }
      row[i] = scale[i] / static_cast<float>(denominator);
    }
  }
}

// The hot loop, compiled for AVX-512, for AVX2+FMA and for plain x86-64, chosen at load time
// by the CPU it runs on; each clone holds one unrolled kernel per m.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void DensityBlock(
    const SeriesPlanes& s, const double* cosines, const double* sines, int64_t phases,
    int64_t begin, int64_t end, float* out) {
  switch (s.order) {
#define TRANSIENT_DENSITY_CASE(M) \
  case M:                         \
    return DensityBlockFixed<M>(s, cosines, sines, phases, begin, end, out);
    TRANSIENT_DENSITY_CASE(1)
    TRANSIENT_DENSITY_CASE(2)
    TRANSIENT_DENSITY_CASE(3)
    TRANSIENT_DENSITY_CASE(4)
    TRANSIENT_DENSITY_CASE(5)
    TRANSIENT_DENSITY_CASE(6)
    TRANSIENT_DENSITY_CASE(7)
    TRANSIENT_DENSITY_CASE(8)
    TRANSIENT_DENSITY_CASE(9)
    TRANSIENT_DENSITY_CASE(10)
    TRANSIENT_DENSITY_CASE(11)
    TRANSIENT_DENSITY_CASE(12)
    TRANSIENT_DENSITY_CASE(13)
    TRANSIENT_DENSITY_CASE(14)
    TRANSIENT_DENSITY_CASE(15)
    TRANSIENT_DENSITY_CASE(16)
#undef TRANSIENT_DENSITY_CASE
  }
  assert(false && "order outside 1..kMaxOrder");
}

}  // namespace

PisarenkoImage EstimatePisarenko(const SolvedImage& solved) {
  PisarenkoImage result = internal::AllocatePisarenko(solved);
  if (solved.order < 1) return result;
  const PisarenkoSearchGrid grid(solved.order);
  internal::ParallelBlocks(solved.geometry.pixel_count(), [&](int64_t begin, int64_t end) {
    internal::PisarenkoPixels(solved, begin, end, &result, &grid);
  });
  return result;
}

void DensitySlices(const SolvedImage& solved, std::span<const double> phases,
                   std::span<float> out) {
  const int64_t pixels = solved.geometry.pixel_count();
  assert(out.size() == phases.size() * pixels);
  // Per calling thread, so that a stream of frames reuses (rather than re-faults) them. The
  // worker threads must see the caller's buffers: a lambda does not capture a thread_local
  // (it would name the worker's own), so they are passed on by reference.
  thread_local SeriesPlanes series_buffer;
  thread_local std::vector<double> cosine_buffer, sine_buffer;
  SeriesPlanes& series = series_buffer;
  std::vector<double>& cosines = cosine_buffer;
  std::vector<double>& sines = sine_buffer;
  MakeSeries(solved, series);
  MakeTables(phases, solved.order, &cosines, &sines);
  internal::ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
    DensityBlock(series, cosines.data(), sines.data(), static_cast<int64_t>(phases.size()), begin,
                 end, out.data());
  });
}

void CumulativeSlices(const SolvedImage& solved, std::span<const double> phases,
                      std::span<float> out) {
  assert(out.size() == phases.size() * solved.geometry.pixel_count());
  std::vector<double> cosines(phases.size()), sines(phases.size());
  for (size_t n = 0; n < phases.size(); ++n) {
    cosines[n] = std::cos(phases[n]);
    sines[n] = std::sin(phases[n]);
  }
  internal::ParallelBlocks(solved.geometry.pixel_count(), [&](int64_t begin, int64_t end) {
    internal::CumulativePixels(solved, phases, begin, end, out, cosines, sines);
  });
}

void BoundSlices(const SolvedImage& solved, double r, std::span<const double> phases,
                 std::span<float> lower, std::span<float> upper) {
  const int64_t pixels = solved.geometry.pixel_count();
  assert(lower.size() == phases.size() * pixels && upper.size() == lower.size());
  internal::ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
    internal::BoundPixels(solved, r, phases, begin, end, lower, upper);
  });
}

}  // namespace transient::optimized
