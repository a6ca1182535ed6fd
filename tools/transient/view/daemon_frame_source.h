// `transient view daemon:ADDR`: frames received from a running transientd over gRPC, served to
// the picture code as a TransientFrameSource. The frames are received once, up front, and held
// in memory: a live source cannot be read twice, and the view reads every frame twice (colour
// scales first, then the pictures).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "tools/transient/view/point_cloud.h"
#include "transient/client/client.h"
#include "transient/formats/transient_frame.h"

namespace transient::tools {

// An input of `transient view` that names a daemon rather than a file: "daemon:" then a gRPC
// target, host:port or unix:PATH.
inline constexpr char kDaemonInputPrefix[] = "daemon:";
bool IsDaemonInput(absl::string_view input);

// At most this many frames are received (they are held in memory).
inline constexpr int64_t kMaxDaemonFrames = 1000;
// ... and at most this many bytes of planes, so that a large --frames x --bins fails up front.
inline constexpr int64_t kMaxDaemonFrameBytes = int64_t{2} << 30;

struct DaemonSourceOptions {
  std::string address = {};  // gRPC target of transientd (the input without "daemon:")
  int64_t frames = 4;        // frames with images to receive, 1..kMaxDaemonFrames
  int bins = 64;  // SLICES and CUMULATIVE uniform over one period, 1..wire::kMaxSlices
  double connect_timeout_s = 5.0;
  client::ChannelSecurity security = {};  // TLS, client certificate, token (files)

  // The message names the option (--frames, --bins, --connect-timeout), the value and the rule.
  absl::Status Validate() const;
};

// Frames of transientd with RANGE, C0, FLAGS, SLICES, CUMULATIVE and DIRECT_INDIRECT (those
// the daemon offers), as Product::kRange, kZerothMoment, kFlags, kDensity, kCumulative,
// kPisarenkoDirect and kPisarenkoIndirect. The daemon sends no Pisarenko returns, bounds or
// Pisarenko range: those products are not available. Bins are phases 2*pi*n/bins, as the
// daemon's SliceSpec defines them; base frequency, order and geometry come from GetInfo, the
// threshold from GetConfig.
class DaemonFrameSource : public TransientFrameSource {
 public:
  // Connects with the client library (client::Client: Unavailable "cannot reach transientd at
  // ADDR within T s"), asks GetInfo and GetConfig, then receives options.frames frames of the
  // whole sensor as float32. State announcements are skipped. A frame whose images do not decode, do not have the sensor's
  // size or lack a product asked for is dropped and counted; more dropped frames than
  // options.frames is DataLoss. When the stream ends early (a replay reached its end) the
  // frames received are kept and notes() says so; with none, the stream's status (OutOfRange
  // for an ended source) prefixed with the address. Cancelled when *cancel turns true.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<DaemonFrameSource>> Receive(
      const DaemonSourceOptions& options, const std::atomic<bool>* cancel = nullptr);

  const std::string& name() const override { return name_; }
  int64_t frames() const override { return static_cast<int64_t>(frames_.size()); }
  ImageGeometry geometry() const override { return geometry_; }
  double base_frequency_hz() const override { return base_frequency_hz_; }
  int bins() const override { return static_cast<int>(phases_.size()); }
  ProductSet available() const override { return available_; }
  absl::Status ReadFrame(int64_t frame, ProductSet wanted, TransientFrame* out) const override;

  const std::vector<double>& phases() const { return phases_; }
  // The camera's pinhole intrinsics from GetInfo; none when the daemon sent invalid ones.
  const std::optional<PinholeIntrinsics>& intrinsics() const { return intrinsics_; }
  const std::string& source_uri() const { return source_uri_; }
  // Frame.sequence of each frame received, in order.
  const std::vector<uint64_t>& sequences() const { return sequences_; }
  // What did not go as asked: an early end, dropped frames.
  const std::vector<std::string>& notes() const { return notes_; }

 private:
  DaemonFrameSource() = default;

  std::string name_;
  std::string source_uri_;
  ImageGeometry geometry_;
  double base_frequency_hz_ = 0.0;
  int order_ = 0;
  double threshold_ = 0.1;
  std::vector<double> phases_;
  ProductSet available_;
  std::optional<PinholeIntrinsics> intrinsics_;
  std::vector<TransientFrame> frames_;
  std::vector<uint64_t> sequences_;
  std::vector<std::string> notes_;
};

}  // namespace transient::tools
