// record / sim, calibrate, moments and info: the measurement half of the `transient` tool.
#include "tools/transient/capture_commands.h"

#include <hdf5.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "transient/formats/moment_file.h"
#include "transient/formats/moment_file_writer.h"
#include "tools/transient/capture_moments.h"
#include "transient/formats/atomic_output.h"
#include "transient/drivers/calibration_capture.h"
#include "transient/formats/calibration_file.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/file_format.h"
#include "transient/drivers/capture_source.h"
#include "transient/formats/h5.h"
#include "transient/drivers/simulator.h"
#include "transient/reconstruct/calibration.h"
#include "transient/reconstruct/cycle_assembler.h"
#include "transient/reconstruct/demodulation.h"
#include "transient/reconstruct/frame_pipeline.h"
#include "transient/reconstruct/smoothing.h"

namespace transient::tools {
namespace {

// How long a recording waits for a frame before it calls the source lost. Generous: a real
// camera delivers a frame every few milliseconds, and replay or the simulator at once.
constexpr absl::Duration kFrameTimeout = absl::Seconds(10);

absl::Status Prefixed(absl::string_view prefix, const absl::Status& status) {
  return absl::Status(status.code(), absl::StrCat(prefix, ": ", status.message()));
}

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

std::string Frequency(double hz) {
  if (hz >= 1e6) return absl::StrFormat("%g MHz", hz / 1e6);
  if (hz >= 1e3) return absl::StrFormat("%g kHz", hz / 1e3);
  return absl::StrFormat("%g Hz", hz);
}

}  // namespace

absl::Status RecordArgs::Validate() const {
  if (source_uri.empty()) return absl::InvalidArgumentError("--source: expected a source URI");
  if (output_path.empty()) return absl::InvalidArgumentError("--out: expected a file name");
  if (frames < 0) {
    return absl::InvalidArgumentError(absl::StrCat("--frames = ", frames, ": expected >= 1"));
  }
  if (!(seconds >= 0.0) || !std::isfinite(seconds)) {
    return absl::InvalidArgumentError(absl::StrCat("--seconds = ", seconds, ": expected > 0"));
  }
  if ((frames > 0) == (seconds > 0.0)) {
    return absl::InvalidArgumentError("give exactly one of --frames N and --seconds S");
  }
  if (deflate_level < 0 || deflate_level > 9) {
    return absl::InvalidArgumentError(
        absl::StrCat("--deflate = ", deflate_level, ": expected 0..9"));
  }
  return absl::OkStatus();
}

absl::StatusOr<RecordSummary> RunRecord(const RecordArgs& args, const CommandHooks& hooks) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
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
    return Prefixed(absl::StrCat("recording stopped after ", summary.raw_frames, " raw frames (",
                                 args.output_path, " keeps them)"),
                    failure);
  }
  return summary;
}

std::string FormatRecordSummary(const RecordSummary& s) {
  return absl::StrFormat(
      "%s: %d raw frames = %d transient frames from %s in %.1f s%s%s\n  schedule: %s",
      s.output_path, s.raw_frames, s.cycles, s.source_uri, s.seconds,
      s.ground_truth ? ", with ground truth" : "", s.interrupted ? " (interrupted)" : "",
      s.schedule);
}

absl::Status CalibrateArgs::Validate() const {
  if (source_uri.empty()) return absl::InvalidArgumentError("--source: expected a source URI");
  if (output_path.empty()) return absl::InvalidArgumentError("--out: expected a file name");
  if (takes < 1 || takes > 256) {
    return absl::InvalidArgumentError(absl::StrCat("--takes = ", takes, ": expected 1..256"));
  }
  return absl::OkStatus();
}

