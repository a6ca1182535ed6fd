// What clients may make the daemon write, over gRPC: names in its data directory only, within
// its quota, and a write that fails (a full disk) ends the recording, not the stream.
#include <grpcpp/grpcpp.h>
#include <signal.h>
#include <sys/resource.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/formats/capture_file.h"
#include "transient/v1/transient.grpc.pb.h"

namespace transient::service {
namespace {

using ::testing::HasSubstr;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::DataDirAt;
using ::transient::service::testing::FirstFrame;
using ::transient::service::testing::kSmallSim;
using ::transient::service::testing::Request;
using ::transient::service::testing::WriteCapture;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;

grpc::Status StartRecording(Daemon& daemon, const std::string& name, v1::Recording* out) {
  grpc::ClientContext context;
  v1::StartRecordingRequest request;
  request.set_path(name);
  return daemon.Stub()->StartRecording(&context, request, out);
}

grpc::Status CalibrateInto(Daemon& daemon, const std::string& name) {
  grpc::ClientContext context;
  v1::CalibrateRequest request;
  request.set_takes(1);
  request.set_output_path(name);
  auto reader = daemon.Stub()->Calibrate(&context, request);
  v1::CalibrateProgress progress;
  while (reader->Read(&progress)) {
  }
  return reader->Finish();
}

v1::Recording WaitForTheRecordingToEnd(Daemon& daemon) {
  v1::Recording recording;
  EXPECT_TRUE(daemon.WaitFor(
      [&] {
        recording = daemon.Stats().recording();
        return !recording.active();
      },
      absl::Seconds(60)));
  return recording;
}

TEST(ConfinedWrites, NoRequestCreatesAFileOutsideTheDataDirectory) {
  ScratchDirectory outside;
  ScratchDirectory data;
  std::filesystem::create_directory_symlink(outside.path(), data.File("out"));
  std::filesystem::create_symlink(outside.File("linked.h5"), data.File("link.h5"));
  ASSERT_EQ(::mkfifo(data.File("fifo").c_str(), 0600), 0);
  std::ofstream(data.File("taken.h5")) << "x";
  PipelineOptions options{.source_uri = kSmallSim};
  options.data_dir = DataDirAt(data);
  Daemon daemon(options);

  const std::vector<std::pair<std::string, grpc::StatusCode>> cases = {
      {outside.File("absolute.h5"), grpc::StatusCode::INVALID_ARGUMENT},
      {"../escaped.h5", grpc::StatusCode::INVALID_ARGUMENT},
      {absl::StrCat("../", outside.path().filename().string(), "/relative.h5"),
       grpc::StatusCode::INVALID_ARGUMENT},
      {"out/through-link.h5", grpc::StatusCode::INVALID_ARGUMENT},
      {"link.h5", grpc::StatusCode::INVALID_ARGUMENT},
      {"fifo", grpc::StatusCode::INVALID_ARGUMENT},
      {"taken.h5", grpc::StatusCode::ALREADY_EXISTS},
      {"", grpc::StatusCode::INVALID_ARGUMENT},
  };
  for (const auto& [name, code] : cases) {
    v1::Recording out;
    const grpc::Status recording = StartRecording(daemon, name, &out);
    EXPECT_EQ(recording.error_code(), code) << name << ": " << recording.error_message();
    EXPECT_THAT(recording.error_message(), HasSubstr("path")) << name;
    if (name.empty()) continue;  // no file: the calibration is measured and applied
    const grpc::Status calibration = CalibrateInto(daemon, name);
    EXPECT_EQ(calibration.error_code(), code) << name << ": " << calibration.error_message();
    EXPECT_THAT(calibration.error_message(), HasSubstr("output_path")) << name;
  }
  EXPECT_TRUE(outside.Entries().empty());
  std::ifstream taken(data.File("taken.h5"));
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(taken), {}), "x");
  // The refusals did not disturb the stream, and a name inside is accepted.
  EXPECT_THAT(FirstFrame(daemon, Request({v1::RANGE})).status(), IsOk());
  std::filesystem::create_directory(data.File("day1"));
  v1::Recording out;
  const grpc::Status accepted = StartRecording(daemon, "day1/capture.h5", &out);
  EXPECT_TRUE(accepted.ok()) << accepted.error_message();
  EXPECT_EQ(out.path(), "day1/capture.h5");
  EXPECT_TRUE(std::filesystem::is_regular_file(data.File("day1/capture.h5")));
}

