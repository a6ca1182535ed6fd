// The optimized kernels: the same products as reference_kernels.cc (the solve is in
// optimized_solve.cc, the MESE range in optimized_range.cc), computed with
// - the MESE denominator written as a real cosine series a_0 + sum_k (alpha_k cos k phi +
//   beta_k sin k phi) whose coefficients are computed once per pixel and whose cos/sin tables
//   are shared by all pixels (thesis eq. 8.4), so all pixels x all phases is a small matrix
//   product followed by a reciprocal, vectorized over pixels; phi, -phi, pi + phi and pi - phi
//   share one evaluation of the series' even and odd parts (PhaseOrbits), and outputs larger
//   than the caches are written with streaming stores;
// - Pisarenko by PisarenkoByLevinson's route, eight or four pixels at a time in SIMD lanes for
//   m <= 8 (internal::PisarenkoBlock, optimized_pisarenko.cc), per pixel above and where the
//   lanes decline, the reference's Pisarenko() where that declines too;
// - the cumulative's closed form (MeseCumulative, per pixel) summed at eight or four phases at
//   a time with the phases' cosines and sines tabled once, its logarithms as real log and atan
//   computed in the lanes (internal::CumulativeLanes, optimized_cumulative.cc);
// - OpenMP threads over blocks of pixels for everything, including the per-pixel solvers
//   (the cumulative's partial fractions, bounds) that stay scalar.
// The series is summed in double: near a sharp peak it cancels to ~eps^2/(m+1)^2 of a_0, which
// float could not resolve; the final division is float (its operands are then exact to 1e-7).
#include <immintrin.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
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
  // alpha_k = 2 Re a_k, beta_k = -2 Im a_k (MeseDenominatorSeries) across pixels.
  const int64_t n = s.pixels;
  internal::ParallelBlocks(n, [&](int64_t begin, int64_t end) {
    const double* qr = solved.q_real.data();
    internal::DenominatorSeriesPlanes<2>(qr + begin, solved.q_imag.data() + begin, n, m,
                                         end - begin, s.a0.data() + begin, s.alpha.data() + begin,
                                         s.beta.data() + begin, n);
    double* a0 = s.a0.data();
    for (int64_t p = begin; p < end; ++p) {
      if (!solved.valid(p)) {
        a0[p] = std::numeric_limits<double>::quiet_NaN();
        s.scale[p] = kNaNf;
        for (int k = 0; k < m; ++k) s.alpha[k * n + p] = s.beta[k * n + p] = 0.0;
      } else {
        s.scale[p] = static_cast<float>(qr[p] / kTwoPi);
      }
    }
  });
}

