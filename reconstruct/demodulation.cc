// Demodulation of capture cycles into moment images (thesis §8.3.1, §8.3.3, §8.5).
#include "transient/reconstruct/demodulation.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

#include "absl/strings/str_cat.h"
#include "kernels_internal.h"
#include "transient/reconstruct/percentile.h"

namespace transient {
namespace {

// Pixels per work item of the demodulation's planes (ParallelBlocks): long runs of each plane.
constexpr int64_t kDemodulationBlock = 8192;

// Robust scores are medians; a thousand well-spread pixels estimate them to about 4 percent,
// which is all a threshold of several times the typical score needs, and keep the per-pixel
// median over takes off the full image.
constexpr int64_t kMaxScoreSamples = 1024;
// Describing a dozen missing exposures in one message helps nobody; the count says the rest.
constexpr int kMaxListedMissing = 4;

// Median of `v` (mean of the two middle values for an even count: the 50th type-7 percentile);
// reorders `v`. `v` non-empty and without NaN.
double MedianInPlace(std::span<double> v) { return Percentile(v, 50.0); }

// A pixel the demodulator must not use: unreadable (NaN) or at or above saturation.
inline bool Unusable(float value, float saturation_level) { return !(value < saturation_level); }


// Well-spread distinct pixels: i * a mod P with a coprime to P near the golden ratio of P, sorted
// for memory order. All pixels when there are few.
std::vector<int64_t> ChooseSamples(int64_t pixels) {
  std::vector<int64_t> samples;
  if (pixels <= kMaxScoreSamples) {
    samples.resize(static_cast<size_t>(pixels));
    std::iota(samples.begin(), samples.end(), int64_t{0});
    return samples;
  }
  int64_t a = static_cast<int64_t>(0.6180339887 * static_cast<double>(pixels)) | 1;
  while (std::gcd(a, pixels) != 1) a += 2;
  samples.reserve(kMaxScoreSamples);
  for (int64_t i = 0; i < kMaxScoreSamples; ++i) samples.push_back((i * a) % pixels);
  std::sort(samples.begin(), samples.end());
  return samples;
}

}  // namespace

absl::Status DemodulationOptions::Validate() const {
  auto violated = [](absl::string_view field, auto value, absl::string_view rule) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, " = ", value, ". Violated constraint: ", rule));
  };
  if (!std::isfinite(outlier_threshold) || outlier_threshold <= 1.0) {
    return violated("outlier_threshold", outlier_threshold, "finite and > 1");
  }
  if (!(outlier_relative_floor >= 0.0 && outlier_relative_floor < 1.0)) {
    return violated("outlier_relative_floor", outlier_relative_floor,
                    "0 <= outlier_relative_floor < 1");
  }
  if (!std::isfinite(video_threshold) || video_threshold <= 1.0) {
    return violated("video_threshold", video_threshold, "finite and > 1");
  }
  if (video_history < kMinVideoScores || video_history > 1024) {
    return violated("video_history", video_history,
                    absl::StrCat(kMinVideoScores, " <= video_history <= 1024"));
  }
  if (video_max_consecutive_fills < 1) {
    return violated("video_max_consecutive_fills", video_max_consecutive_fills,
                    "video_max_consecutive_fills >= 1");
  }
  return absl::OkStatus();
}

absl::StatusOr<Demodulator> Demodulator::Create(const AcquisitionSchedule& schedule,
                                                ImageGeometry geometry,
                                                const DemodulationOptions& options) {
  if (geometry.width <= 0 || geometry.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("geometry ", geometry.width, "x",
                                                   geometry.height,
                                                   ". Violated constraint: width, height > 0"));
  }
  if (absl::Status status = options.Validate(); !status.ok()) return status;
  if (schedule.options().DeliversDepth()) {
    return absl::FailedPreconditionError(
        schedule.options().MissingHarmonicsText("demodulation"));
  }
  return Demodulator(schedule, geometry, options);
}

