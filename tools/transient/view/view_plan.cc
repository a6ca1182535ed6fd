#include "tools/transient/view/view_plan.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tools/transient/view/moment_pictures.h"
#include "transient/reconstruct/status_context.h"
#include "transient/formats/reconstruction_reader.h"

namespace transient::tools {
namespace {

// The bin whose phase is nearest (on the circle) to the time of flight tau.
int NearestBin(const TransientFrameSource& source, const std::vector<double>& phases,
               double tau_ns) {
  const double two_pi = 2.0 * std::numbers::pi;
  const double phi = two_pi * source.base_frequency_hz() * tau_ns * 1e-9;
  int best = 0;
  double best_distance = two_pi;
  for (int n = 0; n < static_cast<int>(phases.size()); ++n) {
    double distance = std::fmod(std::abs(phases[n] - phi), two_pi);
    distance = std::min(distance, two_pi - distance);
    if (distance < best_distance) best = n, best_distance = distance;
  }
  return best;
}

}  // namespace

bool DrawsEverything(const ViewArgs& args) {
  return !args.slices && !args.cumulative && !args.video && !args.images && !args.point_cloud &&
         args.streak_rows.empty() && args.pixels.empty() && !args.moment.enabled;
}

absl::StatusOr<PinholeIntrinsics> CaptureIntrinsics(const CaptureReader& capture, ImageGeometry expected) {
  const CameraInfo& camera = capture.camera();
  if (camera.geometry != expected) {
    return absl::InvalidArgumentError(absl::StrCat(
        capture.path(), ": /camera: ", camera.geometry.width, "x", camera.geometry.height,
        " px, expected the reconstruction's ", expected.width, "x", expected.height, " px"));
  }
  const PinholeIntrinsics& intrinsics = camera.intrinsics;
  if (absl::Status status = intrinsics.Validate(); !status.ok()) {
    return WithContext(absl::StrCat(capture.path(), ": /camera"), status);
  }
  return intrinsics;
}

absl::StatusOr<ViewPlan> MakeViewPlan(const ViewArgs& args, const TransientFrameSource& source,
                                      const std::vector<double>& phases,
                                      std::optional<PinholeIntrinsics> input_intrinsics) {
  const ProductSet available = source.available();
  const auto has = [&](Product product) { return available[static_cast<int>(product)]; };
  const bool all = DrawsEverything(args);
  const ImageGeometry geometry = source.geometry();
  ViewPlan plan;
  plan.slices = args.slices || all;
  plan.cumulative = args.cumulative || all;
  plan.video = args.video || all;
  plan.images = args.images || all;
  plan.streak_rows = args.streak_rows;
  plan.pixels = args.pixels;
  if (all) {
    plan.streak_rows.push_back(geometry.height / 2);
    plan.pixels.push_back({geometry.width / 2, geometry.height / 2});
  }

  const std::string& name = source.name();
  const auto need = [&](bool asked, Product product, const char* what) -> absl::Status {
    if (!asked || has(product)) return absl::OkStatus();
    return absl::NotFoundError(absl::StrCat(name, ": has no dataset ", ProductPath(product),
                                            ", which ", what, " need"));
  };
  // Pictures chosen explicitly must be possible; "everything" skips what the input lacks.
  if (all) {
    plan.slices = plan.slices && has(Product::kDensity);
    plan.video = plan.video && has(Product::kDensity);
    plan.cumulative = plan.cumulative && has(Product::kCumulative);
    if (!has(Product::kDensity)) plan.streak_rows.clear();
  }
  for (absl::Status status :
       {need(plan.slices, Product::kDensity, "density slices (--slices)"),
        need(plan.video, Product::kDensity, "the video (--video)"),
        need(!plan.streak_rows.empty(), Product::kDensity, "streak images (--streak)"),
        need(plan.cumulative, Product::kCumulative, "cumulative frames (--cumulative)")}) {
    if (!status.ok()) return status;
  }
  plan.direct_indirect = plan.images && has(Product::kPisarenkoDirect);
  plan.pisarenko_range = plan.images && has(Product::kPisarenkoRange);

  const double period_ns = 1e9 / source.base_frequency_hz();
  for (double tau : args.tau_ns) {
    if (!(tau >= 0.0 && tau < period_ns)) {
      return absl::OutOfRangeError(absl::StrFormat(
          "--tau = %g ns: expected 0 <= tau < %.4g ns, one period of %s's base frequency %g MHz",
          tau, period_ns, name, source.base_frequency_hz() * 1e-6));
    }
  }
  if (plan.slices || plan.cumulative || plan.video) {
    if (args.tau_ns.empty()) {
      for (int n = 0; n < static_cast<int>(phases.size()); ++n) plan.bins.push_back(n);
    } else {
      for (double tau : args.tau_ns) plan.bins.push_back(NearestBin(source, phases, tau));
    }
  }
  for (int row : plan.streak_rows) {
    if (row < 0 || row >= geometry.height) {
      return absl::OutOfRangeError(absl::StrCat("--streak = ", row, ": scanline outside ", name,
                                                "'s image, expected 0 <= y < ", geometry.height));
    }
  }
  for (const PixelPosition& pixel : plan.pixels) {
    if (pixel.x < 0 || pixel.x >= geometry.width || pixel.y < 0 || pixel.y >= geometry.height) {
      return absl::OutOfRangeError(absl::StrCat(
          "--pixel = ", pixel.x, ",", pixel.y, ": outside ", name, "'s image of ", geometry.width,
          "x", geometry.height, " px, expected 0 <= x < ", geometry.width, " and 0 <= y < ",
          geometry.height));
    }
  }

  if (!args.camera_path.empty()) {
    absl::StatusOr<CaptureReader> camera = CaptureReader::Open(args.camera_path);
    if (!camera.ok()) return camera.status();
    absl::StatusOr<PinholeIntrinsics> intrinsics = CaptureIntrinsics(*camera, geometry);
    if (!intrinsics.ok()) return intrinsics.status();
    plan.intrinsics = *intrinsics;
  } else {
    plan.intrinsics = input_intrinsics;
  }
  plan.point_cloud = args.point_cloud || (all && plan.intrinsics.has_value());
  if (plan.point_cloud && !plan.intrinsics.has_value()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--point-cloud needs the camera's intrinsics: give --camera CAPTURE.h5 (a capture file "
        "of the camera that took ", name, ")"));
  }
  plan.moment_depth = args.moment.enabled;
  if (plan.moment_depth) {
    if (!plan.intrinsics.has_value()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--moment-depth needs the camera's intrinsics to turn range into depth: give --camera "
          "CAPTURE.h5 (a capture file of the camera that took ",
          name, ")"));
    }
    if (absl::Status status = need(true, Product::kRange, "the moment pictures (--moment-depth)");
        !status.ok()) {
      return status;
    }
    if (absl::Status status = CheckMomentOptionsForImage(args.moment, geometry); !status.ok()) {
      return status;
    }
  }

  ProductSet& wanted = plan.wanted;
  const auto want = [&](Product product) {
    if (has(product)) wanted.set(static_cast<int>(product));
  };
  if (plan.slices || plan.video || !plan.streak_rows.empty()) want(Product::kDensity);
  if (plan.cumulative) want(Product::kCumulative);
  if (plan.images || plan.point_cloud || !plan.pixels.empty() || plan.moment_depth) {
    want(Product::kRange);
    want(Product::kZerothMoment);
    want(Product::kFlags);
  }
  if (plan.images) {
    for (Product product : {Product::kPisarenkoDirect, Product::kPisarenkoIndirect,
                            Product::kPisarenkoRange}) {
      want(product);
    }
  }
  if (!plan.pixels.empty()) {
    for (Product product :
         {Product::kDensity, Product::kCumulative, Product::kPisarenkoPhase,
          Product::kPisarenkoWeight, Product::kPisarenkoUniform, Product::kBoundsLower,
          Product::kBoundsUpper}) {
      want(product);
    }
  }
  return plan;
}

}  // namespace transient::tools
