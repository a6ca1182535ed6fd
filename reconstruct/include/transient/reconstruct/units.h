// The units of what the reconstruction computes, as the strings that files (a dataset's
// `units` attribute) and the wire (Image.unit) carry: one spelling each. Moments are in the
// sensor's own units, linear in light (DESIGN.md, "Units and conventions").
#pragma once

namespace transient::units {

inline constexpr char kMetres[] = "m";               // range, depth
inline constexpr char kMillimetres[] = "mm";         // range, depth as 16UC1 (REP 118)
inline constexpr char kRadians[] = "rad";            // phase
inline constexpr char kSensor[] = "sensor";          // c_0, amplitude, light, return weights
inline constexpr char kSensorPerRadian[] = "sensor/rad";  // MESE density and its bounds
inline constexpr char kPerSensor[] = "1/sensor";     // q = C^{-1} e_0
inline constexpr char kBits[] = "bits";              // PixelFlag planes
inline constexpr char kDimensionless[] = "1";        // normalised depth moments

}  // namespace transient::units