grpc::Status CalibrateFrom(Daemon& daemon, const std::string& source_uri) {
  grpc::ClientContext context;
  v1::CalibrateRequest request;
  request.set_takes(1);
  request.set_keep_current(true);
  request.set_source_uri(source_uri);
  auto reader = daemon.Stub()->Calibrate(&context, request);
  v1::CalibrateProgress progress;
  while (reader->Read(&progress)) {
  }
  return reader->Finish();
}

// Calibrate reads what a client names: only the stream's source, a simulator or a recording of
// the data directory; never a file elsewhere (a crafted HDF5 file can hang the library) or
// another device.
TEST(ConfinedWrites, CalibrateReadsOnlyRecordingsOfTheDataDirectory) {
  ScratchDirectory outside;
  ScratchDirectory data;
  // A recording of the calibration scene, inside and outside.
  for (const std::string& path : {data.File("dirac.h5"), outside.File("dirac.h5")}) {
    ASSERT_NO_FATAL_FAILURE(
        WriteCapture("sim:calibration?width=32&height=24&pace=fast&frames=2", path));
  }
  std::filesystem::create_symlink(outside.File("dirac.h5"), data.File("link.h5"));
  PipelineOptions options{.source_uri = kSmallSim};
  options.data_dir = DataDirAt(data);
  Daemon daemon(options);

  for (const std::string& refused :
       {absl::StrCat("replay:", outside.File("dirac.h5")), std::string("replay:../dirac.h5"),
        std::string("replay:link.h5"), std::string("v4l2:/dev/video0"), std::string("usb:kinect2"),
        std::string("openni2:")}) {
    const grpc::Status status = CalibrateFrom(daemon, refused);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << refused;
    EXPECT_THAT(status.error_message(), HasSubstr("source_uri")) << refused;
  }
  EXPECT_EQ(CalibrateFrom(daemon, "replay:missing.h5").error_code(), grpc::StatusCode::NOT_FOUND);
  const grpc::Status inside = CalibrateFrom(daemon, "replay:dirac.h5?pace=fast");
  EXPECT_TRUE(inside.ok()) << inside.error_message();
  const grpc::Status simulator = CalibrateFrom(daemon, "sim:calibration?width=32&height=24");
  EXPECT_TRUE(simulator.ok()) << simulator.error_message();
}

