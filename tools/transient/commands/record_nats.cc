// `transient record --nats`: a camera's MOMENT_STATE frames from NATS JetStream into a moment
// file (record_command.h).
#include <filesystem>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "tools/transient/commands/record_command.h"
#include "transient/client/nats_stream.h"
#include "transient/client/nats_worker.h"
#include "transient/formats/moment_file_writer.h"

namespace transient::tools {

absl::StatusOr<RecordSummary> RunRecordNats(const RecordArgs& args, const CommandHooks& hooks) {
  if (std::filesystem::exists(args.output_path)) {
    return absl::AlreadyExistsError(absl::StrCat(
        args.output_path, ": exists; a recording never replaces a file (remove it first)"));
  }
  client::NatsStreamOptions options;
  options.connect = args.nats;
  options.camera = args.nats_camera;
  options.product = v1::MOMENT_STATE;
  if (absl::Status status = client::ParseNatsStart("--nats-start", args.nats_start, &options);
      !status.ok()) {
    return status;
  }
  options.cancel = hooks.cancel;
  const absl::Time opened = absl::Now();
  if (args.seconds > 0.0) options.deadline = opened + absl::Seconds(args.seconds);
  absl::StatusOr<std::unique_ptr<client::NatsFrameStream>> stream =
      client::NatsFrameStream::Open(options);
  if (!stream.ok()) return stream.status();

  const std::string subject = wire::NatsSubject(args.nats_camera, v1::MOMENT_STATE);
  RecordSummary summary{.output_path = args.output_path,
                        .source_uri = absl::StrCat("nats:", args.nats.servers, " ", subject),
                        .moments = true};
  std::optional<MomentFileWriter> writer;
  client::StreamFrame frame;
  absl::Status failure;
  while (!hooks.cancelled() && (args.frames == 0 || summary.cycles < args.frames) &&
         (*stream)->Next(&frame)) {
    if (frame.kind != client::StreamFrame::Kind::kImages) continue;  // counted by the stream
    absl::StatusOr<SolvedImage> state = client::SolvedFromMomentState(frame.images);
    if (!state.ok()) {
      failure = state.status();
      break;
    }
    MomentImage moments(state->geometry, state->order);
    const size_t pixels = static_cast<size_t>(state->geometry.pixel_count());
    for (size_t i = 0; i < moments.real.size(); ++i) {
      moments.real[i] = static_cast<float>(state->c_real[i]);
      moments.imag[i] = static_cast<float>(state->c_imag[i]);
    }
    moments.valid.assign(pixels, 1);
    for (size_t p = 0; p < pixels; ++p) {
      if (!state->valid(static_cast<int64_t>(p))) moments.valid[p] = 0;
    }
    if (!writer.has_value()) {
      if ((*stream)->base_frequency_hz() <= 0.0) {
        failure = absl::DataLossError(absl::StrCat(subject,
                                                   ": frames without the camera's base frequency (",
                                                   wire::kNatsBaseFrequencyHeader, ")"));
        break;
      }
      MomentFileHeader header{.geometry = state->geometry,
                              .order = state->order,
                              .base_frequency_hz = (*stream)->base_frequency_hz(),
                              .source = summary.source_uri,
                              .calibration = "as published by transientd"};
      absl::StatusOr<MomentFileWriter> created = MomentFileWriter::Create(args.output_path, header);
      if (!created.ok()) return created.status();
      writer.emplace(*std::move(created));
      summary.schedule =
          absl::StrFormat("%dx%d, m = %d, f = %.6g MHz", state->geometry.width,
                          state->geometry.height, state->order, header.base_frequency_hz / 1e6);
    }
    if (absl::Status status = writer->Append(moments, frame.capture_time_s); !status.ok()) {
      failure = status;
      break;
    }
    ++summary.cycles;
    hooks.Progress(summary.cycles, args.frames);
  }
  summary.interrupted = hooks.cancelled();
  summary.seconds = absl::ToDoubleSeconds(absl::Now() - opened);
  if (writer.has_value()) {
    if (absl::Status status = writer->Close(); !status.ok() && failure.ok()) failure = status;
  }
  if (!failure.ok()) return failure;
  if (!writer.has_value()) {
    return absl::UnavailableError(
        absl::StrCat("no frame on ", subject, " at ", args.nats.servers, " within the time given"));
  }
  return summary;
}

}  // namespace transient::tools
