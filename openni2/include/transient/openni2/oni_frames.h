// How transient's images become OpenNI2 frames and back: one home for the conventions that the
// OpenNI2 driver (openni2/driver.cc), the OpenNI2 input source (drivers/src/openni2/) and their
// tests share (../shared/research/openni2.md, sections 2.3, 2.4, 5.7, 5.12, 5.13).
//
// - Depth is Z in the optical frame as an unsigned 16-bit count of millimetres (DEPTH_1_MM) or
//   of 100 micrometres (DEPTH_100_UM); 0 means no depth. A depth above the stream's MAX_VALUE
//   is invalid (0), never clamped to the maximum: a recording's 16z codec is bounded by it, and
//   0xFFFF is never written (NiViewer indexes a 65535-entry histogram with it).
// - OpenNI2 applications rebuild a camera from the fields of view alone: fx = fy = f and a
//   centred principal point (PCL, ROS, RTAB-Map: (w - 1)/2). So a stream of size W x H is a
//   virtual ideal pinhole with that principal point and a focal length f chosen from the
//   sensor's, and its pixels are resampled from the sensor's image by nearest neighbour: the
//   value at (u, v) is the sensor's value along the ray ((u - (W-1)/2)/f, (v - (H-1)/2)/f, 1),
//   never an interpolation across a depth edge. Z is the same in both cameras (they share the
//   optical centre and axis). Rays are the undistorted pinhole's, as everywhere in the project
//   (reconstruct/camera_model.h).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "transient/reconstruct/camera_model.h"

namespace transient::openni2 {

enum class DepthUnit {
  kMillimetre,         // PIXEL_FORMAT_DEPTH_1_MM
  kHundredMicrometre,  // PIXEL_FORMAT_DEPTH_100_UM
};

// Metres per count of `unit`: 0.001 or 0.0001.
double MetresPerCount(DepthUnit unit);

// The largest depth a stream reports (its MAX_VALUE) for a camera whose depth reaches
// `max_depth_m`: ceil(max_depth_m / MetresPerCount), at most 65534; 65534 when max_depth_m is
// not finite or not positive.
uint16_t MaxDepthCount(double max_depth_m, DepthUnit unit);

// Z in metres as a depth pixel: round(z / MetresPerCount(unit)), or 0 when z is not finite,
// rounds to 0, or is above `max_count`.
uint16_t DepthCount(float z_m, DepthUnit unit, uint16_t max_count);

// A depth pixel in metres: NaN for 0 (no depth).
float DepthMetres(uint16_t count, DepthUnit unit);

// An amplitude (IR) pixel as GRAY16: round(amplitude * scale) clamped to 0..65535; 0 for NaN.
uint16_t IrCount(float amplitude, double scale);

// An amplitude pixel as the grey level of an RGB888 "colour" image: IrCount / 8 (a 12-bit
// sensor's amplitudes fill 0..255), rounded and clamped to 255.
uint8_t GreyLevel(float amplitude, double scale);

// The ideal pinhole of one stream size.
struct VirtualCamera {
  int width = 0, height = 0;
  double focal_px = 0.0;  // fx = fy
  double cx() const { return 0.5 * (width - 1); }
  double cy() const { return 0.5 * (height - 1); }
  // 2 atan(W / 2f) and 2 atan(H / 2f), radians: what the stream reports, from which applications
  // get f back.
  double HorizontalFov() const;
  double VerticalFov() const;
};

// The virtual camera of size width x height for `sensor`: the sensor's horizontal field of view
// spread over `width` pixels, f = fx * width / sensor width (the vertical one follows; rows
// beyond the sensor's view have no depth).
VirtualCamera VirtualCameraFor(const CameraInfo& sensor, int width, int height);

// For every pixel of `camera` (row-major), the index of the sensor pixel it takes its value
// from, or -1 when its ray leaves the sensor's image. A sensor that is an ideal pinhole (fx = fy,
// principal point centred) maps onto itself at its own size: its image passes unchanged.
std::vector<int32_t> ResampleMap(const CameraInfo& sensor, const VirtualCamera& camera);

}  // namespace transient::openni2
