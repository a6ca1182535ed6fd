// The replay source: recorded frames from a capture file, paced like the recording or as fast
// as they are taken.
#include "transient/drivers/replay_source.h"

#include <algorithm>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "source_uri.h"
#include "transient/drivers/source_registry.h"

namespace transient {

absl::StatusOr<ReplayOptions> ParseReplayUri(absl::string_view uri, std::string* path) {
  absl::StatusOr<internal::SourceUri> parsed = internal::ParseSourceUri(uri);
  if (!parsed.ok()) return parsed.status();
  if (parsed->scheme != "replay") {
    return absl::InvalidArgumentError(
        absl::StrCat(uri, ": expected replay:<file.h5>?loop=0|1&pace=realtime|fast&start=<cycle>"));
  }
  *path = parsed->target;
  if (path->empty()) return absl::InvalidArgumentError(absl::StrCat(uri, ": no file path"));
  ReplayOptions options;
  for (const auto& [key, value] : parsed->keys) {
    const auto bad_value = [&, &key = key, &value = value](absl::string_view expected) {
      return internal::BadKeyValue(uri, key, value, expected);
    };
    if (key == "loop") {
      if (value != "0" && value != "1") return bad_value("0 or 1");
      options.loop = value == "1";
    } else if (key == "pace") {
      if (value == "realtime") {
        options.pace = ReplayPace::kRealtime;
      } else if (value == "fast") {
        options.pace = ReplayPace::kFast;
      } else {
        return bad_value("realtime or fast");
      }
    } else if (key == "start") {
      if (!absl::SimpleAtoi(value, &options.start_cycle) || options.start_cycle < 0) {
        return bad_value("a cycle number >= 0");
      }
    } else {
      return absl::InvalidArgumentError(
          absl::StrCat(uri, ": unknown key '", key, "'; expected loop, pace, start"));
    }
  }
  return options;
}

absl::StatusOr<std::unique_ptr<ReplaySource>> ReplaySource::Open(absl::string_view uri) {
  std::string path;
  absl::StatusOr<ReplayOptions> options = ParseReplayUri(uri, &path);
  if (!options.ok()) return options.status();
  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(path);
  if (!reader.ok()) return reader.status();
  std::unique_ptr<ReplaySource> source(
      new ReplaySource(std::string(uri), *std::move(reader), *options));
  if (options->start_cycle >= 0) {
    if (absl::Status status = source->Seek(options->start_cycle); !status.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(uri, ": start: ", status.message()));
    }
  }
  return source;
}

SourceCapabilities ReplaySource::capabilities() const {
  SourceCapabilities capabilities;
  capabilities.replay = true;
  capabilities.waits_for_consumer = options_.pace == ReplayPace::kFast;
  bool first = true;
  for (const ExposureConfig& exposure : schedule().exposures()) {
    if (first || exposure.frequency_hz < capabilities.min_frequency_hz) {
      capabilities.min_frequency_hz = exposure.frequency_hz;
    }
    capabilities.max_frequency_hz = std::max(capabilities.max_frequency_hz, exposure.frequency_hz);
    capabilities.unmodulated_exposures |= exposure.frequency_hz == 0.0;
    first = false;
  }
  const ScheduleOptions& options = schedule().options();
  capabilities.arbitrary_phase_shift = options.sampling != SamplingScheme::kFourBucket;
  capabilities.min_exposure_s = capabilities.max_exposure_s = options.exposure_s;
  return capabilities;
}

absl::Status ReplaySource::Start() {
  if (started_) return absl::FailedPreconditionError(absl::StrCat(uri_, ": already started"));
  started_ = true;
  anchored_ = false;
  return absl::OkStatus();
}

absl::Status ReplaySource::Stop() {
  if (!started_) return absl::FailedPreconditionError(absl::StrCat(uri_, ": not started"));
  started_ = false;
  return absl::OkStatus();
}

absl::Status ReplaySource::Seek(int64_t cycle) {
  for (int64_t i = 0; i < reader_.frames(); ++i) {
    if (reader_.config(i).cycle == cycle) {
      position_ = i;
      anchored_ = false;
      return absl::OkStatus();
    }
  }
  const int64_t frames = reader_.frames();
  return absl::InvalidArgumentError(
      frames == 0 ? absl::StrCat("cycle ", cycle, ": the recording has no frames")
                  : absl::StrCat("cycle ", cycle, ": no recorded frame has it (the recording has "
                                 "cycles ", reader_.config(0).cycle, "..",
                                 reader_.config(frames - 1).cycle, ")"));
}

