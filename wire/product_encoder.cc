// Encoding a frame's products as transient.v1 images (product_encoder.h).
#include "transient/wire/product_encoder.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/reconstruct/physical_constants.h"
#include "transient/wire/product_registry.h"

namespace transient::wire {

// Names an encoded image of `kind` (index: its slice or harmonic) as the registry says.
void LabelImage(ImageKind kind, int index, v1::Image* image) {
  image->set_name(ImageName(kind, index));
  image->set_product(Image(kind).product);
  image->set_unit(WireUnit(kind, image->encoding()));
}

namespace {

// Adds one float plane as an image; false when the frame lacks it (asked for after the frame's
// products were chosen).
absl::StatusOr<bool> AddFloat(const ProductEncoding& plan, const FrameProducts& products,
                              std::span<const float> plane, ImageKind kind, v1::Frame* frame,
                              int index = 0, double time_ns = 0.0) {
  if (plane.size() != static_cast<size_t>(products.geometry.pixel_count())) return false;
  v1::Image* image = frame->add_images();
  if (absl::Status status = EncodeFloatPlane(plane, products.geometry, plan.rect, plan.encoding,
                                             plan.compression, image);
      !status.ok()) {
    return status;
  }
  LabelImage(kind, index, image);
  image->set_time_of_flight_ns(time_ns);  // 0 (proto3: not sent) for all but slices
  return true;
}

}  // namespace

// What EncodeProducts's result depends on besides the frame: streams whose plans have the same
// key share one encoding of each frame (PublishedFrame::encoded). Phases as hexadecimal floats:
// exact.
std::string EncodingKey(const ProductEncoding& plan) {
  std::string key;
  for (v1::Product p : plan.products) absl::StrAppend(&key, static_cast<int>(p), ",");
  absl::StrAppend(&key, "|", plan.rect.x, ",", plan.rect.y, ",", plan.rect.width, ",",
                  plan.rect.height, "|", static_cast<int>(plan.encoding), "|",
                  static_cast<int>(plan.compression), "|");
  for (double phase : plan.slice_phases) absl::StrAppend(&key, absl::StrFormat("%a,", phase));
  const MomentDepthSpec& m = plan.moment_depth;
  absl::StrAppend(&key, "|",
                  absl::StrFormat("%a,%a,%a,%d,%d", m.near_m, m.far_m, m.sigma_px,
                                  static_cast<int>(m.format), m.from_returns ? 1 : 0));
  return key;
}

// Fills `frame` with the planned products of `products`. false when one is missing.
absl::StatusOr<bool> EncodeProducts(const ProductEncoding& plan, const FrameProducts& products,
                                    v1::Frame* frame) {
  const size_t pixels = static_cast<size_t>(products.geometry.pixel_count());
  for (v1::Product product : plan.products) {
    absl::StatusOr<bool> added = true;
    switch (product) {
      case v1::RANGE:
        added = AddFloat(plan, products, products.range_m, ImageKind::kRange, frame);
        break;
      case v1::DEPTH:
        added = AddFloat(plan, products, products.depth_m, ImageKind::kDepth, frame);
        break;
      case v1::AMPLITUDE:
        added = AddFloat(plan, products, products.amplitude, ImageKind::kAmplitude, frame);
        break;
      case v1::C0:
        added = AddFloat(plan, products, products.c0, ImageKind::kC0, frame);
        break;
      case v1::FLAGS: {
        v1::Image* image = frame->add_images();
        if (absl::Status status = EncodeBytePlane(products.flags, products.geometry, plan.rect,
                                                  plan.compression, image);
            !status.ok()) {
          return status;
        }
        LabelImage(ImageKind::kFlags, 0, image);
        break;
      }
      case v1::MOMENT_STATE: {
        const SolvedImage& s = *products.solved;
        std::vector<float> plane(pixels);
        auto add_plane = [&](const std::vector<double>& source, int j,
                             ImageKind kind) -> absl::StatusOr<bool> {
          for (size_t p = 0; p < pixels; ++p) {
            plane[p] = static_cast<float>(source[j * pixels + p]);
          }
          return AddFloat(plan, products, plane, kind, frame, j);
        };
        for (int j = 0; j <= s.order && added.ok(); ++j) {
          added = add_plane(s.c_real, j, ImageKind::kCReal);
          if (added.ok() && j > 0) added = add_plane(s.c_imag, j, ImageKind::kCImag);
          if (added.ok()) added = add_plane(s.q_real, j, ImageKind::kQReal);
          if (added.ok()) added = add_plane(s.q_imag, j, ImageKind::kQImag);
        }
        break;
      }
      case v1::SLICES:
      case v1::CUMULATIVE: {
        auto it = products.slices.find(plan.slice_phases);
        if (it == products.slices.end()) return false;
        const std::vector<float>& planes =
            product == v1::SLICES ? it->second.density : it->second.cumulative;
        const std::vector<double>& phases = plan.slice_phases;
        if (planes.size() != phases.size() * pixels) return false;
        for (size_t n = 0; n < phases.size() && added.ok() && *added; ++n) {
          added =
              AddFloat(plan, products, std::span<const float>(planes).subspan(n * pixels, pixels),
                       product == v1::SLICES ? ImageKind::kSlice : ImageKind::kCumulative, frame,
                       static_cast<int>(n),
                       PhaseToTimeOfFlight(phases[n], products.base_frequency_hz) * 1e9);
        }
        break;
      }
      case v1::DIRECT_INDIRECT:
        added = AddFloat(plan, products, products.direct, ImageKind::kDirect, frame);
        if (added.ok() && *added) {
          added = AddFloat(plan, products, products.indirect, ImageKind::kIndirect, frame);
        }
        break;
      case v1::CONFIDENCE:
        added = AddFloat(plan, products, products.confidence, ImageKind::kConfidence, frame);
        break;
      case v1::MOMENT_DEPTH: {
        auto it = products.moment_depth.find(plan.moment_depth);
        if (it == products.moment_depth.end()) return false;
        v1::Image* image = frame->add_images();
        if (absl::Status status = EncodeMomentDepth(*it->second, plan.moment_depth.from_returns,
                                                    plan.rect, plan.compression, image);
            !status.ok()) {
          return status;
        }
        LabelImage(ImageKind::kMomentDepth, 0, image);
        break;
      }
      default:
        return absl::InternalError(absl::StrCat("unplanned product ", product));
    }
    if (!added.ok()) return added.status();
    if (!*added) return false;
  }
  return true;
}

}  // namespace transient::wire
