// The daemon's side of the products: sets of wire products, what they need of the core's
// products of a frame (frame_products.h), and the resolution of slice and moment depth requests
// against the sensor.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <vector>

#include "transient/reconstruct/frame_products.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/reconstruct/reconstructor.h"
#include "transient/v1/transient.pb.h"

namespace transient::service {

using ::transient::FrameProducts;
using ::transient::MomentDepthSpec;
using ::transient::ProductNeeds;
using ::transient::ProductOptions;
using ::transient::RangeMethod;

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


// At most this many distinct MOMENT_DEPTH specs are computed per frame for all streams.
inline constexpr int kMaxMomentDepthSpecs = 8;

// Resolves a request: near = far = 0 means [0, unambiguous_range_m]; sigma unset means 1 px;
// bits 0 means 64. InvalidArgument naming the field for a non-finite or negative near, far not
// above near, a negative or non-finite sigma, a filter wider than the sensor, or bits other
// than 0, 64 and 128.
absl::StatusOr<MomentDepthSpec> ResolveMomentDepthSpec(const v1::MomentDepthRequest& request,
                                                       ImageGeometry sensor,
                                                       double unambiguous_range_m);

// The core's products (frame_products.h) that a set of wire products needs, with the slice
// lists and moment depth specs of the requests.
ProductNeeds NeedsFor(const ProductSet& products);

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
