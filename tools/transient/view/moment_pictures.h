// The moment-depth pictures of `transient view --moment-depth` (issue 7): moment shadow mapping
// (thesis ch. 4) applied to camera depth, drawn as the assignment's report does. The camera's
// depth becomes a filtered 64-bit moment map (MomentDepthMapBuilder); virtual objects placed in
// the camera's view ask it which fraction of each pixel's footprint the real scene covers in
// front of them; and since an AMCW camera's light sits at the camera, the same map is a shadow
// map that casts the real scene's soft shadow onto a virtual backdrop. Hard depth test, VSM,
// Hamburger and Hausdorff 4MSM side by side.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/view/figure.h"
#include "tools/transient/view/moment_setup.h"
#include "tools/transient/view/point_cloud.h"
#include "tools/transient/view/virtual_scene.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/moment_depth_map.h"

namespace transient::tools {

// frame_NNN/<kMomentDirectory>/ holds a frame's moment-depth pictures.
inline constexpr char kMomentDirectory[] = "moment_depth";

// How a virtual fragment is tested against the real scene.
enum class OcclusionTest {
  kHardDepth,   // nearest depth texel: hidden when the real depth is nearer (no filtering)
  kVariance,    // variance shadow maps (assignment), on the filtered moments
  kHamburger4,  // Hamburger 4MSM (thesis alg. 4.2)
  kHausdorff4,  // Hausdorff 4MSM (thesis app. C.2)
};
inline constexpr std::array<OcclusionTest, 4> kOcclusionTests = {
    OcclusionTest::kHardDepth, OcclusionTest::kVariance, OcclusionTest::kHamburger4,
    OcclusionTest::kHausdorff4};
const char* OcclusionTestName(OcclusionTest test);

enum class VirtualObject { kPlane, kSphere };
const char* VirtualObjectName(VirtualObject object);  // "virtual plane", "virtual sphere"

// The moment maps and pictures of one frame. Create once per run, SetFrame per frame.
class MomentPictures {
 public:
  // Builders of the unfiltered and each blurred map (64-bit optimized, thesis eq. 4.4) and the
  // fragments of the objects. InvalidArgument from MomentDepthMapBuilder::Create.
  static absl::StatusOr<MomentPictures> Create(const MomentSetup& setup);

  // The frame's optical depth (NaN = none) and its amplitude c0 (the background, grey over
  // [0, c0_scale]); builds every map. InvalidArgument for planes of the wrong size.
  absl::Status SetFrame(int64_t index, std::span<const float> depth_m, std::span<const float> c0,
                        double c0_scale);

  // Visibility 1 - G of each fragment (NaN where there is none): the hard test on the frame's
  // depth, the others on blur_px[blur]'s map bilinearly interpolated at the fragment, as a
  // renderer sampling the map would, with the 64-bit map's bias (kQuantized16MomentBias).
  std::vector<float> Visibility(const Fragments& fragments, OcclusionTest test, int blur) const;

  // Figures. `blur` -1 is the unfiltered map.
  ImageFigure MapFigure(int blur) const;
  ImageFigure CompositeFigure(VirtualObject object, OcclusionTest test, int blur) const;
  ImageFigure BackdropFigure(OcclusionTest test, int blur) const;
  cv::Mat ComparisonFigure() const;      // plane and sphere rows, four tests, compare blur
  cv::Mat ShadowFigure(int blur) const;  // the backdrop, four tests
  cv::Mat VideoFrameFigure() const;      // the plane: hard test and Hamburger 4MSM

  // Writes the frame's pictures into `dir` (created): map_unfiltered.png, map_sigma_S.png,
  // plane_sigma_S.png, sphere_sigma_S.png, shadow_sigma_S.png for every blur S, and
  // compare_sigma_S.png at the compare blur. Returns the number of PNG files written.
  absl::StatusOr<int> WriteFrame(const std::filesystem::path& dir) const;

  const MomentSetup& setup() const { return setup_; }
  const MomentDepthMap& map(int blur) const { return blur < 0 ? unfiltered_ : maps_[blur]; }
  const Fragments& fragments(VirtualObject object) const {
    return object == VirtualObject::kPlane ? plane_ : sphere_;
  }
  const Fragments& backdrop() const { return backdrop_; }

 private:
  explicit MomentPictures(const MomentSetup& setup) : setup_(setup) {}
  std::string Subtitle(int blur) const;
  std::vector<uint8_t> Composite(const Fragments& object,
                                 const std::vector<float>& visibility) const;

  MomentSetup setup_;
  std::vector<MomentDepthMapBuilder> builders_;  // one per blur
  std::optional<MomentDepthMapBuilder> unfiltered_builder_;
  std::vector<MomentDepthMap> maps_;
  MomentDepthMap unfiltered_;
  std::vector<std::vector<float>> texels_;  // decoded b_1..b_4 of each blurred map, interleaved
  Fragments plane_, sphere_, backdrop_;
  int64_t index_ = 0;
  std::vector<float> depth_m_;
  std::vector<float> grey_;  // background c0 / c0_scale, clamped to [0, 1]; NaN = none
};

}  // namespace transient::tools
