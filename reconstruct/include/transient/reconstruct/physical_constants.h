// The speed of light and the conversions between phase, round-trip time of flight and range
// that every part of the project uses (DESIGN.md, "Units and conventions"): phase
// phi = 2*pi*f*tau for base frequency f and round-trip time tau; range = c*tau/2.
#pragma once

#include <numbers>

namespace transient {

inline constexpr double kSpeedOfLight = 299'792'458.0;  // m/s, exact (SI)
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Round-trip time of flight (s) of phase `phase_rad` at base frequency f, and back (unwrapped).
inline double PhaseToTimeOfFlight(double phase_rad, double base_frequency_hz) {
  return phase_rad / (kTwoPi * base_frequency_hz);
}
inline double TimeOfFlightToPhase(double time_s, double base_frequency_hz) {
  return kTwoPi * base_frequency_hz * time_s;
}
// Range c*tau/2 (m) of a round-trip time of flight tau (s).
inline double TimeOfFlightToRange(double time_s) { return kSpeedOfLight * time_s / 2.0; }
// The range of phase 2*pi: c / (2 f), where ranges wrap (6.52 m at 23 MHz).
inline double UnambiguousRange(double base_frequency_hz) {
  return kSpeedOfLight / (2.0 * base_frequency_hz);
}

}  // namespace transient
