// One reconstructed transient frame in memory: what `transient view` draws, independent of
// where it came from (a reconstruction file, a moment file reconstructed on the fly, later a
// running daemon). Every plane is row-major with geometry.pixel_count() values per plane.
#pragma once

#include <bitset>
#include <cstdint>
#include <initializer_list>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "transient/formats/reconstruction_file.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/physical_constants.h"

namespace transient {

struct TransientFrame {
  ImageGeometry geometry = {};
  int order = 0;                  // m
  double base_frequency_hz = 0.0; // f; one period 1/f of round-trip time of flight
  int64_t index = 0;              // frame index in its source
  double threshold = 0.1;         // relative threshold of a return used for range and direct
  // Phases phi_n of the bins planes (density, cumulative, bounds), rad in [0, 2*pi); the time of
  // flight of bin n is phi_n / (2*pi*f).
  std::vector<double> phases = {};
  std::optional<double> bounds_r = std::nullopt;  // r of the bounds planes, when present

  // Each of these is empty when the source does not have it.
  std::vector<float> range_m = {};  // range of the first return, m; NaN = none
  std::vector<float> c0 = {};       // c_0 after biasing, sensor units; NaN = invalid pixel
  std::vector<uint8_t> flags = {};  // PixelFlag bits
  // bins planes: MESE density D(phi_n), sensor units per radian (thesis eq. 8.3).
  std::vector<float> density = {};
  // bins planes: MESE light arriving in [0, phi_n], sensor units (thesis eq. 8.9).
  std::vector<float> cumulative = {};
  // m planes each: the Pisarenko returns, phase in rad ascending and weight in sensor units;
  // NaN padding (thesis §8.4.1).
  std::vector<float> pisarenko_phase = {};
  std::vector<float> pisarenko_weight = {};
  std::vector<float> pisarenko_uniform = {};   // mass of the uniform part, sensor units
  std::vector<float> pisarenko_range_m = {};   // range of the first return above threshold, m
  std::vector<float> pisarenko_direct = {};    // weight of that return, sensor units
  std::vector<float> pisarenko_indirect = {};  // the other returns' weights, sensor units
  // bins planes: sharp bounds of the Poisson-smoothed density (thesis prop. 8.4), per radian.
  std::vector<float> bounds_lower = {};
  std::vector<float> bounds_upper = {};

  int bins() const { return static_cast<int>(phases.size()); }
  double period_s() const { return 1.0 / base_frequency_hz; }
  // Round-trip time of flight of phase `phi` (rad), ns.
  double TimeOfFlightNs(double phi) const {
    return PhaseToTimeOfFlight(phi, base_frequency_hz) * 1e9;
  }
  double BinTimeOfFlightNs(int bin) const { return TimeOfFlightNs(phases[bin]); }
  int64_t pixel_index(int x, int y) const { return int64_t{y} * geometry.width + x; }
  // Value of plane `plane` of a stack of planes at pixel (x, y).
  float at(const std::vector<float>& planes, int plane, int x, int y) const {
    return planes[plane * geometry.pixel_count() + pixel_index(x, y)];
  }
};

// A set of Product (reconstruction_file.h): which planes of a TransientFrame to fill.
using ProductSet = std::bitset<kProductCount>;
ProductSet Products(std::initializer_list<Product> products);

// Where frames come from: a reconstruction file (ReconstructionReader), later a running daemon.
class TransientFrameSource {
 public:
  virtual ~TransientFrameSource() = default;
  virtual const std::string& name() const = 0;  // for messages: the file as given
  virtual int64_t frames() const = 0;
  virtual ImageGeometry geometry() const = 0;
  virtual double base_frequency_hz() const = 0;
  virtual int bins() const = 0;  // phases of the bins products; 0 without them
  virtual ProductSet available() const = 0;
  // Fills the planes of `wanted` of frame `frame` (0 <= frame < frames()) and empties the
  // others. NotFound when a wanted product is not available.
  virtual absl::Status ReadFrame(int64_t frame, ProductSet wanted, TransientFrame* out) const = 0;
};

// Range c*tau/2 in metres of a round-trip time of flight in ns.
inline double RangeOfTimeOfFlightNs(double tau_ns) { return TimeOfFlightToRange(tau_ns * 1e-9); }

}  // namespace transient
