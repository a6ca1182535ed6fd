// The products of one solved frame (DESIGN.md, "The data path", step 4): range and depth, the
// amplitude and c_0, the flags that say why a pixel has no value, the Pisarenko returns and the
// direct/indirect split, MESE density and cumulative slices at lists of phases, and moment depth
// maps. Computed once per frame for the union of what its consumers need: the daemon's
// subscribers, `transient reconstruct`'s file, `transient view`'s pictures.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/reconstruct/phase_unwrapping.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient {

// How the range of a pixel is chosen (thesis §8.4.3): the first MESE peak above the threshold,
// or the first Pisarenko return whose weight is above it.
enum class RangeMethod { kMese, kPisarenko };

struct ProductOptions {
  double base_frequency_hz = 23e6;
  RangeMethod range_method = RangeMethod::kMese;
  double threshold = 0.1;  // relative to the pixel's highest density / largest weight
};

// A moment depth map asked for (moment_depth_map.h): equal specs share one map per frame.
struct MomentDepthSpec {
  double near_m = 0.0;
  double far_m = 1.0;
  double sigma_px = 1.0;  // 0 = no filter
  MomentMapFormat format = MomentMapFormat::kOptimized64;
  bool from_returns = false;  // the Pisarenko returns instead of the single depth

  MomentDepthMapOptions MapOptions() const {
    return {.normalisation = {.near_m = near_m, .far_m = far_m},
            .sigma_px = sigma_px,
            .format = format};
  }
  friend auto operator<=>(const MomentDepthSpec&, const MomentDepthSpec&) = default;
};

struct SliceImages {
  std::vector<float> density;     // [slices, pixels], per radian of phase (thesis eq. 8.3)
  std::vector<float> cumulative;  // [slices, pixels] (thesis eq. 8.9); empty unless asked
};

struct SliceNeed {
  bool density = false;
  bool cumulative = false;
};

// What to compute. Planes not needed stay empty.
struct ProductNeeds {
  bool range = false;      // range_m, by ProductOptions::range_method, and kFlagNoReturn
  bool depth = false;      // depth_m: Z of the range (camera_model.h)
  bool amplitude = false;  // |c_1|
  bool c0 = false;
  bool direct_indirect = false;  // Pisarenko: the first return's weight, and the others'
  bool pisarenko = false;        // the Pisarenko returns themselves (phase, weight, uniform)
  bool pisarenko_range = false;  // the first Pisarenko return's range, whatever the method
  std::map<std::vector<double>, SliceNeed> slice_phases = {};  // keyed by phases in [0, 2*pi]
  std::vector<MomentDepthSpec> moment_depth = {};         // distinct specs
};

// Everything a consumer may take of one frame. Planes not needed are empty.
struct FrameProducts {
  uint64_t sequence = 0;
  ImageGeometry geometry;
  int order = 0;
  double base_frequency_hz = 0.0;
  // The moment state, per-pixel plots; always, except for a schedule without every harmonic
  // 1..m (ComputeUnwrappedProducts) and a depth camera's (ComputeDepthProducts), which have none.
  std::shared_ptr<const SolvedImage> solved;
  std::shared_ptr<const PisarenkoImage> pisarenko;  // when anything above needed it
  // PixelFlag bits: the solver's, and kFlagNoReturn where range_m is NaN on a valid pixel
  // (when the range was computed).
  std::vector<uint8_t> flags;
  std::vector<float> range_m, depth_m, amplitude, c0, direct, indirect;  // NaN = none
  std::vector<float> pisarenko_range_m;                                  // NaN = none
  // Phase unwrapping's coherence of the frequencies (phase_unwrapping.h), with range_m from
  // ComputeUnwrappedProducts only.
  std::vector<float> confidence;
  std::map<std::vector<double>, SliceImages> slices;  // keyed by their phases, radians
  std::map<MomentDepthSpec, std::shared_ptr<const MomentDepthMap>> moment_depth;
};

