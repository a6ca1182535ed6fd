// The optimized MESE range kernel (thesis §8.4.3): the first peak of the density above the
// threshold, the same answer as reference::MeseRange (range.cc) with the same grid, the same
// Newton refinement and the same choice among peaks, computed across pixels instead of one
// pixel at a time:
// 1. per block of kRangeBlock pixels, the denominator's cosine series (thesis eq. 8.4) and
//    p = conj(q) as planes, one SIMD lane per pixel;
// 2. for eight or four pixels at a time (kernels_simd.h), one pixel per SIMD lane, their search
//    grids from shared cos/sin tables (four phases from each orbit of the cosines, RangeTables)
//    and their local minima, each lane's in slots in the order of their bins (at most m);
// 3. Newton's method on the derivative of the series, slot by slot, masked per lane exactly as
//    RefineMinimum of range.cc decides, two slots side by side (their steps interleave). No
//    sine or cosine is called: the phase is the grid phase (tabled) plus an offset of at most
//    one bin, and e^{i offset} is its Taylor polynomial;
// 4. per pixel, the first return by MeseFirstReturn (range.cc): the first peak whose density
//    is at least `threshold` times the highest, or whose light is at least `threshold` times
//    the brightest peak's where it stands apart. Every grid minimum is refined: the brightest
//    peak's light needs them all. In the lanes (ChoosePeaks), the valleys between peaks read
//    at the grid's crests, found from the bits of FindMinima only where a peak may pass by its
//    light; the scalar rule (ChoosePeak) only for a pixel with a minimum that is not a peak.
// With the pixels in lanes, a pixel's coefficients are each a lane of vectors loaded once, and
// its minima and peaks stay in its lane: nothing is gathered per minimum but its bin's phase.
// A pixel with more grid minima than m (rounding on a flat series) or whose grid is not finite
// takes the reference's path, whatever the padded order its lanes run at.
// Grids coarser than kMaxRotation per bin (fewer than 26 phases) take the per-pixel path.
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "absl/container/inlined_vector.h"
#include "kernels_internal.h"
#include "kernels_simd.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/range.h"

