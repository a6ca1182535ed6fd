// The v4l2: source's end-to-end numbers on the emulated MLX75027 (emulated_tof_sensor.h), for
// docs/v4l2.md. Not a test: run it by hand, under umockdev's preload library,
//   LD_PRELOAD=libumockdev-preload.so.0 build/tests/drivers/transient_v4l2_bench [seconds]
// It measures, on this machine, with the sensor's frames rendered once per frequency by the
// simulator and then delivered again and again (so that the simulator's cost is not measured):
//  1. the source alone: raw frames and capture cycles per second through the real ioctl, mmap
//     and unpack path (the emulated kernel side packs every frame into Y12P in this process too);
//  2. transientd on it (in this process, gRPC on loopback): the RANGE frames a client receives
//     per second, the latency the daemon reports, and the source's counters.
#include <grpcpp/grpcpp.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "tests/drivers/v4l2/emulated_tof_sensor.h"
#include "tests/drivers/v4l2/simulated_phases.h"
#include "transient/drivers/capture_source.h"
#include "transient/service/pipeline.h"
#include "transient/service/server.h"
#include "transient/v1/transient.grpc.pb.h"
#include "v4l2/frame_unpacker.h"

namespace transient::v4l2 {
namespace {

using testing::EmulatedNode;
using testing::EmulatedTofSensor;
using testing::ProgrammedSequence;

constexpr char kScene[] = "mirrors?gain_error=0&delay_error_ns=0&waveform=sinusoid";

// Renders each (frequency, phases) once with the simulator, then repeats it.
class CachedPhases {
 public:
  CachedPhases() : light_(kScene, /*signed_output=*/true) {}
  testing::Renderer AsRenderer() {
    return [this](const ProgrammedSequence& sequence, ImageGeometry geometry) {
      const auto key = std::make_pair(static_cast<long long>(sequence.frequency_hz),
                                      sequence.phases_deg);
      auto it = cache_.find(key);
      if (it == cache_.end()) it = cache_.emplace(key, light_.Render(sequence, geometry)).first;
      return it->second;
    };
  }

 private:
  testing::SimulatedPhases light_;
  std::map<std::pair<long long, std::vector<int64_t>>, std::vector<std::vector<int32_t>>> cache_;
};

std::string Uri(ImageGeometry geometry) {
  return absl::StrFormat("v4l2:/dev/video0?profile=mlx7502x&width=%d&height=%d&f=20e6&m=3",
                         geometry.width, geometry.height);
}

EmulatedNode Sensor(ImageGeometry geometry, CachedPhases& light, bool realtime) {
  EmulatedNode node;
  node.formats = {{kFourccY12P, "12-bit Greyscale (MIPI Packed)"}};
  node.controls = testing::Mlx7502xControls();
  node.sensor = geometry;
  node.renderer = light.AsRenderer();
  node.realtime = realtime;
  return node;
}

int SourceAlone(ImageGeometry geometry, double seconds) {
  EmulatedTofSensor sensor;
  CachedPhases light;
  sensor.AddNode(Sensor(geometry, light, /*realtime=*/false));
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(Uri(geometry));
  if (!source.ok() || !(*source)->Start().ok()) {
    std::fprintf(stderr, "%s\n", source.status().ToString().c_str());
    return 1;
  }
  RawFrame frame;
  for (int i = 0; i < 12; ++i) (void)(*source)->Next(absl::Seconds(5), &frame);  // warm-up
  const absl::Time start = absl::Now();
  int64_t frames = 0;
  while (absl::Now() - start < absl::Seconds(seconds)) {
    if (absl::Status s = (*source)->Next(absl::Seconds(5), &frame); !s.ok()) {
      std::fprintf(stderr, "%s\n", s.ToString().c_str());
      return 1;
    }
    ++frames;
  }
  const double elapsed = absl::ToDoubleSeconds(absl::Now() - start);
  std::printf("source alone, %dx%d, m = 3 (12 raw frames a cycle): %.0f raw frames/s, %.1f "
              "cycles/s\n",
              geometry.width, geometry.height, frames / elapsed, frames / elapsed / 12.0);
  return 0;
}

int ThroughTheDaemon(ImageGeometry geometry, double seconds, bool realtime) {
  EmulatedTofSensor sensor;
  CachedPhases light;
  sensor.AddNode(Sensor(geometry, light, realtime));
  absl::StatusOr<std::unique_ptr<service::Pipeline>> pipeline =
      service::Pipeline::Create({.source_uri = Uri(geometry)});
  if (!pipeline.ok()) {
    std::fprintf(stderr, "%s\n", pipeline.status().ToString().c_str());
    return 1;
  }
  absl::StatusOr<std::unique_ptr<service::TransientServer>> server =
      service::TransientServer::Start(pipeline->get(), {.listen = "127.0.0.1:0", .version = "bench"});
  if (!server.ok()) {
    std::fprintf(stderr, "%s\n", server.status().ToString().c_str());
    return 1;
  }
  (*pipeline)->Start();
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);
  auto stub = v1::Transient::NewStub(grpc::CreateCustomChannel(
      absl::StrCat("127.0.0.1:", (*server)->port()), grpc::InsecureChannelCredentials(), args));
  grpc::ClientContext context;
  v1::StreamRequest request;
  request.add_products(v1::RANGE);
  auto reader = stub->StreamFrames(&context, request);
  v1::Frame frame;
  int64_t received = 0;
  absl::Time start;
  while (reader->Read(&frame)) {
    if (frame.images_size() == 0) continue;
    if (received++ == 2) start = absl::Now();  // after the first frames
    if (received > 2 && absl::Now() - start >= absl::Seconds(seconds)) break;
  }
  const double elapsed = absl::ToDoubleSeconds(absl::Now() - start);
  context.TryCancel();
  (void)reader->Finish();
  grpc::ClientContext stats_context;
  v1::Stats stats;
  (void)stub->GetStats(&stats_context, {}, &stats);
  std::string counters;
  for (const v1::SourceCounter& c : stats.source_counters()) {
    if (c.value() != 0) absl::StrAppend(&counters, counters.empty() ? "" : ", ", c.name(), " ", c.value());
  }
  std::printf("transientd, %dx%d, m = 3, RANGE, sensor %s: %.1f frames/s received, latency p50 "
              "%.1f ms, p99 %.1f ms, %llu cycles dropped (reconstruction behind); source: %s\n",
              geometry.width, geometry.height, realtime ? "at its pace" : "unpaced",
              (received - 3) / elapsed, stats.latency().p50_ms(), stats.latency().p99_ms(),
              static_cast<unsigned long long>(stats.cycles_dropped()), counters.c_str());
  (*pipeline)->Stop();
  (*server)->Shutdown(absl::Seconds(2));
  return 0;
}

}  // namespace
}  // namespace transient::v4l2

int main(int argc, char** argv) {
  using namespace transient::v4l2;
  {
    EmulatedTofSensor probe;  // umockdev says whether it is preloaded once a testbed exists
    if (!EmulatedTofSensor::Available()) {
      std::fprintf(stderr, "run under LD_PRELOAD=libumockdev-preload.so.0\n");
      return 2;
    }
  }
  const double seconds = argc > 1 ? std::atof(argv[1]) : 5.0;
  int failures = 0;
  failures += SourceAlone({640, 480}, seconds);
  failures += SourceAlone({160, 120}, seconds);
  failures += ThroughTheDaemon({160, 120}, seconds, /*realtime=*/true);
  failures += ThroughTheDaemon({640, 480}, seconds, /*realtime=*/true);
  return failures == 0 ? 0 : 1;
}