absl::StatusOr<CalibrateSummary> RunCalibrate(const CalibrateArgs& args,
                                              const CommandHooks& hooks) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  // The output path is checked before the measurement, not written until it is complete.
  if (absl::Status status = AtomicOutput::Prepare(args.output_path).status(); !status.ok()) {
    return status;
  }
  absl::StatusOr<std::unique_ptr<CaptureSource>> opened = OpenSource(args.source_uri);
  if (!opened.ok()) return opened.status();
  CaptureSource& source = **opened;
  const AcquisitionSchedule& schedule = source.schedule();
  const ImageGeometry geometry = source.camera().geometry;
  absl::StatusOr<CalibrationCapture> measured = CaptureCalibration(
      source, args.takes,
      {.on_take = [&](int done, int total) { hooks.Progress(done, total); },
       .cancel = hooks.cancel});
  if (absl::IsCancelled(measured.status())) {
    return absl::CancelledError("interrupted; no calibration written");
  }
  if (!measured.ok()) return measured.status();
  const CalibrationTable& table = measured->table;
  if (hooks.cancelled()) return absl::CancelledError("interrupted; no calibration written");
  if (absl::Status status = WriteCalibrationFile(args.output_path, table); !status.ok()) {
    return status;
  }

  CalibrateSummary summary{.output_path = args.output_path,
                           .takes_averaged = table.takes_averaged,
                           .frames_rejected = measured->frames_rejected,
                           .usable_pixels = measured->usable_pixels,
                           .pixels = geometry.pixel_count(),
                           .schedule = schedule.Describe()};
  return summary;
}

std::string FormatCalibrateSummary(const CalibrateSummary& s) {
  return absl::StrFormat(
      "%s: calibration from %d takes (%d outlier raw frames left out), %d of %d pixels "
      "usable\n  schedule: %s",
      s.output_path, s.takes_averaged, s.frames_rejected, s.usable_pixels, s.pixels, s.schedule);
}

absl::Status MomentsArgs::Validate() const {
  if (capture_path.empty()) return absl::InvalidArgumentError("expected a capture file");
  if (output_path.empty()) return absl::InvalidArgumentError("--out: expected a file name");
  if (uncalibrated && !calibration_path.empty()) {
    return absl::InvalidArgumentError("--uncalibrated and --calibration exclude each other");
  }
  if (absl::Status status = ValidateSmoothingSigma(smoothing_sigma_px); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("--smooth: ", status.message()));
  }
  return absl::OkStatus();
}

absl::StatusOr<MomentsSummary> RunMoments(const MomentsArgs& args, const CommandHooks& hooks) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  absl::StatusOr<CaptureReader> capture = CaptureReader::Open(args.capture_path);
  if (!capture.ok()) return capture.status();
  const AcquisitionSchedule& schedule = capture->schedule();

  MomentsSummary summary{.output_path = args.output_path};
  absl::StatusOr<FramePipeline> pipeline =
      CapturePipeline(*capture,
                      {.calibration_path = args.calibration_path,
                       .uncalibrated = args.uncalibrated,
                       .smoothing_sigma_px = args.smoothing_sigma_px,
                       .video = args.video},
                      &summary.calibration);
  if (!pipeline.ok()) return pipeline.status();

  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(args.output_path);
  if (!output.ok()) return output.status();
  absl::StatusOr<MomentFileWriter> writer = MomentFileWriter::Create(
      output->temporary_path(),
      MomentFileHeader{.geometry = capture->camera().geometry, .order = schedule.order(),
                       .base_frequency_hz = schedule.options().base_frequency_hz,
                       .zeroth = schedule.options().zeroth, .source = args.capture_path,
                       .calibration = summary.calibration,
                       .smoothing_sigma_px = args.smoothing_sigma_px});
  if (!writer.ok()) return WithFinalPath(writer.status(), args.output_path);

  CaptureMeasureCounts counts;
  absl::Status measured = MeasureCapture(
      *capture, *pipeline, hooks, &counts,
      [&](const MomentImage& moments, double cycle_start_s) {
        return WithFinalPath(writer->Append(moments, cycle_start_s), args.output_path);
      });
  if (absl::IsCancelled(measured)) return absl::CancelledError("interrupted; no moment file written");
  if (!measured.ok()) return measured;
  summary.frames_written = counts.frames;
  summary.cycles_dropped = counts.cycles_dropped;
  summary.raw_frames_dropped = counts.raw_frames_dropped;
  summary.raw_frames_rejected = counts.raw_frames_rejected;
  summary.filled_pixels = counts.filled_pixels;
  summary.saturated_pixels = counts.saturated_pixels;
  summary.problems = std::move(counts.problems);
  if (absl::Status status = writer->Close(); !status.ok()) {
    return WithFinalPath(status, args.output_path);
  }
  if (hooks.cancelled()) return absl::CancelledError("interrupted; no moment file written");
  if (absl::Status status = output->Commit(); !status.ok()) return status;
  return summary;
}