Demodulator::Demodulator(const AcquisitionSchedule& schedule, ImageGeometry geometry,
                         const DemodulationOptions& options)
    : schedule_(schedule),
      geometry_(geometry),
      options_(options),
      exposures_per_take_(schedule.exposures_per_take()),
      takes_(schedule.options().takes),
      inverse_gain_(1.0 / schedule.nominal_gain()),
      sample_pixels_(ChooseSamples(geometry.pixel_count())) {
  const int buckets = schedule.options().buckets;
  std::array<int, kMaxPhaseBuckets> none;
  none.fill(-1);
  plane_exposures_.assign(static_cast<size_t>(schedule.order() + 1), none);
  for (int k = 0; k < buckets; ++k) {
    // Exact zeros where cos or sin vanish (four-bucket: the plain differences).
    auto snap = [](double v) { return static_cast<float>(std::abs(v) < 1e-12 ? 0.0 : v); };
    const double shift = BucketPhaseShift(k, buckets);
    bucket_cos_.push_back(snap(2.0 / buckets * std::cos(shift)));
    bucket_sin_.push_back(snap(2.0 / buckets * std::sin(shift)));
  }
  exposure_plane_.resize(static_cast<size_t>(exposures_per_take_));
  for (int e = 0; e < exposures_per_take_; ++e) {
    const ExposureConfig& config = schedule.exposures()[static_cast<size_t>(e)];
    exposure_plane_[static_cast<size_t>(e)] = config.harmonic;
    int slot;
    if (config.frequency_hz == 0.0) {  // the unmodulated pair
      slot = config.illumination ? 0 : 1;
    } else {
      slot = BucketIndex(config.phase_shift_rad, buckets);
    }
    plane_exposures_[static_cast<size_t>(config.harmonic)][static_cast<size_t>(slot)] = e;
  }
  history_.resize(static_cast<size_t>(exposures_per_take_));
  averages_.resize(static_cast<size_t>(exposures_per_take_));
}

void Demodulator::ResetHistory() {
  have_previous_ = false;
  for (ExposureHistory& h : history_) h = ExposureHistory();
}

absl::Status Demodulator::IndexFrames(std::span<const RawFrame> cycle) {
  const size_t n = static_cast<size_t>(schedule_.raw_frames_per_frame());
  slots_.assign(n, nullptr);
  const int64_t pixels = geometry_.pixel_count();
  for (const RawFrame& frame : cycle) {
    if (frame.geometry != geometry_) {
      return absl::InvalidArgumentError(absl::StrCat(
          DescribeFrame(frame.config), " has geometry ", frame.geometry.width, "x", frame.geometry.height,
          "; the demodulator expects ", geometry_.width, "x", geometry_.height));
    }
    if (static_cast<int64_t>(frame.pixels.size()) != pixels) {
      return absl::InvalidArgumentError(
          absl::StrCat(DescribeFrame(frame.config), " holds ", frame.pixels.size(),
                       " pixels. Violated constraint: pixels == width*height = ", pixels));
    }
    absl::StatusOr<int> index = schedule_.IndexOf(frame.config);
    if (!index.ok()) return index.status();
    if (frame.config.cycle != cycle.front().config.cycle) {
      return absl::InvalidArgumentError(
          absl::StrCat(DescribeFrame(frame.config), " belongs to cycle ", frame.config.cycle, "; frame ",
                       cycle.front().config.sequence, " to cycle ", cycle.front().config.cycle,
                       ". Violated constraint: one cycle per call"));
    }
    const RawFrame*& slot = slots_[static_cast<size_t>(*index)];
    if (slot != nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat(DescribeFrame(frame.config), " duplicates the exposure of frame ",
                       slot->config.sequence, " in cycle ", frame.config.cycle));
    }
    slot = &frame;
  }
  std::vector<size_t> missing;
  for (size_t i = 0; i < n; ++i) {
    if (slots_[i] == nullptr) missing.push_back(i);
  }
  if (!missing.empty()) {
    std::string message = absl::StrCat(
        "cycle ",
        cycle.empty() ? std::string("(no frames)") : absl::StrCat(cycle.front().config.cycle),
        " lacks ", missing.size(), " of ", n, " exposures of the schedule ", schedule_.Describe(),
        ": missing ");
    for (size_t k = 0; k < missing.size() && k < kMaxListedMissing; ++k) {
      absl::StrAppend(&message, k == 0 ? "" : "; ",
                      DescribeExposure(schedule_.exposures()[missing[k]]));
    }
    if (missing.size() > kMaxListedMissing) {
      absl::StrAppend(&message, "; and ", missing.size() - kMaxListedMissing, " more");
    }
    return absl::InvalidArgumentError(message);
  }
  return absl::OkStatus();
}

