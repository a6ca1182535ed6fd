// The virtual objects of the moment-depth pictures (moment_pictures.h) as fragments: a plane and
// a sphere ray cast through the camera's view, and a backdrop seen from a viewpoint beside the
// camera, each fragment with its depth and where it falls in the camera image.
#pragma once

#include <vector>

#include "tools/transient/common/image_writers.h"
#include "tools/transient/view/moment_setup.h"
#include "transient/reconstruct/image.h"

namespace transient::tools {

// Okabe-Ito colours: the plane's checks and the sphere.
inline constexpr Rgb8 kPlaneColourA = {0, 158, 115};
inline constexpr Rgb8 kPlaneColourB = {86, 180, 233};
inline constexpr Rgb8 kSphereColour = {230, 159, 0};
// Virtual fragments at the output resolution (upscale times the camera's), row-major.
struct Fragments {
  ImageGeometry geometry = {};
  std::vector<float> depth_m;  // optical Z of the fragment; NaN = no fragment
  std::vector<float> x, y;     // where it falls in the camera image (pixel coordinates)
  std::vector<Rgb8> colour;    // shaded surface colour (objects; empty for the backdrop)
};

// Ray casting of the objects through every output pixel of the camera's view (pixel centre of
// output pixel (U, V): camera coordinates x = (U + 0.5)/upscale - 0.5, likewise y), and of the
// backdrop from the displaced viewpoint (its fragments carry their projection into the camera).
Fragments RenderPlane(const MomentSetup& setup);
Fragments RenderSphere(const MomentSetup& setup);
Fragments RenderBackdrop(const MomentSetup& setup);

}  // namespace transient::tools
