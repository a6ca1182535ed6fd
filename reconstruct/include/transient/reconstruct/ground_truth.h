// The truth behind a simulated capture, per pixel: what the simulator knows and a capture file
// stores beside the frames, so that reconstructions can be compared with it.
#pragma once

#include <vector>

#include "transient/reconstruct/image.h"

namespace transient {

// What a simulated scene really contains, per pixel: the returns of its impulse response and
// the moments they have. Returns of one pixel are sorted by delay; unused entries hold NaN.
struct GroundTruth {
  ImageGeometry geometry;
  int max_returns = 0;                  // R
  std::vector<float> first_range_m;     // [H*W] range c*tau/2 of the earliest return; NaN if none
  std::vector<float> return_range_m;    // [R, H, W] range of each return's onset (its mode for
                                        // a continuous return), metres
  std::vector<float> return_amplitude;  // [R, H, W] total light of each return (sensor units)
  std::vector<float> return_spread_m;   // [R, H, W] 0 for a Dirac return, else the range
                                        // extent holding most of a continuous return
  MomentImage moments;                  // true c_0..c_m at the schedule's f, in the units a
                                        // calibrated capture reproduces
};

}  // namespace transient