// Moment depth map builders kept from frame to frame, one per spec, so that their buffers
// (five planes of the image, before and after the filter: 12 MB at 640x480) are allocated
// once, not with every frame. Builders of specs no longer asked for are dropped, and one of
// another geometry is replaced. For one thread at a time (the reconstruction's).
class MomentDepthBuilders {
 public:
  // Keeps only the builders of `specs` (the specs of this frame).
  void Retain(const std::vector<MomentDepthSpec>& specs);
  // The builder of `spec` for `geometry`, created at its first frame; nullptr for a spec that
  // MomentDepthMapBuilder::Create refuses.
  MomentDepthMapBuilder* For(ImageGeometry geometry, const MomentDepthSpec& spec);
  size_t size() const { return builders_.size(); }

 private:
  std::map<MomentDepthSpec, std::optional<MomentDepthMapBuilder>> builders_;  // nullopt: refused
};

// Computes `needs` from the solved state with the kernels of reconstructor.h. `camera` gives
// the intrinsics for depth (Z = range * PixelRay(x, y).z; lens distortion not removed). Moment
// depth maps are built from the depth, or from the Pisarenko returns converted to depth the
// same way (returns weaker than the threshold times the pixel's strongest are left out); a spec
// whose map cannot be built (an invalid spec) is left out of the frame. The maps' builders come
// from `builders` when given (kept by the caller across frames), else they serve this frame only.
std::shared_ptr<const FrameProducts> ComputeProducts(std::shared_ptr<const SolvedImage> solved,
                                                     const CameraInfo& camera,
                                                     const ProductOptions& options,
                                                     const ProductNeeds& needs,
                                                     uint64_t sequence = 0,
                                                     MomentDepthBuilders* builders = nullptr);

// The products of a schedule whose harmonics are not all of 1..m (phase_unwrapping.h): range
// (with confidence, kFlagAmbiguous and kFlagLowAmplitude), depth, amplitude (the mean |c_j| of
// the measured harmonics), flags and moment depth maps of the depth. Needs that only the moment
// reconstruction has (c_0, Pisarenko, slices, maps of returns) are the caller's to refuse
// (ScheduleOptions::MissingHarmonicsText); they are left empty here. `unwrap` must pass
// Validate() and `moments` have order >= its highest harmonic (asserted). `builders` as for
// ComputeProducts.
std::shared_ptr<const FrameProducts> ComputeUnwrappedProducts(
    const MomentImage& moments, const CameraInfo& camera, const UnwrapOptions& unwrap,
    const ProductNeeds& needs, uint64_t sequence = 0, MomentDepthBuilders* builders = nullptr);

// The products of a depth camera's frame (SamplingScheme::kDepth): nothing demodulated or
// solved. depth_m is `depth_m` as given where it is finite and > 0, NaN elsewhere, with
// kFlagNoReturn in flags (the camera measured no depth there); range_m is RangeFromDepth of it
// (camera_model.h: the pinhole ray, lens distortion not removed); amplitude is `amplitude`
// (empty: the source delivers none, and the caller refused AMPLITUDE); moment depth maps are of
// the depth (specs from_returns are the caller's to refuse; left out here). order and
// base_frequency_hz are 0, `solved` is null. Range, depth and flags are always computed (they
// cost one pass); `depth_m` and a non-empty `amplitude` hold pixel_count() values (asserted).
// `builders` as for ComputeProducts.
std::shared_ptr<const FrameProducts> ComputeDepthProducts(
    std::span<const float> depth_m, std::span<const float> amplitude, const CameraInfo& camera,
    const ProductNeeds& needs, uint64_t sequence = 0, MomentDepthBuilders* builders = nullptr);

// Combines the solver's flags with a range estimate's kFlagNoReturn bit, so that a range plane
// is NaN exactly where the flags say why: the range functions flag every NaN they leave on a
// valid pixel; a NaN they did not flag is counted as "no return" too.
void MergeNoReturn(std::span<const uint8_t> solved_flags, std::span<const uint8_t> range_flags,
                   std::span<const float> range_m, std::span<uint8_t> out);

}  // namespace transient