// out[rows[n] * stride + p] = scale[p] / (a0[p] + sum_k alpha_k[p] C[n][k] + beta_k[p] S[n][k])
// for p in [begin, end), with m a compile-time constant so the sum unrolls into registers, one
// SIMD lane per pixel (Ceres-style fixed sizes).
template <int M>
__attribute__((always_inline)) inline void DensityBlockFixed(
    const SeriesPlanes& s, const double* cosines, const double* sines, const int64_t* rows,
    int64_t phases, int64_t begin, int64_t end, float* out) {
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
    float* row = out + rows[n] * stride + begin;
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

// The phases of a request grouped by the symmetries of the series: phi, -phi, pi + phi and
// pi - phi share their cosines and sines up to sign (cos k(pi + phi) = (-1)^k cos k phi, ...),
// so with the sums over even and odd k of the cosine and sine terms, C_e, C_o, S_e and S_o, the
// four denominators are a_0 + C_e + C_o +- (S_e + S_o) and a_0 + C_e - C_o +- (S_e - S_o):
// 2m multiply-adds for four phases instead of 8m. Uniform slices over a period (the daemon's
// default, UniformPhases) are such orbits but for the phases 0, pi/2, pi, 3 pi/2.
struct PhaseOrbits {
  // Rows of phi, -phi, pi + phi, pi - phi, four per orbit, and cos/sin(k phi) for k = 1..m.
  std::vector<int64_t> rows;
  std::vector<double> cosines, sines;
  // The other phases, one by one: cos/sin(k phi_n) at [n * m + k - 1].
  std::vector<int64_t> single_rows;
  std::vector<double> single_cosines, single_sines;
};

// Phases closer than this (radians, modulo 2 pi) are taken as equal; the density then differs
// by at most |D'| 1e-12, ~1e-9 of D at the sharpest peaks (relative width ~1e-3).
constexpr double kSamePhase = 1e-12;

void MakeOrbits(std::span<const double> phases, int m, PhaseOrbits* orbits) {
  const int64_t count = static_cast<int64_t>(phases.size());
  // Phases wrapped into [0, 2 pi), sorted, to find each phase's partners.
  // (Finite phases only: a NaN would break the sort's ordering; NaN and infinite phases are
  // computed one by one, into NaN densities as the reference's.)
  std::vector<std::pair<double, int64_t>> sorted;
  sorted.reserve(count);
  for (int64_t n = 0; n < count; ++n) {
    if (!std::isfinite(phases[n])) continue;
    double w = std::fmod(phases[n], kTwoPi);
    if (w < 0.0) w += kTwoPi;
    sorted.push_back({w, n});
  }
  std::sort(sorted.begin(), sorted.end());
  std::vector<bool> used(count, false);
  auto distance = [](double a, double b) {
    const double d = std::abs(a - b);
    return std::min(d, kTwoPi - d);
  };
  // An unused phase within kSamePhase of `target` (any wrap), or -1.
  auto find = [&](double target) -> int64_t {
    double w = std::fmod(target, kTwoPi);
    if (w < 0.0) w += kTwoPi;
    const auto at =
        std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(w - kSamePhase, int64_t{-1}));
    for (auto it = at; it != sorted.end() && it->first <= w + kSamePhase; ++it) {
      if (!used[it->second]) return it->second;
    }
    for (const auto* edge : {&sorted.front(), &sorted.back()}) {  // across the wrap
      if (!used[edge->second] && distance(edge->first, w) <= kSamePhase) return edge->second;
    }
    return -1;
  };
  orbits->rows.clear();
  orbits->cosines.clear();
  orbits->sines.clear();
  orbits->single_rows.clear();
  orbits->single_cosines.clear();
  orbits->single_sines.clear();
  auto add_tables = [m](double phase, std::vector<double>* c, std::vector<double>* s) {
    for (int k = 1; k <= m; ++k) {
      c->push_back(std::cos(k * phase));
      s->push_back(std::sin(k * phase));
    }
  };
  for (int64_t n = 0; n < count; ++n) {
    if (used[n]) continue;
    used[n] = true;
    const double phi = phases[n];
    std::array<int64_t, 3> partner = {-1, -1, -1};
    bool all = std::isfinite(phi);
    for (int j = 0; j < 3 && all; ++j) {
      partner[j] = find(j == 0 ? -phi : j == 1 ? std::numbers::pi + phi : std::numbers::pi - phi);
      if (partner[j] < 0) {
        all = false;
      } else {
        used[partner[j]] = true;
      }
    }
    if (all) {
      orbits->rows.insert(orbits->rows.end(), {n, partner[0], partner[1], partner[2]});
      add_tables(phi, &orbits->cosines, &orbits->sines);
      continue;
    }
    for (int64_t p : partner) {
      if (p >= 0) used[p] = false;
    }
    orbits->single_rows.push_back(n);
    add_tables(phi, &orbits->single_cosines, &orbits->single_sines);
  }
}