void Demodulator::RejectOutlierTakes(int e) {
  const size_t samples = sample_pixels_.size();
  // Per-pixel median over takes at the sample pixels; NaN where a take is unreadable, so that
  // NaN never enters a comparison.
  scratch_.resize(samples);
  std::vector<double> values(static_cast<size_t>(takes_));
  score_scratch_.clear();
  for (size_t s = 0; s < samples; ++s) {
    const int64_t p = sample_pixels_[s];
    bool finite = true;
    for (int t = 0; t < takes_; ++t) {
      const float v = slots_[static_cast<size_t>(t * exposures_per_take_ + e)]->pixels[p];
      finite = finite && std::isfinite(v);
      values[static_cast<size_t>(t)] = v;
    }
    if (!finite) {
      scratch_[s] = kNaNf;
      continue;
    }
    const double median = MedianInPlace(values);
    scratch_[s] = static_cast<float>(median);
    score_scratch_.push_back(std::abs(median));
  }
  if (score_scratch_.empty()) return;  // nothing readable to judge by
  const double floor = options_.outlier_relative_floor * MedianInPlace(score_scratch_);

  std::vector<double> scores(static_cast<size_t>(takes_));
  for (int t = 0; t < takes_; ++t) {
    const std::vector<float>& pixels =
        slots_[static_cast<size_t>(t * exposures_per_take_ + e)]->pixels;
    score_scratch_.clear();
    for (size_t s = 0; s < samples; ++s) {
      if (std::isnan(scratch_[s])) continue;
      score_scratch_.push_back(std::abs(double{pixels[sample_pixels_[s]]} - scratch_[s]));
    }
    scores[static_cast<size_t>(t)] = MedianInPlace(score_scratch_);
  }
  std::vector<double> sorted = scores;
  const double limit = options_.outlier_threshold * std::max(MedianInPlace(sorted), floor);
  for (int t = 0; t < takes_; ++t) {
    if (scores[static_cast<size_t>(t)] > limit) {
      accepted_[static_cast<size_t>(t * exposures_per_take_ + e)] = false;
    }
  }
}

