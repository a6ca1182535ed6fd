// The acquisition schedule of an AMCW camera (thesis §8.3): which exposures one capture cycle
// takes, with which modulation frequency, phase shift and sub-exposure split, and the raw
// frames that come out of them. Pure data and arithmetic: sources (drivers/) produce frames
// in this vocabulary and the demodulator (demodulation.h) consumes them, so both depend on
// this header and not on each other.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/moments.h"

namespace transient {

// How each modulated exposure makes the effective modulation sinusoidal (thesis §8.3.1).
enum class SamplingScheme {
  kFourBucket,            // one phase shift per exposure (with buckets != 4: N-step sampling);
                          // odd harmonics stay (prop. 8.3 needs more)
  kArccos,                // n_phi equal sub-exposures at arccos(1 - (2k+1)/n_phi) (eq. 8.7)
  kHarmonicCancellation,  // n_phi sub-exposures at k*pi/(n_phi+1), time ~ sin((k+1)*pi/(n_phi+1))
                          // [Payne et al. 2010]
  // Not a sampling of modulated exposures: the camera computes depth itself (an OpenNI2 device,
  // an .oni file) and delivers, per capture cycle, one frame of Z in metres and optionally one
  // of amplitude (ScheduleOptions::depth_amplitude, FrameContent). Nothing is demodulated: the
  // daemon serves RANGE, DEPTH, AMPLITUDE, FLAGS and MOMENT_DEPTH of that depth and refuses the
  // moment reconstruction (HasAllHarmonics() is false). Only a source declares it, in code: no
  // URI key or file attribute names it (ParseSamplingScheme refuses "depth"), and the capture
  // and calibration formats refuse such a schedule.
  kDepth,
};

// How the zeroth moment c_0 is obtained (thesis §8.3.3).
enum class ZerothScheme {
  kUnmodulatedPair,    // two unmodulated exposures, illumination on and off: c_0 = on - off
  kLowFrequencyProxy,  // four buckets at a low frequency (900 kHz): c_0 = |phasor|
  kEstimated,          // not measured: estimated from lambda_min (reconstructor.h, kEstimate)
};

// "four-bucket", "arccos", "harmonic-cancellation", "depth"; "pair", "proxy", "estimated".
absl::string_view SamplingSchemeName(SamplingScheme scheme);
absl::string_view ZerothSchemeName(ZerothScheme scheme);
// Inverse of the names above; InvalidArgument listing the accepted names otherwise. "depth" is
// refused too (InvalidArgument saying why): a depth schedule comes from its source's code, never
// from a URI key or a file's attribute.
absl::StatusOr<SamplingScheme> ParseSamplingScheme(absl::string_view name);
absl::StatusOr<ZerothScheme> ParseZerothScheme(absl::string_view name);

// Phase steps of one harmonic: the bucket phase shifts 2*pi*k/N, k = 0..N-1.
inline constexpr int kMinPhaseBuckets = 3;
inline constexpr int kMaxPhaseBuckets = 16;

struct ScheduleOptions {
  double base_frequency_hz = 23e6;  // f; harmonic j is modulated at j*f
  int order = 3;                    // m, 1 <= m <= kMaxOrder; with `harmonics`, max(harmonics)
  // The harmonics measured, in capture order, when not all of 1..m: a real camera's set, e.g.
  // the Kinect v2's {10, 2, 15} of 8 MHz (80, 16, 120 MHz). Empty: 1..order. Distinct, each in
  // 1..kMaxOrder, without a common factor (2, 4 of f are 1, 2 of 2f: say so). The moment reconstruction (MESE, Pisarenko, slices, cumulative, bounds) needs
  // every harmonic 1..m (thesis §8.2: the Toeplitz matrix of c_0..c_m); on a schedule without
  // them only the products of phase_unwrapping.h can be computed (HasAllHarmonics()).
  std::vector<int> harmonics = {};
  // N equally spaced phase steps per harmonic (2*pi*k/N): 4 is four-bucket sampling, 3 the
  // Kinect v2's 120-degree steps. N-step demodulation Z = (2/N) sum_k M_k exp(i*2*pi*k/N) cancels
  // the offset and every harmonic h of the effective modulation except h = 1 (mod N) and
  // h = -1 (mod N), which alias into the estimate: N = 4 keeps the 3rd (conjugated) and 5th, N = 3
  // the 2nd (conjugated) and 4th. kMinPhaseBuckets..kMaxPhaseBuckets.
  int buckets = 4;
  SamplingScheme sampling = SamplingScheme::kArccos;
  int phase_steps = 8;  // n_phi of arccos / harmonic cancellation, 1..64; four-bucket uses 1
  ZerothScheme zeroth = ZerothScheme::kUnmodulatedPair;
  double proxy_frequency_hz = 900e3;  // kLowFrequencyProxy only; below f
  double exposure_s = 1.92e-3;        // of each raw frame (thesis §8.5.1)
  int takes = 1;                      // repetitions of all exposures per transient frame, 1..1024
                                      // (1 with kDepth)