TEST(ConfinedWrites, TheFileQuotaRefusesNewFiles) {
  ScratchDirectory data;
  std::ofstream(data.File("old.h5")) << "x";
  PipelineOptions options{.source_uri = kSmallSim};
  options.data_dir = DataDirAt(data, {.max_files = 1});
  Daemon daemon(options);
  v1::Recording out;
  const grpc::Status recording = StartRecording(daemon, "new.h5", &out);
  EXPECT_EQ(recording.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(recording.error_message(), HasSubstr("holds 1 files, its quota is 1"));
  EXPECT_EQ(CalibrateInto(daemon, "new.h5").error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(data.Entries(), std::vector<std::string>{"old.h5"});
}

// A recording stops by itself before its file passes the byte quota: the file is whole and
// within it, the stream goes on, and a new recording is refused.
TEST(ConfinedWrites, TheByteQuotaStopsARecordingCleanly) {
  constexpr uint64_t kQuota = 3 << 20;
  ScratchDirectory data;
  PipelineOptions options{.source_uri = absl::StrCat(kSmallSim, "&pace=fast")};
  options.data_dir = DataDirAt(data, {.max_bytes = kQuota});
  Daemon daemon(options);
  v1::Recording out;
  const grpc::Status started = StartRecording(daemon, "capture.h5", &out);
  ASSERT_TRUE(started.ok()) << started.error_message();
  const v1::Recording ended = WaitForTheRecordingToEnd(daemon);
  EXPECT_THAT(ended.error(), HasSubstr("quota"));
  EXPECT_GT(ended.raw_frames(), 0u);
  EXPECT_EQ(ended.flushed_frames(), ended.raw_frames());
  EXPECT_LE(std::filesystem::file_size(data.File("capture.h5")), kQuota);
  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(data.File("capture.h5"));
  ASSERT_THAT(reader.status(), IsOk());
  EXPECT_EQ(static_cast<uint64_t>(reader->frames()), ended.raw_frames());
  RawFrame frame;
  EXPECT_THAT(reader->Read(reader->frames() - 1, &frame), IsOk());

  EXPECT_THAT(FirstFrame(daemon, Request({v1::RANGE})).status(), IsOk());
  const grpc::Status again = StartRecording(daemon, "again.h5", &out);
  EXPECT_EQ(again.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << again.error_message();
  EXPECT_THAT(again.error_message(), HasSubstr("of its quota of 3145728"));
}

// A limit on the file's size, here RLIMIT_FSIZE (writes past it fail with EFBIG): the recording
// stops before its file reaches it, with every frame whole, and the stream goes on. The limit is
// the test process's own and is lifted before anything else is written. (A disk that fills
// while frames are still held in memory: tests/service/python_client_test.py full_disk.)
TEST(ConfinedWrites, AFileSizeLimitEndsTheRecordingWithEveryFrameWhole) {
  // At the camera's pace (12.5 frames of 14 raw frames a second), a few seconds of frames.
  constexpr rlim_t kFileLimit = 2 << 20;
  ScratchDirectory data;
  PipelineOptions options{.source_uri = kSmallSim};
  options.data_dir = DataDirAt(data);
  Daemon daemon(options);
  ASSERT_THAT(FirstFrame(daemon, Request({v1::RANGE})).status(), IsOk());

  rlimit before;
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &before), 0);
  const sighandler_t disposition = ::signal(SIGXFSZ, SIG_IGN);
  rlimit limited = before;
  limited.rlim_cur = kFileLimit;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limited), 0);
  v1::Recording out;
  const grpc::Status started = StartRecording(daemon, "capture.h5", &out);
  const v1::Recording ended = started.ok() ? WaitForTheRecordingToEnd(daemon) : v1::Recording();
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &before), 0);
  ::signal(SIGXFSZ, disposition);
  ASSERT_TRUE(started.ok()) << started.error_message();

  EXPECT_THAT(ended.error(), HasSubstr("RLIMIT_FSIZE = 2097152"));
  EXPECT_GT(ended.raw_frames(), 0u);
  EXPECT_EQ(ended.flushed_frames(), ended.raw_frames());
  EXPECT_LE(std::filesystem::file_size(data.File("capture.h5")), kFileLimit);
  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(data.File("capture.h5"));
  ASSERT_THAT(reader.status(), IsOk());
  EXPECT_EQ(static_cast<uint64_t>(reader->frames()), ended.raw_frames());
  RawFrame frame;
  for (int64_t i = 0; i < reader->frames(); ++i) {
    ASSERT_THAT(reader->Read(i, &frame), IsOk()) << "frame " << i;
  }
  // The stream goes on, and with room again a new recording starts.
  EXPECT_THAT(FirstFrame(daemon, Request({v1::RANGE})).status(), IsOk());
  const grpc::Status again = StartRecording(daemon, "again.h5", &out);
  EXPECT_TRUE(again.ok()) << again.error_message();
}

}  // namespace
}  // namespace transient::service
