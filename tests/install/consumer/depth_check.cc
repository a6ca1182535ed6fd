// A user's program on the installed client library: connects to transientd, streams DEPTH and
// checks what arrives (the sensor's geometry, metres, most pixels valid, depths of the mirrors
// scene). Exit 0 when all holds, 1 with the reason otherwise, 2 for a bad command line.
//   usage: depth_check HOST:PORT
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <string>

#include "transient/client/client.h"
#include "transient/client/frame_stream.h"
#include "transient/reconstruct/units.h"
#include "transient/v1/transient.pb.h"

namespace {

constexpr int kFrames = 3;
// The mirrors scene lies 2..3 m from the camera (docs/measuring.md); anything outside 0.5..10 m is wrong.
constexpr float kNearestM = 0.5f;
constexpr float kFarthestM = 10.0f;
// Most pixels see the scene: a few at silhouettes and in the dark may be invalid (NaN).
constexpr double kMinValidShare = 0.5;

int Fail(const std::string& why) {
  std::cerr << "depth_check: " << why << "\n";
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: depth_check HOST:PORT\n";
    return 2;
  }
  namespace client = transient::client;
  absl::StatusOr<client::Client> daemon =
      client::Client::Connect({.address = argv[1], .timeout_s = 20.0});
  if (!daemon.ok()) return Fail(daemon.status().ToString());
  absl::StatusOr<transient::v1::Info> info = daemon->GetInfo();
  if (!info.ok()) return Fail(info.status().ToString());
  const int width = static_cast<int>(info->camera().width());
  const int height = static_cast<int>(info->camera().height());

  transient::v1::StreamRequest request;
  request.add_products(transient::v1::DEPTH);
  std::unique_ptr<client::FrameStream> stream = daemon->StreamFrames(request);
  client::StreamFrame frame;
  int frames = 0;
  float nearest = kFarthestM, farthest = kNearestM;
  double valid_share = 0.0;
  while (frames < kFrames && stream->Next(&frame)) {
    if (frame.kind == client::StreamFrame::Kind::kCorrupt) {
      return Fail(frame.corruption.ToString());
    }
    if (frame.kind != client::StreamFrame::Kind::kImages) continue;
    ++frames;
    if (frame.images.size() != 1) {
      return Fail("expected one image, got " + std::to_string(frame.images.size()));
    }
    const client::DecodedImage& depth = frame.images.front();
    if (depth.name != "depth" || depth.product != transient::v1::DEPTH) {
      return Fail("expected the depth image, got '" + depth.name + "'");
    }
    if (depth.unit != transient::units::kMetres) return Fail("unit '" + depth.unit + "'");
    if (depth.geometry.width != width || depth.geometry.height != height) {
      return Fail("image " + std::to_string(depth.geometry.width) + "x" +
                  std::to_string(depth.geometry.height) + ", GetInfo says " +
                  std::to_string(width) + "x" + std::to_string(height));
    }
    int64_t valid = 0;
    for (const float z : depth.values) {
      if (std::isnan(z)) continue;
      if (!(z >= kNearestM && z <= kFarthestM)) {
        return Fail("depth " + std::to_string(z) + " m outside the scene's 0.5..10 m");
      }
      nearest = std::min(nearest, z);
      farthest = std::max(farthest, z);
      ++valid;
    }
    valid_share = static_cast<double>(valid) / static_cast<double>(depth.values.size());
    if (valid_share < kMinValidShare) {
      return Fail("only " + std::to_string(valid) + " of " +
                  std::to_string(depth.values.size()) + " pixels have a depth");
    }
  }
  if (const absl::Status end = stream->Finish(); !end.ok()) return Fail(end.ToString());
  if (frames < kFrames) return Fail("the stream ended after " + std::to_string(frames) + " frames");
  std::cout << "depth_check: " << frames << " frames of " << width << "x" << height << " from "
            << daemon->address() << ", " << 100.0 * valid_share << "% valid, depth " << nearest
            << ".." << farthest << " m\n";
  return 0;
}
