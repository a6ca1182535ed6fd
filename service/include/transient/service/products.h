// The products of one transient frame (DESIGN.md, "The data path", step 4), computed once per
// frame from the per-pixel solved state for the union of what the subscribers asked for.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <vector>

#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/reconstruct/reconstructor.h"
#include "transient/v1/transient.pb.h"

namespace transient::service {

enum class RangeMethod { kMese, kPisarenko };

// A set of v1::Product values.
class ProductSet {
 public:
  ProductSet() = default;
  void Add(v1::Product product) { bits_ |= Bit(product); }
  bool Has(v1::Product product) const { return (bits_ & Bit(product)) != 0; }
  bool empty() const { return bits_ == 0; }
  ProductSet& operator|=(const ProductSet& other) {
    bits_ |= other.bits_;
    return *this;
  }
  std::vector<v1::Product> List() const;
  friend bool operator==(const ProductSet&, const ProductSet&) = default;

 private:
  static uint32_t Bit(v1::Product product) { return uint32_t{1} << static_cast<int>(product); }
  uint32_t bits_ = 0;
};


struct SliceImages {
  std::vector<float> density;     // [slices, pixels], per radian of phase (thesis eq. 8.3)
  std::vector<float> cumulative;  // [slices, pixels] (thesis eq. 8.9); empty unless asked
};

// A MOMENT_DEPTH request resolved against the sensor (v1::MomentDepthRequest): equal specs of
// several subscribers share one map per frame.
struct MomentDepthSpec {
  double near_m = 0.0;
  double far_m = 1.0;
  double sigma_px = 1.0;  // 0 = no filter
  MomentMapFormat format = MomentMapFormat::kOptimized64;
  bool from_returns = false;  // Pisarenko returns instead of the single depth

  MomentDepthMapOptions MapOptions() const {
    return {.normalisation = {.near_m = near_m, .far_m = far_m},
            .sigma_px = sigma_px,
            .format = format};
  }
  friend auto operator<=>(const MomentDepthSpec&, const MomentDepthSpec&) = default;
};

// At most this many distinct MOMENT_DEPTH specs are computed per frame for all streams.
inline constexpr int kMaxMomentDepthSpecs = 8;

// Resolves a request: near = far = 0 means [0, unambiguous_range_m]; sigma unset means 1 px;
// bits 0 means 64. InvalidArgument naming the field for a non-finite or negative near, far not
// above near, a negative or non-finite sigma, a filter wider than the sensor, or bits other
// than 0, 64 and 128.
absl::StatusOr<MomentDepthSpec> ResolveMomentDepthSpec(const v1::MomentDepthRequest& request,
                                                       ImageGeometry sensor,
                                                       double unambiguous_range_m);

struct ProductOptions {
  double base_frequency_hz = 23e6;
  RangeMethod range_method = RangeMethod::kMese;
  double threshold = 0.1;
};

// Everything a subscriber may ask of one frame. Planes not asked for by anyone are empty.
struct FrameProducts {
  uint64_t sequence = 0;
  ImageGeometry geometry;
  int order = 0;
  double base_frequency_hz = 0.0;
  std::shared_ptr<const SolvedImage> solved;        // always: MOMENT_STATE, GetPixel
  std::shared_ptr<const PisarenkoImage> pisarenko;  // when range or separation needed it
  std::vector<uint8_t> flags;                       // PixelFlag bits, incl. kFlagNoReturn
  std::vector<float> range_m, depth_m, amplitude, c0, direct, indirect;
  std::map<std::vector<double>, SliceImages> slices;  // keyed by their phases, radians
  std::map<MomentDepthSpec, std::shared_ptr<const MomentDepthMap>> moment_depth;
};

// What to compute: products, and per phase list of SLICES/CUMULATIVE requests which of the two.
struct SliceNeed {
  bool density = false;
  bool cumulative = false;
};
struct ProductNeeds {
  ProductSet products;
  std::map<std::vector<double>, SliceNeed> slice_phases;
  std::vector<MomentDepthSpec> moment_depth;  // distinct specs, for MOMENT_DEPTH
};

// Computes the needed planes from the solved state (with the kernels of reconstructor.h).
// `camera` gives the intrinsics for DEPTH (Z = range / |(x - cx)/fx, (y - cy)/fy, 1|; the lens
// distortion is not removed). MOMENT_DEPTH maps are built from DEPTH, or from the Pisarenko
// returns converted to depth the same way; a spec whose map cannot be built (which Resolve
// rules out) is left out of the frame, so that its subscribers get no frame rather than a wrong
// one.
std::shared_ptr<const FrameProducts> ComputeProducts(std::shared_ptr<const SolvedImage> solved,
                                                     const CameraInfo& camera,
                                                     const ProductOptions& options,
                                                     const ProductNeeds& needs,
                                                     uint64_t sequence);

// Phases (radians in [0, 2*pi)) of the slices of a request at base frequency f: `bins` uniform
// bins, or listed bin indices of `bins`, or listed round-trip times of flight (ns).
// InvalidArgument naming the field for bins = 0 with nothing listed, bins > kMaxSliceBins, an
// index >= bins, a negative or non-finite time, more than kMaxSlices slices, or more slice
// memory per frame than kMaxSliceBytesPerFrame for this sensor.
inline constexpr int kMaxSliceBins = 4096;
inline constexpr int kMaxSlices = 1024;
inline constexpr int64_t kMaxSliceBytesPerFrame = int64_t{64} << 20;
absl::StatusOr<std::vector<double>> ResolveSlicePhases(const v1::SliceSpec& spec,
                                                       double base_frequency_hz,
                                                       ImageGeometry geometry);

// Round-trip time of flight (ns) of phase phi at base frequency f, and back (phase in [0, 2pi)).
double PhaseToTimeOfFlightNs(double phase_rad, double base_frequency_hz);
double TimeOfFlightNsToPhase(double time_ns, double base_frequency_hz);

}  // namespace transient::service