  // sampling = kDepth only (Validate refuses them otherwise). The fields above other than
  // exposure_s and takes are unused by a depth schedule; `harmonics` must stay empty.
  // A second frame per cycle, after the depth: amplitude (IR intensity) in sensor units.
  bool depth_amplitude = false;
  // The camera's maximum depth, metres: finite and > 0 with kDepth, 0 otherwise. It takes the
  // place of the unambiguous range (UnambiguousRangeM()).
  double max_depth_m = 0.0;

  // Names the first violated constraint, e.g. "order = 0. Violated constraint: 1 <= order <= 16".
  absl::Status Validate() const;

  // The harmonics measured in capture order: `harmonics`, or 1..order.
  std::vector<int> MeasuredHarmonics() const;
  // Every harmonic 1..order is measured: the moment reconstruction can run. False for kDepth,
  // which measures none.
  bool HasAllHarmonics() const;
  // sampling == kDepth: the source delivers depth, not modulated captures.
  bool DeliversDepth() const { return sampling == SamplingScheme::kDepth; }
  // Why the moment reconstruction cannot run on this schedule, for a FailedPrecondition:
  // "the schedule measures harmonics 2, 10, 15 of 8 MHz; <what> needs every harmonic 1..15
  // (missing 1, 3-9, 11-14)", or for kDepth "the source delivers depth, not modulated
  // captures: <what> needs modulated captures". Empty when HasAllHarmonics().
  std::string MissingHarmonicsText(absl::string_view what) const;
  // The farthest distance the schedule tells apart, metres: c / (2 f) of a modulated schedule
  // (physical_constants.h), max_depth_m of a depth camera (GetInfo's unambiguous_range_m, the
  // default far plane of moment depth maps).
  double UnambiguousRangeM() const;
};

// Bucket k's phase shift of N-step sampling, 2*pi*k/N, and the bucket of a phase shift (the
// nearest k, modulo N).
double BucketPhaseShift(int k, int buckets);
int BucketIndex(double phase_shift_rad, int buckets);

// ScheduleOptions::harmonics as text, "10,2,15", and back (ParseHarmonicList: InvalidArgument
// naming the bad entry). The order of the list is kept.
std::string FormatHarmonicList(std::span<const int> harmonics);
absl::StatusOr<std::vector<int>> ParseHarmonicList(absl::string_view text);

// One sub-exposure of a modulated exposure: the phase shift added to the bucket's and the share
// of the exposure time it gets. The shares of one exposure sum to 1.
struct SubExposure {
  double phase_shift_rad = 0.0;
  double weight = 1.0;
};

// What the pixels of a raw frame hold. Everything but a depth camera's frames is kModulated.
enum class FrameContent {
  kModulated,  // one modulated (or unmodulated) exposure, sensor units
  kDepth,      // a depth camera's Z in the optical frame, metres; NaN, Inf or <= 0: no depth
  kAmplitude,  // a depth camera's amplitude (IR intensity), sensor units; NaN: unreadable
};
// "modulated", "depth", "amplitude".
absl::string_view FrameContentName(FrameContent content);

// The metadata an AMCW SDK attaches to one raw frame (one exposure of the sensor).
struct ExposureConfig {
  int harmonic = 0;            // j of c_j this exposure contributes to; 0 for the zeroth moment
  double frequency_hz = 0.0;   // modulation frequency: j*f, the proxy frequency, or 0 (unmodulated)
  double phase_shift_rad = 0;  // bucket offset between illumination and sensor modulation:
                               // 2*pi*k/N in [0, 2*pi) (four-bucket: 0, pi/2, pi, 3*pi/2); 0 for
                               // unmodulated exposures
  double exposure_s = 0.0;     // integration time
  bool illumination = true;    // active illumination on
  int take = 0;                // 0 <= take < takes
  int64_t cycle = 0;           // index of the transient frame (capture cycle) this belongs to
  uint64_t sequence = 0;       // running number of the raw frame at its source
  double timestamp_s = 0.0;    // start of the exposure, seconds since the source started
  // What the pixels hold: tells a depth camera's depth and amplitude frames apart (their other
  // fields are equal: harmonic 0, frequency 0, phase shift 0, the schedule's exposure_s,
  // illumination on).
  FrameContent content = FrameContent::kModulated;
};

// One raw image of the sensor with its exposure. `pixels` is row-major, pixel_count() values in
// sensor units: ADC counts (DN) for a real or quantized simulated sensor, linear units for
// float simulated data. NaN marks a pixel the source could not read; a value at or above
// `saturation_level` is saturated (the demodulator flags such pixels, never uses them).
// A depth camera's frames (config.content) hold Z in metres (NaN, Inf or <= 0: no depth) or
// amplitude in sensor units; saturation_level is not used for them.
struct RawFrame {
  ExposureConfig config;
  ImageGeometry geometry;
  std::vector<float> pixels;
  float saturation_level = std::numeric_limits<float>::infinity();
};

// The exposures of one capture cycle, in capture order: for each take, the zeroth-moment
// exposures (if measured), then the measured harmonics j (1..m, or `harmonics` in its order),
// each with buckets 2*pi*k/N, k = 0..N-1 (N = 4: 0, pi/2, pi, 3*pi/2).
// Every modulated exposure uses the same sub-exposure split. A depth schedule (kDepth) has one
// exposure of content kDepth, then with depth_amplitude one of kAmplitude (harmonic 0,
// frequency 0, phase shift 0, exposure_s, illumination on, take 0): its source copies
// exposures()[i] into each frame and stamps cycle, sequence and timestamp.
class AcquisitionSchedule {
 public:
  // InvalidArgument when `options` fails Validate().
  [[nodiscard]] static absl::StatusOr<AcquisitionSchedule> Create(const ScheduleOptions& options);

