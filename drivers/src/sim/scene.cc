// Return planes and the scene factory.
#include "scene.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace transient::sim {

void ReturnPlanes::Reset(ImageGeometry g, int r) {
  geometry = g;
  max_returns = r;
  const size_t n = static_cast<size_t>(r) * g.pixel_count();
  tau_s.assign(n, 0.0f);
  amplitude.assign(n, 0.0f);
  sigma_s.assign(n, 0.0f);
  decay_rate.assign(n, 0.0f);
}

void ReturnPlanes::SortByDelay() {
  const int64_t count = geometry.pixel_count();
  struct Entry {
    float tau, amplitude, sigma, rate;
  };
  std::array<Entry, 16> entries;
  for (int64_t p = 0; p < count; ++p) {
    for (int r = 0; r < max_returns; ++r) {
      const int64_t i = index(r, p);
      entries[r] = {tau_s[i], amplitude[i], sigma_s[i], decay_rate[i]};
    }
    std::stable_sort(entries.begin(), entries.begin() + max_returns,
                     [](const Entry& a, const Entry& b) {
                       if ((a.amplitude > 0) != (b.amplitude > 0)) return a.amplitude > 0;
                       return a.tau < b.tau;
                     });
    for (int r = 0; r < max_returns; ++r) {
      const int64_t i = index(r, p);
      tau_s[i] = entries[r].tau;
      amplitude[i] = entries[r].amplitude;
      sigma_s[i] = entries[r].sigma;
      decay_rate[i] = entries[r].rate;
    }
  }
}

Complex CharacteristicFunction(const ReturnPlanes& returns, int64_t i, double omega) {
  const double sigma = returns.sigma_s[i];
  const double rate = returns.decay_rate[i];
  Complex value = std::polar(std::exp(-0.5 * sigma * sigma * omega * omega),
                             omega * static_cast<double>(returns.tau_s[i]));
  if (rate > 0.0) value /= Complex(1.0, -omega / rate);
  return value;
}

absl::StatusOr<std::unique_ptr<Scene>> MakeScene(const SimulatorOptions& options,
                                                 const CameraInfo& camera) {
  if (options.scene == "mirrors") return MakeMirrorsScene(options, camera);
  if (options.scene == "corner") return MakeCornerScene(options, camera);
  if (options.scene == "sparse") return MakeSparseScene(options, camera);
  if (options.scene == "video") return MakeVideoScene(options, camera);
  if (options.scene == "calibration") return MakeCalibrationScene(options, camera);
  return absl::InvalidArgumentError(absl::StrCat("unknown scene '", options.scene, "'"));
}

}  // namespace transient::sim