void Demodulator::RejectVideoOutliers() {
  const size_t n = slots_.size();
  video_scores_.assign(n, kNaN);
  if (!have_previous_) return;  // no previous cycle: nothing to compare with
  std::vector<double> ratios(n, kNaN);
  std::vector<double> ratio_list;
  for (size_t i = 0; i < n; ++i) {
    if (!accepted_[i]) continue;
    const ExposureHistory& h = history_[i % static_cast<size_t>(exposures_per_take_)];
    if (h.previous_samples.empty()) continue;
    const std::vector<float>& pixels = slots_[i]->pixels;
    score_scratch_.clear();
    for (size_t s = 0; s < sample_pixels_.size(); ++s) {
      const double d = std::abs(double{pixels[sample_pixels_[s]]} - h.previous_samples[s]);
      if (std::isfinite(d)) score_scratch_.push_back(d);
    }
    if (score_scratch_.empty()) continue;
    video_scores_[i] = MedianInPlace(score_scratch_);
    if (static_cast<int>(h.scores.size()) < kMinVideoScores) continue;
    std::vector<double> recent(h.scores.begin(), h.scores.end());
    const double scale = std::max(MedianInPlace(recent), h.score_floor);
    ratios[i] = scale > 0.0
                    ? video_scores_[i] / scale
                    : (video_scores_[i] > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
    ratio_list.push_back(ratios[i]);
  }
  if (ratio_list.empty()) return;
  // Scene motion raises every exposure's score together; an outlier capture raises its own.
  const double reference = std::max(1.0, MedianInPlace(ratio_list));
  for (size_t i = 0; i < n; ++i) {
    const ExposureHistory& h = history_[i % static_cast<size_t>(exposures_per_take_)];
    if (h.consecutive_fills >= options_.video_max_consecutive_fills) continue;
    if (ratios[i] > options_.video_threshold * reference) accepted_[i] = false;
  }
}

const float* Demodulator::ExposureAverage(int e) {
  const float* single = nullptr;
  int used = 0;
  for (int t = 0; t < takes_; ++t) {
    const size_t i = static_cast<size_t>(t * exposures_per_take_ + e);
    if (!accepted_[i]) continue;
    if (used++ == 0) single = slots_[i]->pixels.data();
  }
  if (used == 1) return single;
  std::vector<float>& sum = averages_[static_cast<size_t>(e)];
  sum.resize(static_cast<size_t>(geometry_.pixel_count()));
  return sum.data();
}

void Demodulator::AverageExposure(int e, int64_t begin, int64_t end) {
  uint8_t* bad = bad_.data();
  float* sum = averages_[static_cast<size_t>(e)].data();
  int used = 0;
  const float* first = nullptr;
  for (int t = 0; t < takes_; ++t) {
    const size_t i = static_cast<size_t>(t * exposures_per_take_ + e);
    if (!accepted_[i]) continue;
    const float* v = slots_[i]->pixels.data();
    const float level = slots_[i]->saturation_level;
    if (used == 0) {
      first = v;
      for (int64_t p = begin; p < end; ++p) bad[p] |= Unusable(v[p], level);
    } else {
      if (used == 1) std::copy(first + begin, first + end, sum + begin);
      for (int64_t p = begin; p < end; ++p) {
        sum[p] += v[p];
        bad[p] |= Unusable(v[p], level);
      }
    }
    ++used;
  }
  if (used <= 1) return;
  const float scale = 1.0f / static_cast<float>(used);
  for (int64_t p = begin; p < end; ++p) sum[p] *= scale;
}

void Demodulator::UpdateVideoHistory(const std::vector<bool>& exposure_filled) {
  const size_t samples = sample_pixels_.size();
  for (int e = 0; e < exposures_per_take_; ++e) {
    ExposureHistory& h = history_[static_cast<size_t>(e)];
    if (exposure_filled[static_cast<size_t>(e)]) {
      ++h.consecutive_fills;
      continue;
    }
    h.consecutive_fills = 0;
    h.previous_samples.assign(samples, 0.0f);
    int used = 0;
    for (int t = 0; t < takes_; ++t) {
      const size_t i = static_cast<size_t>(t * exposures_per_take_ + e);
      if (!accepted_[i]) continue;
      ++used;
      for (size_t s = 0; s < samples; ++s) {
        h.previous_samples[s] += slots_[i]->pixels[sample_pixels_[s]];
      }
      if (!std::isnan(video_scores_[i])) h.scores.push_back(video_scores_[i]);
    }
    for (float& v : h.previous_samples) v /= static_cast<float>(used);
    score_scratch_.clear();
    for (float v : h.previous_samples) {
      if (std::isfinite(v)) score_scratch_.push_back(std::abs(double{v}));
    }
    h.score_floor = score_scratch_.empty()
                        ? 0.0
                        : options_.outlier_relative_floor * MedianInPlace(score_scratch_);
    while (static_cast<int>(h.scores.size()) > options_.video_history) h.scores.pop_front();
  }
}

absl::Status Demodulator::Demodulate(std::span<const RawFrame> cycle, MomentImage* out,
                                     DemodulationReport* report) {
  if (absl::Status status = IndexFrames(cycle); !status.ok()) return status;
  const size_t n = slots_.size();
  const int m = schedule_.order();
  const int64_t pixels = geometry_.pixel_count();
  const size_t exposures = static_cast<size_t>(exposures_per_take_);

  accepted_.assign(n, true);
  if (options_.reject_outliers && takes_ >= 3) {
    for (int e = 0; e < exposures_per_take_; ++e) RejectOutlierTakes(e);
  }
  if (options_.video) RejectVideoOutliers();

  // An exposure with no accepted take leaves its plane to the previous cycle (video mode only:
  // take rejection keeps at least half of the takes, and video rejection needs a history).
  std::vector<bool> exposure_filled(exposures, false);
  std::vector<bool> plane_filled(static_cast<size_t>(m + 1), false);
  for (size_t e = 0; e < exposures; ++e) {
    bool any = false;
    for (int t = 0; t < takes_; ++t) any = any || accepted_[t * exposures + e];
    if (!any) {
      exposure_filled[e] = true;
      plane_filled[static_cast<size_t>(exposure_plane_[e])] = true;
    }
  }

  // Each exposure's mean over its accepted takes: the single take's pixels, or averages_[e],
  // which the blocks below fill (AverageExposure).
  std::vector<const float*> average(exposures, nullptr);
  int frames_used = 0;
  for (size_t e = 0; e < exposures; ++e) {
    if (plane_filled[static_cast<size_t>(exposure_plane_[e])]) continue;
    average[e] = ExposureAverage(static_cast<int>(e));
    for (int t = 0; t < takes_; ++t) frames_used += accepted_[t * exposures + e] ? 1 : 0;
  }
  std::vector<int> filled_planes;
  for (int j = 0; j <= m; ++j) {
    if (plane_filled[static_cast<size_t>(j)]) filled_planes.push_back(j);
  }

  // Sized only: the blocks below write every value.
  bad_.resize(static_cast<size_t>(pixels));
  out->geometry = geometry_;
  out->order = m;
  out->real.resize(static_cast<size_t>((m + 1) * pixels));
  out->imag.resize(static_cast<size_t>((m + 1) * pixels));
  out->valid.resize(static_cast<size_t>(pixels));
  out->flags.resize(static_cast<size_t>(pixels));
  if (options_.video) {
    previous_.geometry = geometry_;
    previous_.order = m;
    previous_.real.resize(out->real.size());
    previous_.imag.resize(out->imag.size());
    previous_.valid.resize(out->valid.size());
    previous_.flags.resize(out->flags.size());
  }

  const float gain_re = static_cast<float>(inverse_gain_.real());
  const float gain_im = static_cast<float>(inverse_gain_.imag());
  const float gain_abs = static_cast<float>(std::abs(inverse_gain_));
  const ZerothScheme zeroth = schedule_.options().zeroth;
  std::atomic<int64_t> saturated{0};
  // Each pixel's moments depend on that pixel alone: the whole cycle is demodulated over blocks
  // of pixels on the kernels' threads, each block as the whole image was (the same values).
  internal::ParallelBlocks(
      pixels,
      [&](int64_t begin, int64_t end) {
        uint8_t* bad = bad_.data();
        std::fill(bad + begin, bad + end, uint8_t{0});
        for (size_t e = 0; e < exposures; ++e) {
          if (average[e] != nullptr) AverageExposure(static_cast<int>(e), begin, end);
        }
        for (int j = 0; j <= m; ++j) {
          float* re = out->real_plane(j);
          float* im = out->imag_plane(j);
          if (plane_filled[static_cast<size_t>(j)]) {  // the previous cycle's
            std::copy(previous_.real_plane(j) + begin, previous_.real_plane(j) + end, re + begin);
            std::copy(previous_.imag_plane(j) + begin, previous_.imag_plane(j) + end, im + begin);
            continue;
          }
          std::fill(re + begin, re + end, 0.0f);
          std::fill(im + begin, im + end, 0.0f);
          const std::array<int, kMaxPhaseBuckets>& ex = plane_exposures_[static_cast<size_t>(j)];
          if (j == 0 && zeroth == ZerothScheme::kEstimated) continue;  // plane 0 stays 0
          if (ex[0] < 0) continue;  // a harmonic the schedule does not measure: stays 0
          if (j == 0 && zeroth == ZerothScheme::kUnmodulatedPair) {
            const float* on = average[static_cast<size_t>(ex[0])];
            const float* off = average[static_cast<size_t>(ex[1])];
            for (int64_t p = begin; p < end; ++p) re[p] = on[p] - off[p];
            continue;
          }
          // Z = (2/N) sum_k M_k exp(i*2*pi*k/N), accumulated bucket by bucket into re, im.
          for (size_t k = 0; k < bucket_cos_.size(); ++k) {
            const float* a = average[static_cast<size_t>(ex[k])];
            const float wc = bucket_cos_[k], ws = bucket_sin_[k];
            for (int64_t p = begin; p < end; ++p) {
              re[p] += wc * a[p];
              im[p] += ws * a[p];
            }
          }
          if (j == 0) {  // low-frequency proxy: the modulus needs no phase calibration
            for (int64_t p = begin; p < end; ++p) {
              re[p] = gain_abs * std::sqrt(re[p] * re[p] + im[p] * im[p]);
              im[p] = 0.0f;
            }
            continue;
          }
          for (int64_t p = begin; p < end; ++p) {
            const float zr = re[p], zi = im[p];
            re[p] = zr * gain_re - zi * gain_im;
            im[p] = zr * gain_im + zi * gain_re;
          }
        }
        uint8_t* valid = out->valid.data();
        uint8_t* flags = out->flags.data();
        int64_t block_saturated = 0;
        for (int64_t p = begin; p < end; ++p) {
          valid[p] = bad[p] == 0 ? 1 : 0;
          flags[p] = bad[p] == 0 ? 0 : kFlagSaturated;
          block_saturated += bad[p] == 0 ? 0 : 1;
        }
        if (!filled_planes.empty()) {
          for (int64_t p = begin; p < end; ++p) {
            flags[p] |=
                static_cast<uint8_t>(kFlagOutlierFilled | (previous_.flags[p] & kFlagSaturated));
            valid[p] &= previous_.valid[p];
          }
        }
        for (int64_t p = begin; p < end; ++p) {
          if (valid[p]) continue;
          for (int j = 0; j <= m; ++j) {
            out->real_plane(j)[p] = kNaNf;
            out->imag_plane(j)[p] = kNaNf;
          }
        }
        saturated.fetch_add(block_saturated, std::memory_order_relaxed);
        if (!options_.video) return;
        // This cycle, for the next one's filled planes.
        for (int j = 0; j <= m; ++j) {
          std::copy(out->real_plane(j) + begin, out->real_plane(j) + end,
                    previous_.real_plane(j) + begin);
          std::copy(out->imag_plane(j) + begin, out->imag_plane(j) + end,
                    previous_.imag_plane(j) + begin);
        }
        std::copy(valid + begin, valid + end, previous_.valid.data() + begin);
        std::copy(flags + begin, flags + end, previous_.flags.data() + begin);
      },
      kDemodulationBlock);

  if (options_.video) {
    UpdateVideoHistory(exposure_filled);
    have_previous_ = true;
  }
  if (report != nullptr) {
    report->cycle = cycle.front().config.cycle;
    report->frames_used = frames_used;
    report->rejected.clear();
    for (size_t i = 0; i < n; ++i) {
      if (!accepted_[i]) report->rejected.push_back(slots_[i]->config);
    }
    report->filled_planes = std::move(filled_planes);
    report->saturated_pixels = saturated.load();
    report->filled_pixels = report->filled_planes.empty() ? 0 : pixels;
  }
  return absl::OkStatus();
}

}  // namespace transient
