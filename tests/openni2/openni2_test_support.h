// What the OpenNI2 tests share: transientd on the simulated camera as a child process, the
// daemon's frames over gRPC by sequence, and openni_only_reader's frames.
#pragma once

#include <signal.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/subprocess.h"
#include "transient/client/client.h"

namespace transient {

using testing::ChildProcess;
using testing::ProcessResult;
using testing::RunProcess;
using testing::ScratchDirectory;
using testing::WaitForPortFile;

inline constexpr char kScene[] = "sim:mirrors?width=80&height=60";
inline constexpr int kWidth = 80, kHeight = 60;

// transientd on the simulated camera, on a port of the system's choice (or the one given).
class Daemon {
 public:
  // `extra`: more options of transientd (a --token-file).
  explicit Daemon(const ScratchDirectory& scratch, int port = 0,
                  const std::vector<std::string>& extra = {})
      : port_file_(scratch.File(absl::StrCat("port", port))),
        process_(Arguments(scratch, port, port_file_, extra), scratch.File("transientd.log")) {
    port_ = WaitForPortFile(port_file_);
  }
  int port() const { return port_; }
  std::string address() const { return absl::StrCat("127.0.0.1:", port_); }
  std::string uri() const { return absl::StrCat("transient://", address()); }
  void Kill() { process_.Signal(SIGKILL), process_.Wait(); }

 private:
  static std::vector<std::string> Arguments(const ScratchDirectory& scratch, int port,
                                            const std::string& port_file,
                                            const std::vector<std::string>& extra) {
    std::vector<std::string> argv = {TRANSIENTD_BINARY, "--source",    kScene,
                                     "--listen",        absl::StrCat("127.0.0.1:", port),
                                     "--port-file",     port_file,
                                     "--data-dir",      scratch.File("data")};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return argv;
  }

  std::string port_file_;
  ChildProcess process_;
  int port_ = 0;
};

// The daemon's DEPTH in millimetres (its own UINT16_MM encoding) and AMPLITUDE of every frame
// it sends, by sequence, received on a thread for as long as the object lives.
class GrpcFrames {
 public:
  // With `amplitude`, also AMPLITUDE (Has() then waits for both).
  explicit GrpcFrames(const std::string& address, bool amplitude = true) : amplitude_(amplitude) {
    absl::StatusOr<client::Client> daemon = client::Client::Connect({.address = address});
    EXPECT_TRUE(daemon.ok()) << daemon.status();
    if (!daemon.ok()) return;
    info_ = daemon->GetInfo().value_or(v1::Info{});
    // Depth in the daemon's own millimetres (UINT16_MM is for lengths only), amplitude as float.
    v1::StreamRequest depth_request;
    depth_request.add_products(v1::DEPTH);
    depth_request.set_encoding(v1::UINT16_MM);
    depth_request.set_queue_frames(64);
    v1::StreamRequest amplitude_request;
    amplitude_request.add_products(v1::AMPLITUDE);
    amplitude_request.set_queue_frames(64);
    std::vector<v1::StreamRequest> requests = {depth_request};
    if (amplitude_) requests.push_back(amplitude_request);
    for (const v1::StreamRequest& request : requests) {
      streams_.push_back(daemon->StreamFrames(request));
      threads_.emplace_back([this, stream = streams_.back().get()] { Receive(stream); });
    }
  }
  void Receive(client::FrameStream* stream) {
    client::StreamFrame frame;
    while (stream->Next(&frame)) {
      if (frame.kind != client::StreamFrame::Kind::kImages) continue;
      std::lock_guard lock(mutex_);
      Frame& entry = frames_[frame.sequence];
      for (const client::DecodedImage& image : frame.images) {
        if (image.product == v1::DEPTH) {
          for (float metres : image.values) {
            entry.depth_mm.push_back(
                std::isnan(metres) ? 0 : static_cast<uint16_t>(std::lround(metres * 1000.0)));
          }
        } else {
          entry.amplitude = image.values;
        }
      }
    }
  }
  ~GrpcFrames() {
    for (const auto& stream : streams_) stream->Cancel();
    for (std::thread& thread : threads_) thread.join();
  }
  struct Frame {
    std::vector<uint16_t> depth_mm;
    std::vector<float> amplitude;
  };
  // Both images of the frame came.
  bool Has(uint64_t sequence) {
    std::lock_guard lock(mutex_);
    const auto found = frames_.find(sequence);
    return found != frames_.end() && !found->second.depth_mm.empty() &&
           (!amplitude_ || !found->second.amplitude.empty());
  }
  Frame Get(uint64_t sequence) {
    std::lock_guard lock(mutex_);
    return frames_.at(sequence);
  }
  size_t size() {
    std::lock_guard lock(mutex_);
    return frames_.size();
  }
  std::vector<Frame> All() {
    std::lock_guard lock(mutex_);
    std::vector<Frame> all;
    for (const auto& entry : frames_) {
      if (!entry.second.depth_mm.empty()) all.push_back(entry.second);
    }
    return all;
  }
  const v1::Info& info() const { return info_; }

 private:
  const bool amplitude_;
  v1::Info info_;
  std::vector<std::unique_ptr<client::FrameStream>> streams_;
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::map<uint64_t, Frame> frames_;
};

// One frame as openni_only_reader writes it.
struct ReaderFrame {
  int64_t index = 0;
  uint64_t timestamp_us = 0;
  int width = 0, height = 0, format = 0;
  std::vector<uint16_t> pixels;
};

inline std::vector<ReaderFrame> ReadFrames(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<ReaderFrame> frames;
  ReaderFrame frame;
  int32_t header[3];
  while (in.read(reinterpret_cast<char*>(&frame.index), sizeof frame.index) &&
         in.read(reinterpret_cast<char*>(&frame.timestamp_us), sizeof frame.timestamp_us) &&
         in.read(reinterpret_cast<char*>(header), sizeof header)) {
    frame.width = header[0], frame.height = header[1], frame.format = header[2];
    frame.pixels.resize(static_cast<size_t>(frame.width) * frame.height);
    if (!in.read(reinterpret_cast<char*>(frame.pixels.data()),
                 static_cast<std::streamsize>(frame.pixels.size() * sizeof(uint16_t)))) {
      break;
    }
    frames.push_back(frame);
  }
  return frames;
}

// Runs openni_only_reader with the build's private OpenNI2 runtime.
inline ProcessResult RunReader(const std::vector<std::string>& args) {
  // (Not silenced by TRANSIENT_OPENNI2_DISABLE, which the openni2: source sets in this process.)
  std::vector<std::string> argv = {"env", "-u", "TRANSIENT_OPENNI2_DISABLE",
                                   absl::StrCat("LD_LIBRARY_PATH=", OPENNI2_RUNTIME),
                                   OPENNI_ONLY_READER};
  argv.insert(argv.end(), args.begin(), args.end());
  return RunProcess(argv);
}


}  // namespace transient
