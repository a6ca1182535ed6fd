// What an OpenNI2 application gets from transientd through the driver, for openni2/README.md.
// Not a test: run it by hand against a running daemon, with the build's private OpenNI2 runtime,
//   LD_LIBRARY_PATH=build/openni2-runtime build/tests/openni2/transient_openni2_bench ADDR [s] [WxH]
// It reads the depth stream through OpenNI2's API for the given seconds (default 10; size
// default 640x480) and, in the same process, the daemon's DEPTH over gRPC, and prints:
//  - the rate of frames the OpenNI2 reader got, beside the rate the daemon sent;
//  - the latency from the end of a frame's capture to the OpenNI2 application, per frame index:
//    the gRPC client's arrival time minus the latency it computed (Frame.latency_s plus the
//    transfer) gives the end of capture on this machine's clock; the OpenNI2 frame's arrival
//    (waitForAnyStream returning) minus that is the latency; beside it, the gRPC client's own.
#include <OpenNI.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/time/clock.h"
#include "transient/client/client.h"
#include "transient/reconstruct/percentile.h"

namespace {

using transient::client::Client;
using transient::client::FrameStream;
using transient::client::StreamFrame;

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: transient_openni2_bench HOST:PORT [seconds] [WxH]\n");
    return 2;
  }
  const std::string address = argv[1];
  const double seconds = argc > 2 ? std::atof(argv[2]) : 10.0;
  int width = 640, height = 480;
  if (argc > 3 && std::sscanf(argv[3], "%dx%d", &width, &height) != 2) return 2;

  absl::StatusOr<Client> daemon = Client::Connect({.address = address});
  if (!daemon.ok()) {
    std::fprintf(stderr, "%s\n", daemon.status().ToString().c_str());
    return 1;
  }
  std::mutex mutex;
  std::map<uint64_t, absl::Time> capture_end;  // by frame index, this machine's clock
  int grpc_frames = 0;
  std::vector<double> grpc_latency_ms;  // the gRPC client's own, for comparison
  transient::v1::StreamRequest request;
  request.add_products(transient::v1::DEPTH);
  std::unique_ptr<FrameStream> stream = daemon->StreamFrames(request);
  std::thread grpc([&] {
    StreamFrame frame;
    while (stream->Next(&frame)) {
      if (frame.kind != StreamFrame::Kind::kImages) continue;
      std::lock_guard lock(mutex);
      capture_end[frame.sequence] = frame.arrival - absl::Seconds(frame.latency_s);
      grpc_latency_ms.push_back(frame.latency_s * 1e3);
      ++grpc_frames;
    }
  });

  setenv("TRANSIENT_OPENNI2_ADDRESS", address.c_str(), 1);
  if (openni::OpenNI::initialize() != openni::STATUS_OK) return 1;
  openni::Device device;
  const std::string uri = "transient://" + address;
  if (device.open(uri.c_str()) != openni::STATUS_OK) {
    std::fprintf(stderr, "cannot open %s: %s\n", uri.c_str(), openni::OpenNI::getExtendedError());
    return 1;
  }
  openni::VideoStream depth;
  depth.create(device, openni::SENSOR_DEPTH);
  openni::VideoMode mode = depth.getVideoMode();
  mode.setResolution(width, height);
  if (depth.setVideoMode(mode) != openni::STATUS_OK) return 1;
  depth.start();
  std::vector<std::pair<uint64_t, absl::Time>> arrivals;
  const absl::Time start = absl::Now();
  openni::VideoStream* streams[] = {&depth};
  while (absl::Now() - start < absl::Seconds(seconds)) {
    int ready = -1;
    if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, 2000) != openni::STATUS_OK) continue;
    openni::VideoFrameRef frame;
    if (depth.readFrame(&frame) != openni::STATUS_OK) continue;
    arrivals.emplace_back(frame.getFrameIndex(), absl::Now());
  }
  const double elapsed = absl::ToDoubleSeconds(absl::Now() - start);
  depth.stop();
  depth.destroy();
  device.close();
  openni::OpenNI::shutdown();
  stream->Cancel();
  grpc.join();

  std::vector<double> latency_ms;
  {
    std::lock_guard lock(mutex);
    for (const auto& [index, arrival] : arrivals) {
      const auto found = capture_end.find(index);
      if (found != capture_end.end()) {
        latency_ms.push_back(absl::ToDoubleMilliseconds(arrival - found->second));
      }
    }
  }
  std::printf("OpenNI2 reader, %dx%d depth: %zu frames in %.1f s = %.1f frames/s; "
              "the daemon sent %d over gRPC (%.1f frames/s)\n",
              width, height, arrivals.size(), elapsed, arrivals.size() / elapsed, grpc_frames,
              grpc_frames / elapsed);
  const size_t matched = latency_ms.size();
  std::printf("latency, end of capture to the OpenNI2 application (%zu frames): p50 %.1f ms, "
              "p90 %.1f ms, p99 %.1f ms\n",
              matched, transient::Percentile(latency_ms, 50), transient::Percentile(latency_ms, 90),
              transient::Percentile(latency_ms, 99));
  std::printf("latency, end of capture to the gRPC client in the same process (%zu frames): "
              "p50 %.1f ms, p90 %.1f ms, p99 %.1f ms\n",
              grpc_latency_ms.size(), transient::Percentile(grpc_latency_ms, 50),
              transient::Percentile(grpc_latency_ms, 90), transient::Percentile(grpc_latency_ms, 99));
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return Main(argc, argv); }