absl::Status ReplaySource::Next(absl::Duration timeout, RawFrame* frame) {
  if (!started_) return absl::FailedPreconditionError(absl::StrCat(uri_, ": not started"));
  const int64_t frames = reader_.frames();
  if (position_ >= frames) {
    if (!options_.loop || frames == 0) {
      return absl::OutOfRangeError(absl::StrCat(uri_, ": end of the recording (", frames,
                                                " frames)"));
    }
    // The next pass continues the numbering where this one ended, one frame period on.
    const ExposureConfig& first = reader_.config(0);
    const ExposureConfig& last = reader_.config(frames - 1);
    double period = camera().frame_period_s;
    if (period <= 0.0 && frames > 1) {
      period = (last.timestamp_s - first.timestamp_s) / static_cast<double>(frames - 1);
    }
    cycle_offset_ += std::max<int64_t>(last.cycle - first.cycle + 1, 1);
    sequence_offset_ += last.sequence >= first.sequence ? last.sequence - first.sequence + 1
                                                        : static_cast<uint64_t>(frames);
    timestamp_offset_ += std::max(last.timestamp_s - first.timestamp_s + period, 0.0);
    position_ = 0;
  }
  const double timestamp_s = reader_.config(position_).timestamp_s + timestamp_offset_;
  if (options_.pace == ReplayPace::kRealtime) {
    const absl::Time now = absl::Now();
    if (!anchored_) {
      anchored_ = true;
      anchor_time_ = now;
      anchor_timestamp_s_ = timestamp_s;
    }
    const absl::Time due = anchor_time_ + absl::Seconds(timestamp_s - anchor_timestamp_s_);
    if (due - now > timeout) {
      absl::SleepFor(timeout);
      return absl::DeadlineExceededError(
          absl::StrCat(uri_, ": next frame due in ", absl::FormatDuration(due - now)));
    }
    if (due > now) absl::SleepFor(due - now);
  }
  const int64_t index = position_++;
  if (absl::Status status = reader_.Read(index, frame); !status.ok()) return status;
  frame->config.cycle += cycle_offset_;
  frame->config.sequence += sequence_offset_;
  frame->config.timestamp_s = timestamp_s;
  return absl::OkStatus();
}

const CalibrationTable* ReplaySource::embedded_calibration(std::string* origin) const {
  if (!reader_.calibration().has_value()) return nullptr;
  if (origin != nullptr) *origin = absl::StrCat(reader_.path(), ": /calibration");
  return &*reader_.calibration();
}

absl::StatusOr<GroundTruth> ReplaySource::GroundTruthAt(double timestamp_s) const {
  (void)timestamp_s;
  if (!reader_.ground_truth().has_value()) {
    return absl::UnimplementedError(absl::StrCat(uri_, ": the recording has no ground truth"));
  }
  return *reader_.ground_truth();
}

namespace internal {
namespace {

constexpr SourceKey kReplayKeys[] = {
    {"loop", "0", "", "1: start over at the end, cycles and timestamps still increasing"},
    {"pace", "realtime", "",
     "realtime (as recorded) or fast (as fast as taken, never dropping a frame)"},
    {"start", "first", "", "the recorded capture cycle to begin with"},
};

absl::StatusOr<std::unique_ptr<CaptureSource>> OpenReplaySource(absl::string_view uri) {
  absl::StatusOr<std::unique_ptr<ReplaySource>> source = ReplaySource::Open(uri);
  if (!source.ok()) return source.status();
  return std::unique_ptr<CaptureSource>(*std::move(source));
}

}  // namespace

extern const SourceScheme kReplayScheme;
const SourceScheme kReplayScheme = {
    .name = "replay",
    .syntax = "replay:<capture.h5>?loop=0|1&pace=realtime|fast&start=<cycle>",
    .description = "a recorded capture file (transient record, sim, or the daemon's recording)",
    .keys = kReplayKeys,
    .capabilities = {.ground_truth = true,
                     .seek = true,
                     .pace = true,
                     .embedded_calibration = true},
    .open = OpenReplaySource,
};

}  // namespace internal
}  // namespace transient