  const ScheduleOptions& options() const { return options_; }
  int order() const { return options_.order; }
  bool zeroth_measured() const { return options_.zeroth != ZerothScheme::kEstimated; }

  // Exposures of one cycle with cycle = sequence = 0 and timestamp_s = 0.
  std::span<const ExposureConfig> exposures() const { return exposures_; }
  // Raw frames one transient frame costs (thesis §8.5.3: m = 3, four-bucket, c_0 estimated,
  // one take -> 12).
  int raw_frames_per_frame() const { return static_cast<int>(exposures_.size()); }
  int exposures_per_take() const { return raw_frames_per_frame() / options_.takes; }

  // The sub-exposure split of every modulated exposure.
  std::span<const SubExposure> sub_exposures() const { return sub_exposures_; }
  // sum_k w_k exp(-i theta_k): what the split does to a sinusoidal effective modulation, whose
  // four-bucket phasor becomes nominal_gain() * c_j. The demodulator divides by it.
  Complex nominal_gain() const { return nominal_gain_; }

  // Position in exposures() of the exposure `config` describes (content, harmonic, frequency,
  // phase shift, exposure time, illumination and take must match; cycle, sequence and timestamp
  // are ignored). InvalidArgument describing the frame when none matches.
  absl::StatusOr<int> IndexOf(const ExposureConfig& config) const;

  // One line: "f = 23 MHz, m = 3, arccos (n_phi = 8), zeroth: pair, 1 take: 14 raw frames";
  // "depth camera (Z up to 10 m), with amplitude: 2 raw frames".
  std::string Describe() const;

 private:
  ScheduleOptions options_;
  std::vector<ExposureConfig> exposures_;
  std::vector<SubExposure> sub_exposures_;
  Complex nominal_gain_{1.0, 0.0};
};

// "harmonic 2 (46 MHz), phase shift 1.5708 rad, exposure 1.92 ms, illumination on, take 0";
// a depth camera's "depth (Z, m), take 0" / "amplitude, take 0".
std::string DescribeExposure(const ExposureConfig& config);
// A raw frame in messages: "frame 17 (cycle 1, harmonic 2 (46 MHz), ...)".
std::string DescribeFrame(const ExposureConfig& config);

}  // namespace transient