std::string FormatMomentsSummary(const MomentsSummary& s) {
  std::string text = absl::StrFormat(
      "%s: %d transient frames (calibration: %s); %d incomplete or refused frames dropped, %d "
      "outlier raw frames rejected, %d pixels filled from the previous frame, %d saturated",
      s.output_path, s.frames_written, s.calibration, s.cycles_dropped, s.raw_frames_rejected,
      s.filled_pixels, s.saturated_pixels);
  for (const std::string& p : s.problems) absl::StrAppend(&text, "\n  dropped: ", p);
  return text;
}

namespace {

std::string DescribeCamera(const CameraInfo& camera) {
  return absl::StrFormat(
      "camera: %dx%d px, fx %.2f fy %.2f cx %.2f cy %.2f px, %s, frame period %.3f ms",
      camera.geometry.width, camera.geometry.height, camera.intrinsics.fx, camera.intrinsics.fy,
      camera.intrinsics.cx, camera.intrinsics.cy,
      camera.model.empty() ? "unnamed" : camera.model, camera.frame_period_s * 1e3);
}

absl::StatusOr<std::string> DescribeCapture(const std::string& path) {
  absl::StatusOr<CaptureReader> capture = CaptureReader::Open(path);
  if (!capture.ok()) return capture.status();
  const AcquisitionSchedule& schedule = capture->schedule();
  const int64_t frames = capture->frames();
  std::string text = absl::StrCat(path, ": capture (transient-capture 1)\n  source: ",
                                  capture->source_uri(), "\n  ", DescribeCamera(capture->camera()),
                                  "\n  schedule: ", schedule.Describe());
  const int64_t per_cycle = schedule.raw_frames_per_frame();
  absl::StrAppend(&text, absl::StrFormat(
                             "\n  frames: %d raw (%s, saturation at %g) = %d complete transient "
                             "frames%s",
                             frames,
                             capture->pixel_type() == CapturePixelType::kUint16 ? "uint16"
                                                                                 : "float32",
                             capture->saturation_level(), frames / per_cycle,
                             frames % per_cycle == 0
                                 ? ""
                                 : absl::StrCat(" + ", frames % per_cycle, " raw frames")));
  if (frames > 0) {
    const double first = capture->config(0).timestamp_s;
    const double last = capture->config(frames - 1).timestamp_s;
    absl::StrAppend(&text, absl::StrFormat("\n  time: %.3f s to %.3f s (%.3f s)", first, last,
                                           last - first));
  }
  if (capture->ground_truth().has_value()) {
    const GroundTruth& truth = *capture->ground_truth();
    float near = INFINITY, far = -INFINITY;
    for (float r : truth.first_range_m) {
      if (std::isfinite(r)) {
        near = std::min(near, r);
        far = std::max(far, r);
      }
    }
    absl::StrAppend(&text, absl::StrFormat(
                               "\n  ground truth: up to %d returns per pixel, first return at "
                               "%.3f..%.3f m",
                               truth.max_returns, near, far));
  } else {
    absl::StrAppend(&text, "\n  ground truth: none");
  }
  absl::StrAppend(&text, "\n  calibration: ",
                  capture->calibration().has_value() ? "embedded" : "none");
  return text;
}

absl::StatusOr<std::string> DescribeCalibration(const std::string& path) {
  absl::StatusOr<CalibrationTable> table = ReadCalibrationFile(path);
  if (!table.ok()) return table.status();
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(table->schedule);
  const int64_t pixels = table->geometry.pixel_count();
  const int64_t usable = std::count(table->valid.begin(), table->valid.end(), uint8_t{1});
  std::string text = absl::StrFormat(
      "%s: calibration (transient-calibration 1)\n  %dx%d px, %s\n  takes averaged: %d\n  "
      "usable pixels: %d of %d",
      path, table->geometry.width, table->geometry.height,
      schedule.ok() ? schedule->Describe() : "unknown schedule", table->takes_averaged, usable,
      pixels);
  // The median factor per harmonic: its modulus is the relative gain, its angle the phase
  // offset the calibration removes.
  for (int j = 1; j <= table->order; ++j) {
    std::vector<double> modulus, angle;
    for (int64_t p = 0; p < pixels; ++p) {
      if (!table->valid[p]) continue;
      const std::complex<double> k(table->real[j * pixels + p], table->imag[j * pixels + p]);
      modulus.push_back(std::abs(k));
      angle.push_back(std::arg(k));
    }
    if (modulus.empty()) continue;
    auto median = [](std::vector<double>& v) {
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    absl::StrAppend(&text, absl::StrFormat("\n  k_%d: median |k| %.4g, median arg %.4f rad", j,
                                           median(modulus), median(angle)));
  }
  return text;
}

absl::StatusOr<std::string> DescribeMoments(const std::string& path) {
  absl::StatusOr<MomentFile> file = MomentFile::Open(path);
  if (!file.ok()) return file.status();
  std::string zeroth = "not stated (measured assumed)";
  if (file->zeroth_hint().has_value()) {
    zeroth = *file->zeroth_hint() == ZerothMoment::kEstimate ? "estimated" : "measured";
  }
  return absl::StrFormat(
      "%s: moments (transient-moments 1)\n  %d frames of %dx%d px, m = %d, f = %s\n  c_0: %s\n  "
      "valid mask: %s, flags: %s",
      path, file->frames(), file->geometry().width, file->geometry().height, file->order(),
      Frequency(file->base_frequency_hz()), zeroth, file->has_valid_mask() ? "yes" : "no",
      file->has_flags() ? "yes" : "no");
}

absl::StatusOr<std::string> DescribeReconstruction(const std::string& path) {
  absl::StatusOr<h5::Id> opened = h5::OpenFileForReading(path, "an HDF5 reconstruction file");
  if (!opened.ok()) return opened.status();
  const hid_t file = opened->get();
  std::string text = absl::StrCat(path, ": reconstruction (transient-reconstruction 1)");
  for (const char* attribute : {"method", "zeroth", "source"}) {
    absl::StatusOr<std::string> value = h5::ReadStringAttribute(file, attribute, path);
    if (value.ok()) absl::StrAppend(&text, "\n  ", attribute, ": ", *value);
  }
  for (const char* attribute : {"base_frequency_hz", "order", "bins", "bias_epsilon"}) {
    absl::StatusOr<double> value = h5::ReadNumericAttribute(file, attribute, path);
    if (value.ok()) absl::StrAppend(&text, "\n  ", attribute, ": ", *value);
  }
  for (const char* dataset :
       {"/range_m", "/c0", "/flags", "/density", "/cumulative", "/pisarenko/phase",
        "/pisarenko/range_m", "/bounds/lower"}) {
    if (!h5::LinkExists(file, dataset)) continue;
    h5::Id id = h5::Dataset(H5Dopen2(file, dataset, H5P_DEFAULT));
    if (!id.valid()) continue;
    h5::Id space = h5::Dataspace(H5Dget_space(id.get()));
    absl::StrAppend(&text, "\n  ", dataset, " ", h5::DimensionsToString(h5::Dimensions(space.get())));
  }
  return text;
}

}  // namespace

absl::StatusOr<std::string> DescribeFile(const std::string& path) {
  absl::StatusOr<FileIdentity> file = IdentifyFile(path);
  if (!file.ok()) return file.status();
  if (!file->named.has_value()) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": format '", file->text,
        "' is none of transient-capture, transient-calibration, transient-moments, "
        "transient-reconstruction"));
  }
  // By name: the reader of that format says what is wrong with another version.
  switch (*file->named) {
    case FileFormat::kCapture:
      return DescribeCapture(path);
    case FileFormat::kCalibration:
      return DescribeCalibration(path);
    case FileFormat::kMoments:
      return DescribeMoments(path);
    case FileFormat::kReconstruction:
      return DescribeReconstruction(path);
  }
  return absl::InternalError(absl::StrCat(path, ": unknown file format"));
}

}  // namespace transient::tools