// Copies n floats to dst, bypassing the caches where dst is aligned (streaming stores of the
// widest vector the CPU has: AMD's write combining is slower with 16-byte ones): the slices
// of a frame (78 MB for 64 at 640x480) are far larger than the caches, and a plain store
// first reads each line it writes. The caller fences (_mm_sfence) before the output is read.
#define TRANSIENT_STREAM_FLOATS(NAME, TARGET, BYTES, STORE)                           \
  TARGET void NAME(float* dst, const float* src, int64_t n) {                         \
    int64_t i = 0;                                                                    \
    for (; i < n && (reinterpret_cast<uintptr_t>(dst + i) & ((BYTES)-1)) != 0; ++i) { \
      dst[i] = src[i];                                                                \
    }                                                                                 \
    for (; i + (BYTES) / 4 <= n; i += (BYTES) / 4) STORE;                             \
    for (; i < n; ++i) dst[i] = src[i];                                               \
  }
TRANSIENT_STREAM_FLOATS(StreamFloats64, __attribute__((target("avx512f"))), 64,
                        _mm512_stream_ps(dst + i, _mm512_loadu_ps(src + i)))
TRANSIENT_STREAM_FLOATS(StreamFloats32, __attribute__((target("avx"))), 32,
                        _mm256_stream_ps(dst + i, _mm256_loadu_ps(src + i)))
TRANSIENT_STREAM_FLOATS(StreamFloats16, , 16, _mm_stream_ps(dst + i, _mm_loadu_ps(src + i)))
#undef TRANSIENT_STREAM_FLOATS
void StreamFloats(float* dst, const float* src, int64_t n) {
  static const auto copy = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") ? &StreamFloats64
           : __builtin_cpu_supports("avx")   ? &StreamFloats32
                                             : &StreamFloats16;
  }();
  copy(dst, src, n);
}

// Pixels computed at a time by DensityOrbitsFixed before they are streamed out.
constexpr int64_t kOrbitChunk = 256;

// The four densities of one orbit for `count` pixels, into buffer[j] (or, without a buffer,
// straight into rows[j]).
template <int M>
__attribute__((always_inline)) inline void DensityOrbitChunk(const double* a0, const double* alpha,
                                                             const double* beta, const float* scale,
                                                             int64_t stride, const double* c,
                                                             const double* si, int64_t count,
                                                             float (*buffer)[kOrbitChunk],
                                                             float* const* rows) {
  float* plus = buffer != nullptr ? buffer[0] : rows[0];
  float* minus = buffer != nullptr ? buffer[1] : rows[1];
  float* half_plus = buffer != nullptr ? buffer[2] : rows[2];
  float* half_minus = buffer != nullptr ? buffer[3] : rows[3];
#pragma omp simd
  for (int64_t i = 0; i < count; ++i) {
    double ce = 0.0, co = 0.0, se = 0.0, so = 0.0;
    for (int k = 0; k < M; ++k) {  // the harmonic k + 1: odd for even k
      if (k % 2 == 0) {
        co += alpha[k * stride + i] * c[k];
        so += beta[k * stride + i] * si[k];
      } else {
        ce += alpha[k * stride + i] * c[k];
        se += beta[k * stride + i] * si[k];
      }
    }
    const double even = a0[i] + ce;
    plus[i] = scale[i] / static_cast<float>(even + co + (se + so));
    minus[i] = scale[i] / static_cast<float>(even + co - (se + so));
    half_plus[i] = scale[i] / static_cast<float>(even - co + (se - so));
    half_minus[i] = scale[i] / static_cast<float>(even - co - (se - so));
  }
}