namespace transient::optimized {
namespace {

// Pixels per block: their series and polynomial planes (4m + 3 doubles per pixel, 17 KB at
// m = 16) stay in L1 while each pixel's grid is searched.
constexpr int kRangeBlock = 64;
// As RefineMinimum in range.cc, except that Newton stops after a step below 1e-6 rad rather
// than 1e-10. At a simple minimum convergence is quadratic, so the step that would follow is of
// order K 1e-12 rad (K = r'''/2r'' there, of order m), some 1e-5 of float32's step of the range
// at 2 to 4 m (2.4e-7 m; 1 rad ~ 1 m at 23 MHz). At a flat minimum of order 2k (r'' = 0 there)
// it is linear with ratio (2k - 2) / (2k - 1), leaving at most (2k - 2) 1e-6 rad: 3e-5 rad for
// k <= m <= 16, 3e-5 m at 23 MHz, inside the 0.1 mm contract. One Newton step fewer for most
// minima; the ranges written were bit-identical to those with 1e-10 on every file tried, and a
// last bit flips now and then (docs/speed.md).
constexpr int kNewtonSteps = 8;
constexpr double kPhaseTolerance = 1e-6;
// Largest bin width (radians) of the vectorized path: e^{ix} for |x| <= 0.25 is its Taylor
// polynomial, cos x to x^12 and sin x to x^11, within 3e-18 (0.25^13 / 13!), a fortieth of
// the rounding of cos x near 1.
constexpr double kMaxRotation = 0.25;

// The grid: phases phi_i = (i - 1) h for i = 0..bins+1 (one phase beyond each end, so that
// the search for minima needs no wrap), h = 2 pi / bins, in rows per k = 1..m:
// c2[(k-1) stride + i] = 2 cos(k phi_i) and s2 = -2 sin(k phi_i), so that the series
// a_0 + 2 Re sum_k a_k e^{ik phi} is a_0 + sum_k Re(a_k) c2 + Im(a_k) s2.
// When bins is a multiple of 4 (the automatic 16 (m+1) always is), only the quarter
// n = 0..bins/4 is tabled (rows of orbit_stride): the phases n h, -n h, pi + n h and pi - n h
// share their cosines and sines up to sign (cos k(pi + phi) = (-1)^k cos k phi), so the
// series' even and odd terms at n h give all four (GridOfPixels), as the density's orbits do.
struct RangeTables {
  int bins = 0;
  int stride = 0;  // of c2 and s2's rows: bins + 2
  double h = 0.0;
  std::vector<double> c2, s2;
  int quarter = 0;       // bins / 4 where bins is a multiple of 4, else 0 (c2, s2 instead)
  int orbit_stride = 0;  // of cq and sq's rows: quarter + 1
  std::vector<double> cq, sq;
  std::vector<double> phase_n, cos_n, sin_n;  // n h and e^{i n h}, n = 0..bins-1
};

RangeTables MakeRangeTables(int m, int bins) {
  RangeTables t;
  t.bins = bins;
  t.stride = bins + 2;
  t.h = kTwoPi / bins;
  t.phase_n.resize(bins);
  t.cos_n.resize(bins);
  t.sin_n.resize(bins);
  for (int n = 0; n < bins; ++n) {
    t.phase_n[n] = n * t.h;
    t.cos_n[n] = std::cos(n * t.h);
    t.sin_n[n] = std::sin(n * t.h);
  }
  if (bins % 4 == 0) {
    t.quarter = bins / 4;
    t.orbit_stride = t.quarter + 1;
    t.cq.assign(static_cast<size_t>(t.orbit_stride) * m, 0.0);
    t.sq.assign(t.cq.size(), 0.0);
    for (int n = 0; n <= t.quarter; ++n) {
      for (int k = 1; k <= m; ++k) {
        t.cq[(k - 1) * t.orbit_stride + n] = 2.0 * std::cos(k * n * t.h);
        t.sq[(k - 1) * t.orbit_stride + n] = -2.0 * std::sin(k * n * t.h);
      }
    }
    return t;
  }
  t.c2.assign(static_cast<size_t>(t.stride) * m, 0.0);
  t.s2.assign(t.c2.size(), 0.0);
  for (int i = 0; i < bins + 2; ++i) {
    const int n = i == 0 ? bins - 1 : (i == bins + 1 ? 0 : i - 1);  // the same grid phases
    for (int k = 1; k <= m; ++k) {
      t.c2[(k - 1) * t.stride + i] = 2.0 * std::cos(k * n * t.h);
      t.s2[(k - 1) * t.stride + i] = -2.0 * std::sin(k * n * t.h);
    }
  }
  return t;
}

// Slots of grid minima refined side by side (RefineSlots): min(M, 4) of the padded order M, so
// up to M = 4 all of a lane's minima at once. BM_MeseRange against two at a time (the least of
// six alternating rounds of five repetitions, one thread / two): m = 3 1.487 / 0.775 ->
// 1.342 / 0.700 ms, m = 4 1.964 / 0.998 -> 1.904 / 0.963 ms (docs/speed.md).
constexpr int kRefineGroups = 4;
template <int M>
constexpr int RefineGroups() {
  return M < kRefineGroups ? M : kRefineGroups;
}

// Per-thread working memory, reused from block to block.
struct RangeScratch {
  // Planes of kRangeBlock lanes: a_0, Re and Im of a_k for k = 1..m, Re and Im of
  // p_j = conj(q_j) for j = 0..m.
  std::vector<double> planes;
  // The grids of the pixels searched together, one a lane: grid value i of lane l at
  // i * lanes + l (GridOfPixels).
  std::vector<double> grid;
  // The grids' crests as bits, word w of lane l at [w * lanes + l] (FindMinima).
  std::vector<uint64_t> crests;
  // One pixel's grid values, for the valleys between its peaks (ChoosePeak).
  std::vector<double> valley;
  void Reserve(int m, const RangeTables& t) {
    const size_t planes_per_pixel = static_cast<size_t>(1 + 2 * m + 2 * (m + 1));
    planes.resize(planes_per_pixel * kRangeBlock);
    grid.resize(static_cast<size_t>(t.bins + 2) * simd::kMaxLanes);
    crests.resize(static_cast<size_t>(t.bins + 63) / 64 * simd::kMaxLanes);
    valley.resize(t.bins);
  }
};

// Views of a set of coefficient planes of `width` entries each.
template <int M>
struct Planes {
  int width;
  double* a0;
  double* ar;  // [k-1][entry]
  double* ai;
  double* pr;  // [j][entry]
  double* pi;
};

// (A function, not a constructor: Clang 15 does not emit a class template's constructor that
// only functions with a target attribute call.)
template <int M>
__attribute__((always_inline)) inline Planes<M> PlanesIn(double* storage, int width) {
  Planes<M> b;
  b.width = width;
  b.a0 = storage;
  b.ar = b.a0 + width;
  b.ai = b.ar + M * width;
  b.pr = b.ai + M * width;
  b.pi = b.pr + (M + 1) * width;
  return b;
}

// Step 1: the series a_k = sum_j conj(q_{j+k}) q_j and p = conj(q) of pixels [begin, end);
// lanes past the end and invalid pixels get a_0 = NaN: their grids are not finite, so they
// take the reference's path (FindMinima), which leaves an invalid pixel without a range. M >= the
// image's order m: q_j = 0 for j > m, so a_k = 0 for k > m, and every sum of the later steps adds
// exact zeros — the results are those of M = m (PaddedOrder).
template <int M>
__attribute__((always_inline)) inline void LoadBlock(const SolvedImage& solved, int64_t begin,
                                                     int64_t end, const Planes<M>& b) {
  const int64_t pixels = solved.geometry.pixel_count();
  const int count = static_cast<int>(end - begin);
  for (int j = 0; j <= M; ++j) {
    if (j > solved.order) {
      for (int l = 0; l < kRangeBlock; ++l) {
        b.pr[j * kRangeBlock + l] = b.pi[j * kRangeBlock + l] = 0.0;
      }
      continue;
    }
    const double* qr = solved.q_real.data() + j * pixels + begin;
    const double* qi = solved.q_imag.data() + j * pixels + begin;
    double* pr = b.pr + j * kRangeBlock;
    double* pi = b.pi + j * kRangeBlock;
    // The block's pixels, then zeros past its end (one loop masked per lane ran as 5 % of the
    // kernel).
#pragma omp simd
    for (int l = 0; l < count; ++l) {
      pr[l] = qr[l];
      pi[l] = -qi[l];
    }
    for (int l = count; l < kRangeBlock; ++l) pr[l] = pi[l] = 0.0;
  }
  // a_0 = sum_j |q_j|^2; a_k = sum_j conj(q_{j+k}) q_j = conj(sum_j conj(p_{j+k}) p_j).
  internal::DenominatorSeriesPlanes<1>(b.pr, b.pi, kRangeBlock, M, kRangeBlock, b.a0, b.ar, b.ai,
                                       kRangeBlock);
  const uint8_t* flags = solved.flags.data() + begin;
  for (int l = 0; l < kRangeBlock; ++l) {
    if (l >= count || (flags[l] & kFlagInvalidInput) != 0) {
      b.a0[l] = std::numeric_limits<double>::quiet_NaN();
    }
  }
}

// Step 4 for one pixel over its `count` refined minima: MeseFirstReturn, with the pixel's grid
// for the valleys, for the pixels that ChoosePeaks cannot decide in vectors (a minimum that is
// not a peak). Its values lie `stride` apart: minimum i's bin, phase, |p|^2 and light at
// [i * stride], bin n's grid value at grid[(n + 1) * stride]. Scalar and the same for every
// order and instruction set: one copy, called from the clones rather than inlined into each.
__attribute__((noinline)) double ChoosePeak(const RangeTables& t, double threshold, int count,
                                            const int32_t* bin, const double* phase,
                                            const double* denominator, const double* light,
                                            const double* grid, int stride, RangeScratch& s) {
  absl::InlinedVector<MesePeak, kMaxOrder> peaks;
  for (int i = 0; i < count; ++i) {
    // Not above 0: only underflow, D would be infinite; not a peak (as the reference).
    const double d = denominator[i * stride];
    if (!(d > 0.0)) continue;
    peaks.push_back({OrderingPhase(phase[i * stride]), d, light[i * stride], bin[i * stride]});
  }
  for (int n = 0; n < t.bins; ++n) s.valley[n] = grid[(n + 1) * stride];
  return MeseFirstReturn(peaks, threshold, std::span<const double>(s.valley.data(), t.bins));
}

// The orders compiled (each costs compile time, ~10 s at m = 16 per instruction set): every
// m up to 6, then 8, 12 and 16 for the orders between, zero-padded. Under the sanitizers, where
// compile time counts and speed does not, only 4, 8 and 16: the padded orders give the same
// results (LoadBlock), and the kernel tests there still run m = 1, 3, 4, 8, 10 and 16.
#if defined(TRANSIENT_SIMD_BASELINE_ONLY)
int PaddedOrder(int m) { return m <= 4 ? 4 : m <= 8 ? 8 : 16; }
#else
int PaddedOrder(int m) { return m <= 6 ? m : m <= 8 ? 8 : m <= 12 ? 12 : 16; }
#endif

// The lane code for each lane count (kernels_simd.h).
#define TRANSIENT_LANE_CODE "optimized_range_lanes.inc"
#include "simd_namespaces.inc"

TRANSIENT_SIMD_VARIANTS(RangeBlock, RangeBlockAnyOrder,
                        (const SolvedImage& solved, const RangeTables& t,
                         const RangeOptions& options, int64_t begin, int64_t end,
                         std::span<float> range_m, std::span<uint8_t> flags, RangeScratch& s),
                        (solved, t, options, begin, end, range_m, flags, s))

}  // namespace

void MeseRange(const SolvedImage& solved, const RangeOptions& options, std::span<float> range_m,
               std::span<uint8_t> flags) {
  const int64_t pixels = solved.geometry.pixel_count();
  assert(range_m.size() == static_cast<size_t>(pixels) && flags.size() == range_m.size());
  const int m = solved.order;
  const int bins = options.SearchBins(m);
  if (kTwoPi / bins > kMaxRotation) {
    // A coarse grid (a search_bins chosen by hand): the per-pixel search of the reference.
    internal::ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
      internal::MeseRangePixels(solved, options, begin, end, range_m, flags);
    });
    return;
  }
  const RangeTables tables = MakeRangeTables(PaddedOrder(m), bins);  // zero rows past m
  internal::ParallelBlocks(
      pixels,
      [&](int64_t begin, int64_t end) {
        thread_local RangeScratch scratch;
        RangeBlock(solved, tables, options, begin, end, range_m, flags, scratch);
      },
      kRangeBlock);
}

}  // namespace transient::optimized
