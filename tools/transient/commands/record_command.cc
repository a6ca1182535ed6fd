// transient record / sim: a source's frames appended to a new capture file, flushed as they come.
#include "tools/transient/commands/record_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tools/transient/common/run_length.h"
#include "transient/drivers/capture_source.h"
#include "transient/formats/capture_file.h"
#include "transient/reconstruct/status_context.h"

namespace transient::tools {
namespace {

// How long a recording waits for a frame before it calls the source lost. Generous: a real
// camera delivers a frame every few milliseconds, and replay or the simulator at once.
constexpr absl::Duration kFrameTimeout = absl::Seconds(10);

// uint16 storage is exact for ADC counts; anything else (float simulation, NaN) needs float32.
bool FitsUint16(const RawFrame& frame) {
  if (!(frame.saturation_level <= 65535.0f) && !std::isinf(frame.saturation_level)) return false;
  if (std::isfinite(frame.saturation_level) && frame.saturation_level != std::floor(frame.saturation_level)) {
    return false;
  }
  return std::all_of(frame.pixels.begin(), frame.pixels.end(), [](float v) {
    return v >= 0.0f && v <= 65535.0f && v == std::floor(v);
  });
}

}  // namespace

absl::Status RecordArgs::Validate() const {
  if (source_uri.empty() == nats.servers.empty()) {
    return absl::InvalidArgumentError(
        "--source or --nats: expected one of them (a source URI, or NATS servers)");
  }
  if (output_path.empty()) return absl::InvalidArgumentError("--out: expected a file name");
  if (absl::Status status = ValidateRunLength(frames, seconds); !status.ok()) return status;
  if (deflate_level < 0 || deflate_level > 9) {
    return absl::InvalidArgumentError(
        absl::StrCat("--deflate = ", deflate_level, ": expected 0..9"));
  }
  return absl::OkStatus();
}

absl::StatusOr<RecordSummary> RunRecord(const RecordArgs& args, const CommandHooks& hooks) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  if (!args.nats.servers.empty()) return RunRecordNats(args, hooks);
  if (std::filesystem::exists(args.output_path)) {
    return absl::AlreadyExistsError(absl::StrCat(
        args.output_path, ": exists; a recording never replaces a file (remove it first)"));
  }
  absl::StatusOr<std::unique_ptr<CaptureSource>> opened = OpenSource(args.source_uri);
  if (!opened.ok()) return opened.status();
  CaptureSource& source = **opened;
  const AcquisitionSchedule& schedule = source.schedule();
  const int64_t per_cycle = schedule.raw_frames_per_frame();

  RecordSummary summary{.output_path = args.output_path, .source_uri = args.source_uri,
                        .schedule = schedule.Describe()};
  if (absl::Status status = source.Start(); !status.ok()) return status;
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  std::optional<CaptureWriter> writer;
  RawFrame frame;
  absl::Status failure;
  while (!hooks.cancelled()) {
    if (args.frames > 0 && summary.raw_frames >= args.frames * per_cycle) break;
    if (args.seconds > 0 && elapsed() >= args.seconds && summary.raw_frames % per_cycle == 0) break;
    absl::Status next = source.Next(kFrameTimeout, &frame);
    if (absl::IsOutOfRange(next)) break;  // the end of a recording ends this one too
    if (absl::IsDeadlineExceeded(next)) {
      failure = absl::UnavailableError(absl::StrCat(args.source_uri, ": no frame within ",
                                                    absl::FormatDuration(kFrameTimeout)));
      break;
    }
    if (!next.ok()) {
      failure = next;
      break;
    }
    if (!writer.has_value()) {
      CaptureWriterOptions options{
          .pixel_type = FitsUint16(frame) ? CapturePixelType::kUint16 : CapturePixelType::kFloat32,
          .deflate_level = args.deflate_level,
          .source_uri = args.source_uri,
          .saturation_level = frame.saturation_level};
      absl::StatusOr<CaptureWriter> created =
          CaptureWriter::Create(args.output_path, source.camera(), schedule, options);
      if (!created.ok()) return created.status();
      writer.emplace(*std::move(created));
      // The calibration the source carries (a camera's factory tables, a replay's embedded
      // one) goes with its frames, so that the recording replays like the live camera.
      if (const CalibrationTable* carried = source.embedded_calibration(nullptr)) {
        if (absl::Status status = writer->EmbedCalibration(*carried); !status.ok()) return status;
        summary.embedded_calibration = true;
      }
      if (args.ground_truth) {
        absl::StatusOr<GroundTruth> truth = source.GroundTruthAt(frame.config.timestamp_s);
        if (truth.ok()) {
          if (absl::Status status = writer->SetGroundTruth(*truth); !status.ok()) return status;
          summary.ground_truth = true;
        }
      }
    }
    if (absl::Status status = writer->Append(frame); !status.ok()) {
      failure = status;
      break;
    }
    ++summary.raw_frames;
    if (args.frames > 0) {
      hooks.Progress(summary.raw_frames, args.frames * per_cycle);
    } else {
      hooks.Progress(std::min<int64_t>(static_cast<int64_t>(elapsed() * 10), args.seconds * 10),
               static_cast<int64_t>(args.seconds * 10));
    }
  }
  summary.interrupted = hooks.cancelled();
  (void)source.Stop();
  summary.seconds = elapsed();
  summary.cycles = summary.raw_frames / per_cycle;
  if (!writer.has_value()) {
    if (!failure.ok()) return failure;
    return absl::FailedPreconditionError(
        absl::StrCat(args.source_uri, ": the source delivered no frame; nothing recorded"));
  }
  if (absl::Status status = writer->Close(); !status.ok()) return status;
  if (!failure.ok()) {
    return WithContext(absl::StrCat("recording stopped after ", summary.raw_frames, " raw frames (",
                                 args.output_path, " keeps them)"),
                    failure);
  }
  return summary;
}

std::string FormatRecordSummary(const RecordSummary& s) {
  if (s.moments) {
    return absl::StrFormat("%s: %d frames of moments from %s in %.1f s%s\n  %s", s.output_path,
                           s.cycles, s.source_uri, s.seconds, s.interrupted ? " (interrupted)" : "",
                           s.schedule);
  }
  return absl::StrFormat(
      "%s: %d raw frames = %d transient frames from %s in %.1f s%s%s%s\n  schedule: %s",
      s.output_path, s.raw_frames, s.cycles, s.source_uri, s.seconds,
      s.ground_truth ? ", with ground truth" : "",
      s.embedded_calibration ? ", with the source's calibration" : "",
      s.interrupted ? " (interrupted)" : "", s.schedule);
}

}  // namespace transient::tools