// DensityBlockFixed for the orbits: out rows of each orbit's four phases; `stream`: through
// StreamFloats.
template <int M>
__attribute__((always_inline)) inline void DensityOrbitsFixed(const SeriesPlanes& s,
                                                              const PhaseOrbits& orbits,
                                                              int64_t begin, int64_t end,
                                                              bool stream, float* out) {
  const int64_t stride = s.pixels;
  const int64_t orbit_count = static_cast<int64_t>(orbits.rows.size() / 4);
  alignas(64) float buffer[4][kOrbitChunk];
  for (int64_t chunk = begin; chunk < end; chunk += kOrbitChunk) {
    const int64_t count = std::min(kOrbitChunk, end - chunk);
    const double* a0 = s.a0.data() + chunk;
    const double* alpha = s.alpha.data() + chunk;
    const double* beta = s.beta.data() + chunk;
    const float* scale = s.scale.data() + chunk;
    for (int64_t o = 0; o < orbit_count; ++o) {
      double c[M], si[M];
      for (int k = 0; k < M; ++k) {
        c[k] = orbits.cosines[o * M + k];
        si[k] = orbits.sines[o * M + k];
      }
      float* rows[4];  // phi, -phi, pi + phi, pi - phi
      for (int j = 0; j < 4; ++j) rows[j] = out + orbits.rows[4 * o + j] * stride + chunk;
      DensityOrbitChunk<M>(a0, alpha, beta, scale, stride, c, si, count, stream ? buffer : nullptr,
                           rows);
      if (stream) {
        for (int j = 0; j < 4; ++j) StreamFloats(rows[j], buffer[j], count);
      }
    }
  }
  if (stream) _mm_sfence();
}

// The orders the density kernels are compiled for, every one of 1..kMaxOrder: CASE(M) for each.
#define TRANSIENT_DENSITY_ORDERS(CASE)                                                         \
  CASE(1)                                                                                      \
  CASE(2)                                                                                      \
  CASE(3)                                                                                      \
  CASE(4) CASE(5) CASE(6) CASE(7) CASE(8) CASE(9) CASE(10) CASE(11) CASE(12) CASE(13) CASE(14) \
      CASE(15) CASE(16)

__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void DensityOrbits(
    const SeriesPlanes& s, const PhaseOrbits& orbits, int64_t begin, int64_t end, bool stream,
    float* out) {
  switch (s.order) {
#define TRANSIENT_DENSITY_CASE(M) \
  case M:                         \
    return DensityOrbitsFixed<M>(s, orbits, begin, end, stream, out);
    TRANSIENT_DENSITY_ORDERS(TRANSIENT_DENSITY_CASE)
#undef TRANSIENT_DENSITY_CASE
  }
  assert(false && "order outside 1..kMaxOrder");
}

// The hot loop, compiled for AVX-512, for AVX2+FMA and for plain x86-64, chosen at load time
// by the CPU it runs on; each clone holds one unrolled kernel per m.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void DensityBlock(
    const SeriesPlanes& s, const double* cosines, const double* sines, const int64_t* rows,
    int64_t phases, int64_t begin, int64_t end, float* out) {
  switch (s.order) {
#define TRANSIENT_DENSITY_CASE(M) \
  case M:                         \
    return DensityBlockFixed<M>(s, cosines, sines, rows, phases, begin, end, out);
    TRANSIENT_DENSITY_ORDERS(TRANSIENT_DENSITY_CASE)
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
    (void)internal::PisarenkoBlock(solved, grid, begin, end, &result);
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
  thread_local PhaseOrbits orbit_buffer;
  SeriesPlanes& series = series_buffer;
  PhaseOrbits& orbits = orbit_buffer;
  MakeSeries(solved, series);
  MakeOrbits(phases, solved.order, &orbits);
  // Streaming stores once the output is well beyond the caches (a 2-core VM's L2 and its
  // share of L3); smaller outputs are read back sooner from the caches.
  const bool stream = out.size() * sizeof(float) >= (size_t{8} << 20);
  internal::ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
    if (!orbits.rows.empty()) DensityOrbits(series, orbits, begin, end, stream, out.data());
    DensityBlock(series, orbits.single_cosines.data(), orbits.single_sines.data(),
                 orbits.single_rows.data(), static_cast<int64_t>(orbits.single_rows.size()), begin,
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
    internal::CumulativeLanes(solved, phases, cosines, sines, begin, end, out);
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
