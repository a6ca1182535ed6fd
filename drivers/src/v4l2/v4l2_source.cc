// The V4L2 capture source (v4l2_source.h): URI, profiles, the programming and read-back of the
// ToF controls, the capture loop with its watchdog and restarts, and the scheme's registration.
#include "v4l2/v4l2_source.h"

#include <linux/videodev2.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "source_uri.h"
#include "transient/drivers/source_registry.h"
#include "transient/reconstruct/status_context.h"
#include "v4l2/frame_unpacker.h"
#include "v4l2/sequence_assembler.h"
#include "v4l2/v4l2_device.h"
#include "v4l2/v4l2_options.h"

namespace transient::v4l2 {
namespace {

// A read-back frequency within this relative distance of j*f is j*f: the tolerance with which
// the demodulator matches a frame to its schedule (acquisition.cc).
constexpr double kFrequencyTolerance = 1e-6;

// The ToF controls of the mlx7502x profile, found by their proposed IDs, else by name.
struct TofControls {
  ControlDescription phases, frequency, integration, trigger, trigger_mode;
};

// By ID, else by name; either way of the control's type (an ID of a proposed control may mean
// another control on another kernel).
absl::StatusOr<ControlDescription> FindControl(const std::vector<ControlDescription>& controls,
                                               const ProposedControl& wanted,
                                               const std::string& node) {
  const uint32_t id = wanted.id;
  const std::string name = wanted.name;
  for (const ControlDescription& c : controls) {
    if (c.id == id && c.type == wanted.type) return c;
  }
  for (const ControlDescription& c : controls) {
    if (absl::EqualsIgnoreCase(c.name, name) && c.type == wanted.type) return c;
  }
  std::vector<std::string> found;
  for (const ControlDescription& c : controls) found.push_back(absl::StrCat("'", c.name, "'"));
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s has no control '%s' (0x%08x)%s; name the node with the sensor's controls with "
      "subdev=/dev/v4l-subdevN",
      node, name, id,
      found.empty() ? " and no controls at all" : absl::StrCat("; it has ", absl::StrJoin(found, ", "))));
}

absl::StatusOr<ControlDescription> FindPassthrough(const std::vector<ControlDescription>& controls,
                                                   const std::string& encoded_key,
                                                   const std::string& node) {
  const std::string key = internal::PercentDecoded(encoded_key);
  uint32_t id = 0;
  if (absl::StartsWith(key, "0x") && absl::SimpleHexAtoi(key.substr(2), &id)) {
    for (const ControlDescription& c : controls) {
      if (c.id == id) return c;
    }
  } else {
    for (const ControlDescription& c : controls) {
      if (absl::EqualsIgnoreCase(c.name, key)) return c;
    }
  }
  return absl::InvalidArgumentError(
      absl::StrCat(node, ": ctrl.", key, ": no such control (transient devices lists them)"));
}

// One sensor sequence of the cycle: buckets at one frequency, and the frames it stamps.
// Harmonic cancellation built from captures: the n_phi sub-exposures of a bucket are frames of
// their own, at the bucket's phase plus theta_k and with the share w_k of the exposure time;
// their sum is the exposure the scheme defines (thesis §8.3.1), each frame first scaled by the
// time it should have had over the time the driver set (the signal grows with the time).
struct DeviceSequence {
  std::vector<ControlValue> program;     // mlx7502x: what to set before the trigger
  std::vector<std::vector<int64_t>> read_back;  // and what the driver must read back after it
  std::vector<ExposureConfig> frames;    // the stamps of its raw frames (cycle/sequence/time
                                         // unset), one per `subexposures` buffers
  int subexposures = 1;                  // buffers summed into one raw frame
  std::vector<double> scale;             // per buffer: wanted / set integration time
};

class V4l2Source final : public CaptureSource {
 public:
  static absl::StatusOr<std::unique_ptr<CaptureSource>> Open(absl::string_view uri);

  const std::string& uri() const override { return uri_; }
  const CameraInfo& camera() const override { return camera_; }
  const AcquisitionSchedule& schedule() const override { return *schedule_; }
  SourceCapabilities capabilities() const override;
  absl::Status Start() override;
  absl::Status Next(absl::Duration timeout, RawFrame* frame) override;
  absl::Status Stop() override;
  std::vector<SourceCounter> Counters() const override;

 private:
  V4l2Source(std::string uri, V4l2Options options, V4l2Device device)
      : uri_(std::move(uri)), options_(std::move(options)), device_(std::move(device)) {}

  V4l2Device& controls_device() { return subdev_.has_value() ? *subdev_ : device_; }
  absl::Status Configure();
  absl::Status PlanMlx(const std::vector<ControlDescription>& controls);
  // The trigger controls, and the trigger mode set to internal.
  absl::Status FindTrigger(const std::vector<ControlDescription>& controls);
  void PlanGeneric();
  // Sets a sequence's controls and reads them back into `read_back`.
  absl::Status Program(const std::vector<ControlValue>& program,
                       std::vector<std::vector<int64_t>>* read_back);
  // The current values of the controls `program` sets, in one call.
  absl::StatusOr<std::vector<std::vector<int64_t>>> ReadBack(
      const std::vector<ControlValue>& program);
  absl::Status Trigger();
  absl::Status Restart(const std::string& why);
  // After STREAMON: the alignment and numbering start again.
  void StreamStarted();
  absl::Status HandleBuffer(const DequeuedFrame& dequeued);
  void Emit();

  std::string uri_;
  V4l2Options options_;
  V4l2Device device_;
  std::optional<V4l2Device> subdev_;
  CameraInfo camera_;
  std::optional<AcquisitionSchedule> schedule_;
  NegotiatedFormat format_;
  TofControls tof_;
  std::vector<DeviceSequence> sequences_;  // of one cycle, in capture order
  int frames_per_sequence_ = 0;            // phase images of one device sequence
  std::optional<SequenceAssembler> assembler_;

  // Capture state.
  bool started_ = false;
  size_t next_ = 0;          // the device sequence being taken
  int64_t cycle_ = 0;
  bool triggered_ = false;   // a sequence was triggered and is not all out yet
  uint32_t next_trigger_sequence_ = 0;  // the driver's number of the next trigger's first frame
  absl::Time last_progress_;
  bool bad_samples_ = false;
  bool control_events_ = false;  // subscribed to the ToF controls' change events
  std::vector<std::vector<float>> slots_;
  std::vector<DequeuedBuffer> slot_buffers_;
  std::deque<RawFrame> ready_;
  uint64_t sequence_base_ = 0;   // added to the driver's sequence numbers (restarts reset them)
  uint64_t next_sequence_ = 0;   // one past the last frame's sequence
  std::optional<int64_t> first_timestamp_ns_;
  int consecutive_restarts_ = 0;

  // Counters beyond the assembler's.
  int64_t restarts_ = 0, watchdog_timeouts_ = 0, dequeue_errors_ = 0;
  int64_t dropped_control_changed_ = 0;  // whole, but the read-back differed at their end
  int64_t dropped_bad_samples_ = 0;
  int64_t abandoned_for_control_ = 0;  // of the assembler's abandoned: control changes
};

absl::StatusOr<std::unique_ptr<CaptureSource>> V4l2Source::Open(absl::string_view uri) {
  absl::StatusOr<V4l2Options> options = ParseV4l2Uri(uri);
  if (!options.ok()) return options.status();
  absl::StatusOr<V4l2Device> device = V4l2Device::Open(options->device);
  if (!device.ok()) return device.status();
  std::unique_ptr<V4l2Source> source(
      new V4l2Source(std::string(uri), *std::move(options), *std::move(device)));
  if (absl::Status status = source->Configure(); !status.ok()) return status;
  return std::unique_ptr<CaptureSource>(std::move(source));
}

absl::Status V4l2Source::Configure() {
  absl::StatusOr<Capabilities> caps = device_.QueryCapabilities();
  if (!caps.ok()) return caps.status();
  if (!caps->capture() || !caps->streaming()) {
    return absl::FailedPreconditionError(absl::StrCat(
        options_.device, " (", caps->card, ") is not a streaming video capture node; "
        "transient devices lists the ones that are"));
  }
  if (!options_.subdev.empty()) {
    absl::StatusOr<V4l2Device> subdev = V4l2Device::Open(options_.subdev);
    if (!subdev.ok()) return subdev.status();
    subdev_.emplace(*std::move(subdev));
  }
  absl::StatusOr<std::vector<ControlDescription>> controls =
      controls_device().EnumerateControls();
  if (!controls.ok()) return controls.status();
  // Vendor controls first: they may change what the ToF controls accept.
  for (const auto& [key, values] : options_.passthrough) {
    absl::StatusOr<ControlDescription> control =
        FindPassthrough(*controls, key, controls_device().path());
    if (!control.ok()) return control.status();
    const ControlValue value{&*control, values};
    if (absl::Status s = controls_device().SetControls({&value, 1}); !s.ok()) return s;
  }
  if (options_.profile == Profile::kMlx7502x) {
    if (absl::Status s = PlanMlx(*controls); !s.ok()) return s;
  } else {
    PlanGeneric();
    if (options_.assembly.alignment == Alignment::kTrigger) {
      // A sensor that runs its own program, one cycle per press of its trigger.
      if (absl::Status s = FindTrigger(*controls); !s.ok()) return s;
    }
  }
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options_.schedule);
  if (!schedule.ok()) return WithContext(uri_, schedule.status());
  schedule_.emplace(*std::move(schedule));

  frames_per_sequence_ = static_cast<int>(sequences_.front().frames.size()) *
                         sequences_.front().subexposures;
  if (frames_per_sequence_ % options_.subframes != 0) {
    return absl::InvalidArgumentError(absl::StrCat(uri_, ": subframes = ", options_.subframes,
                                                   " does not divide a sequence of ",
                                                   frames_per_sequence_, " phase images"));
  }
  ImageGeometry buffer_geometry = options_.geometry;
  buffer_geometry.height *= options_.subframes;
  absl::StatusOr<NegotiatedFormat> format =
      device_.SetFormat(options_.sample.fourcc, buffer_geometry);
  if (!format.ok()) return format.status();
  format_ = *format;
  if (absl::Status s = CheckLayout({buffer_geometry, format_.bytes_per_line}, options_.sample);
      !s.ok()) {
    return WithContext(uri_, s);
  }
  AssemblerOptions assembly = options_.assembly;
  assembly.phases = frames_per_sequence_ / options_.subframes;
  assembly.expected_bytes = format_.image_bytes;
  if (absl::Status s = assembly.Validate(); !s.ok()) return WithContext(uri_, s);
  assembler_.emplace(assembly);
  options_.buffers = std::max(options_.buffers, assembly.phases);

  camera_.geometry = options_.geometry;
  camera_.intrinsics = options_.intrinsics;
  camera_.model = absl::StrCat(caps->card, " (", caps->driver, ", ", options_.device, ")");
  slots_.assign(static_cast<size_t>(frames_per_sequence_),
                std::vector<float>(static_cast<size_t>(options_.geometry.pixel_count())));
  slot_buffers_.assign(static_cast<size_t>(frames_per_sequence_), {});
  return absl::OkStatus();
}

// The frequencies of a cycle's sequences: for each take, the proxy's (harmonic 0) if measured,
// then j*f for j = 1..m.
std::vector<std::pair<int, double>> SequenceFrequencies(const ScheduleOptions& schedule) {
  std::vector<std::pair<int, double>> sequences;
  if (schedule.zeroth == ZerothScheme::kLowFrequencyProxy) {
    sequences.emplace_back(0, schedule.proxy_frequency_hz);
  }
  for (int j = 1; j <= schedule.order; ++j) {
    sequences.emplace_back(j, j * schedule.base_frequency_hz);
  }
  return sequences;
}

ExposureConfig Stamp(int harmonic, double frequency_hz, int64_t phase_deg, double exposure_s,
                     int take) {
  ExposureConfig config;
  config.harmonic = harmonic;
  config.frequency_hz = frequency_hz;
  config.phase_shift_rad = static_cast<double>(phase_deg) * std::numbers::pi / 180.0;
  config.exposure_s = exposure_s;
  config.illumination = true;
  config.take = take;
  return config;
}

void V4l2Source::PlanGeneric() {
  // The sensor runs the whole cycle by itself: one device sequence of all its frames.
  DeviceSequence cycle;
  for (int take = 0; take < options_.schedule.takes; ++take) {
    for (const auto& [harmonic, frequency] : SequenceFrequencies(options_.schedule)) {
      for (int64_t phase : options_.phases_deg) {
        cycle.frames.push_back(
            Stamp(harmonic, frequency, phase, options_.schedule.exposure_s, take));
      }
    }
  }
  sequences_ = {std::move(cycle)};
}

absl::Status V4l2Source::FindTrigger(const std::vector<ControlDescription>& controls) {
  const std::string node = controls_device().path();
  absl::StatusOr<ControlDescription> trigger =
      FindControl(controls, kCameraTrigger, node);
  if (!trigger.ok()) return WithContext(uri_, trigger.status());
  absl::StatusOr<ControlDescription> mode =
      FindControl(controls, kCameraTriggerMode, node);
  if (!mode.ok()) return WithContext(uri_, mode.status());
  tof_.trigger = *trigger;
  tof_.trigger_mode = *mode;
  // Internal trigger: the sensor takes one sequence per press of the trigger button.
  const ControlValue internal{&tof_.trigger_mode, {1}};
  return WithContext(uri_, controls_device().SetControls({&internal, 1}));
}

absl::Status V4l2Source::PlanMlx(const std::vector<ControlDescription>& controls) {
  const std::string node = controls_device().path();
  struct Wanted {
    ControlDescription* out;
    const ProposedControl& control;
  };
  for (const Wanted& w : {Wanted{&tof_.phases, kTofPhaseSequence},
                          Wanted{&tof_.frequency, kTofFrequencyModulation},
                          Wanted{&tof_.integration, kTofTimeIntegration}}) {
    absl::StatusOr<ControlDescription> found = FindControl(controls, w.control, node);
    if (!found.ok()) return WithContext(uri_, found.status());
    *w.out = *found;
  }
  if (!options_.proxy_given) {
    options_.schedule.proxy_frequency_hz = static_cast<double>(tof_.frequency.minimum);
  }
  if (absl::Status s = FindTrigger(controls); !s.ok()) return s;
  // The sub-exposures of every bucket (one at 0 with the whole time for four-bucket), in
  // degrees on the phase control's grid, and the buckets that fit one sequence of the sensor.
  absl::StatusOr<AcquisitionSchedule> split = AcquisitionSchedule::Create(options_.schedule);
  if (!split.ok()) return WithContext(uri_, split.status());
  struct Sub {
    int64_t phase_deg;
    double share;
  };
  std::vector<Sub> subs;
  for (const SubExposure& sub : split->sub_exposures()) {
    const double degrees = sub.phase_shift_rad * 180.0 / std::numbers::pi;
    const int64_t rounded = std::llround(degrees);
    const auto step = static_cast<int64_t>(std::max<uint64_t>(tof_.phases.step, 1));
    if (std::abs(degrees - static_cast<double>(rounded)) > 1e-9 || rounded % step != 0) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: nphi = %d needs phase steps of %.6g deg; the sensor's phase control has steps of "
          "%d deg (%s)",
          uri_, options_.schedule.phase_steps, degrees, step, DescribeControlRange(tof_.phases)));
    }
    subs.push_back({rounded, sub.weight});
  }
  const int per_bucket = static_cast<int>(subs.size());
  const int capacity = static_cast<int>(std::max<uint32_t>(tof_.phases.elements, 1));
  int buckets_per_sequence = 4;  // a divisor of the four buckets, so every sequence is as long
  while (buckets_per_sequence * per_bucket > capacity) buckets_per_sequence /= 2;
  if (buckets_per_sequence == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        uri_, ": nphi = ", per_bucket, " needs ", per_bucket, " phases in one sequence; '",
        tof_.phases.name, "' holds ", capacity));
  }
  const double total_us = options_.schedule.exposure_s * 1e6;
  const bool combined = per_bucket > 1;
  std::optional<double> exposure_s;
  sequences_.clear();
  for (int take = 0; take < options_.schedule.takes; ++take) {
    for (const auto& [harmonic, frequency] : SequenceFrequencies(options_.schedule)) {
      for (int first = 0; first < 4; first += buckets_per_sequence) {
        DeviceSequence sequence;
        sequence.subexposures = per_bucket;
        std::vector<int64_t> phases, integration;
        for (int b = first; b < first + buckets_per_sequence; ++b) {
          for (const Sub& sub : subs) {
            phases.push_back((options_.phases_deg[static_cast<size_t>(b)] + sub.phase_deg) % 360);
            integration.push_back(std::max<int64_t>(std::llround(total_us * sub.share), 1));
          }
        }
        sequence.program = {
            {&tof_.frequency, {std::llround(frequency)}},
            {&tof_.phases, phases},
            {&tof_.integration, integration},
        };
        if (absl::Status s = Program(sequence.program, &sequence.read_back); !s.ok()) return s;
        const auto& read_frequency = sequence.read_back[0];
        const auto& read_phases = sequence.read_back[1];
        const auto& read_integration = sequence.read_back[2];
        const double got = read_frequency.empty() ? 0.0 : static_cast<double>(read_frequency[0]);
        if (std::abs(got - frequency) > kFrequencyTolerance * frequency) {
          return absl::InvalidArgumentError(absl::StrFormat(
              "%s: harmonic %d needs %.9g Hz (%s), the driver set 'TOF Frequency Modulation' to "
              "%.9g Hz: not j*f within a relative %g. Choose f so that every j*f is a frequency "
              "the sensor sets exactly (%s)",
              uri_, harmonic, frequency,
              harmonic == 0 ? "the proxy" : absl::StrCat(harmonic, " x f").c_str(), got,
              kFrequencyTolerance, DescribeControlRange(tof_.frequency)));
        }
        if (read_phases != phases) {
          return absl::InvalidArgumentError(absl::StrCat(
              uri_, ": asked for the phase sequence ", absl::StrJoin(phases, ","),
              ", the driver set ", absl::StrJoin(read_phases, ",")));
        }
        if (read_integration.size() != integration.size() ||
            std::any_of(read_integration.begin(), read_integration.end(),
                        [](int64_t t) { return t <= 0; })) {
          return absl::InvalidArgumentError(absl::StrCat(
              uri_, ": asked for the integration times ", absl::StrJoin(integration, ","),
              " us, the driver set ", absl::StrJoin(read_integration, ",")));
        }
        for (size_t k = 0; k < read_integration.size(); ++k) {
          const double wanted = total_us * subs[k % subs.size()].share;
          sequence.scale.push_back(combined ? wanted / static_cast<double>(read_integration[k])
                                            : 1.0);
        }
        // Four-bucket: the frames say the time the driver set (it rounds to its step), and it
        // must be one time for the whole schedule. Combined: each frame was scaled to its
        // share of the exposure, so the sum is one of the exposure asked for.
        const double frame_exposure_s =
            combined ? options_.schedule.exposure_s : static_cast<double>(read_integration[0]) * 1e-6;
        if (!combined &&
            (std::adjacent_find(read_integration.begin(), read_integration.end(),
                                std::not_equal_to<>()) != read_integration.end() ||
             (exposure_s.has_value() && *exposure_s != frame_exposure_s))) {
          return absl::InvalidArgumentError(absl::StrCat(
              uri_, ": asked for one integration time of ", integration[0],
              " us, the driver set ", absl::StrJoin(read_integration, ","),
              exposure_s.has_value() ? absl::StrCat(" (and ", *exposure_s * 1e6, " before)") : ""));
        }
        exposure_s = frame_exposure_s;
        for (int b = first; b < first + buckets_per_sequence; ++b) {
          sequence.frames.push_back(Stamp(harmonic, got, options_.phases_deg[static_cast<size_t>(b)],
                                          frame_exposure_s, take));
        }
        sequences_.push_back(std::move(sequence));
      }
    }
  }
  options_.schedule.exposure_s = *exposure_s;
  // Another program's change of a ToF control shows as an event, where the driver sends them;
  // the read-back at the end of each sequence catches it where it does not.
  const uint32_t watched[] = {tof_.phases.id, tof_.frequency.id, tof_.integration.id};
  const absl::Status subscribed = controls_device().SubscribeControlEvents(watched);
  if (!subscribed.ok() && !absl::IsUnimplemented(subscribed)) return WithContext(uri_, subscribed);
  control_events_ = subscribed.ok();
  return absl::OkStatus();
}

absl::Status V4l2Source::Program(const std::vector<ControlValue>& program,
                                 std::vector<std::vector<int64_t>>* read_back) {
  if (absl::Status s = controls_device().SetControls(program); !s.ok()) {
    return WithContext(uri_, s);
  }
  absl::StatusOr<std::vector<std::vector<int64_t>>> got = ReadBack(program);
  if (!got.ok()) return got.status();
  *read_back = *std::move(got);
  return absl::OkStatus();
}

absl::StatusOr<std::vector<std::vector<int64_t>>> V4l2Source::ReadBack(
    const std::vector<ControlValue>& program) {
  // One VIDIOC_G_EXT_CTRLS for all of them.
  std::vector<const ControlDescription*> controls;
  for (const ControlValue& value : program) controls.push_back(value.control);
  absl::StatusOr<std::vector<std::vector<int64_t>>> got = controls_device().GetControls(controls);
  if (!got.ok()) return WithContext(uri_, got.status());
  return got;
}

SourceCapabilities V4l2Source::capabilities() const {
  SourceCapabilities c;
  if (options_.profile == Profile::kMlx7502x) {
    c.min_frequency_hz = static_cast<double>(tof_.frequency.minimum);
    c.max_frequency_hz = static_cast<double>(tof_.frequency.maximum);
    c.min_exposure_s = static_cast<double>(tof_.integration.minimum) * 1e-6;
    c.max_exposure_s = static_cast<double>(tof_.integration.maximum) * 1e-6;
  } else {
    // What the URI says the sensor runs.
    const std::vector<std::pair<int, double>> frequencies = SequenceFrequencies(options_.schedule);
    c.min_frequency_hz = frequencies.front().second;
    c.max_frequency_hz = frequencies.back().second;
    c.min_exposure_s = c.max_exposure_s = options_.schedule.exposure_s;
  }
  return c;
}

absl::Status V4l2Source::Start() {
  if (started_) return absl::FailedPreconditionError(absl::StrCat(uri_, ": already started"));
  if (absl::Status s = device_.StartStreaming(options_.buffers, assembler_->options().phases);
      !s.ok()) {
    return WithContext(uri_, s);
  }
  started_ = true;
  StreamStarted();
  return absl::OkStatus();
}

void V4l2Source::StreamStarted() {
  assembler_->Reset();
  triggered_ = false;
  next_trigger_sequence_ = 0;      // drivers number frames from 0 at STREAMON
  sequence_base_ = next_sequence_;  // so the frames' numbers keep increasing
  last_progress_ = absl::Now();
  bad_samples_ = false;
}

absl::Status V4l2Source::Stop() {
  if (!started_) return absl::FailedPreconditionError(absl::StrCat(uri_, ": not started"));
  started_ = false;
  ready_.clear();
  return device_.StopStreaming();
}

absl::Status V4l2Source::Trigger() {
  DeviceSequence& sequence = sequences_[next_];
  std::vector<std::vector<int64_t>> read_back;
  if (!sequence.program.empty()) {
    if (absl::Status s = Program(sequence.program, &read_back); !s.ok()) return s;
  }
  if (read_back != sequence.read_back) {
    // The driver no longer sets what it set when the source opened: not the schedule.
    return absl::FailedPreconditionError(absl::StrCat(
        uri_, ": the driver now reads back other values for ",
        DescribeControlValue(*sequence.program[0].control, sequence.program[0].values),
        " than when the source opened"));
  }
  const ControlValue press{&tof_.trigger, {}};
  if (absl::Status s = controls_device().SetControls({&press, 1}); !s.ok()) {
    return WithContext(uri_, s);
  }
  // Every trigger makes the sensor take (and the driver number) a whole sequence, lost frames
  // included: the k-th trigger's frames are numbered from k * N.
  assembler_->BeginSequence(next_trigger_sequence_);
  next_trigger_sequence_ += static_cast<uint32_t>(assembler_->options().phases);
  triggered_ = true;
  last_progress_ = absl::Now();
  return absl::OkStatus();
}

absl::Status V4l2Source::Restart(const std::string& why) {
  ++restarts_;
  if (++consecutive_restarts_ > options_.restarts) {
    return absl::UnavailableError(absl::StrCat(uri_, ": no whole sequence after ",
                                               options_.restarts, " stream restarts (", why, ")"));
  }
  if (absl::Status s = device_.StopStreaming(); !s.ok()) return WithContext(uri_, s);
  if (absl::Status s = device_.StartStreaming(options_.buffers, assembler_->options().phases);
      !s.ok()) {
    return WithContext(uri_, s);
  }
  StreamStarted();
  return absl::OkStatus();
}

absl::Status V4l2Source::HandleBuffer(const DequeuedFrame& dequeued) {
  const DequeuedBuffer& buffer = dequeued.buffer;
  if (control_events_ && triggered_) {
    absl::StatusOr<std::vector<uint32_t>> changed = controls_device().ChangedControls();
    if (!changed.ok()) return WithContext(uri_, changed.status());
    if (!changed->empty()) {
      // Someone else set a control during the sequence: give it up now; its remaining frames
      // come as late ones of an abandoned trigger, and the next trigger sets the controls again.
      assembler_->Abandon();
      ++abandoned_for_control_;
    }
  }
  const Placement placement = assembler_->Add(buffer);
  if (placement.phase.has_value()) {
    const int per_buffer = options_.subframes;
    const size_t sub_bytes = format_.bytes_per_line * static_cast<size_t>(options_.geometry.height);
    const FrameLayout layout{options_.geometry, format_.bytes_per_line};
    if (*placement.phase == 0) bad_samples_ = false;
    for (int s = 0; s < per_buffer; ++s) {
      const size_t slot = static_cast<size_t>(*placement.phase * per_buffer + s);
      const std::span<const uint8_t> data =
          dequeued.data.size() > s * sub_bytes ? dequeued.data.subspan(s * sub_bytes)
                                               : std::span<const uint8_t>();
      if (!Unpack(data, layout, options_.sample, slots_[slot]).ok()) bad_samples_ = true;
      slot_buffers_[slot] = buffer;
    }
  }
  // Copied out: the buffer goes back to the driver at once.
  if (absl::Status s = device_.Requeue(dequeued.index); !s.ok()) return WithContext(uri_, s);
  if (triggered_ && assembler_->TriggerDone()) {
    triggered_ = false;  // all of the trigger's frames are out, whatever became of them
  }
  if (!placement.completes) return absl::OkStatus();
  if (bad_samples_) {
    ++dropped_bad_samples_;
    bad_samples_ = false;
    return absl::OkStatus();
  }
  if (options_.profile == Profile::kMlx7502x && !control_events_) {
    // Controls another program set during the sequence, where the driver sends no events to
    // say so (HandleBuffer reads them): drop it; the next trigger sets them again (Trigger).
    absl::StatusOr<std::vector<std::vector<int64_t>>> now = ReadBack(sequences_[next_].program);
    if (!now.ok()) return now.status();
    if (*now != sequences_[next_].read_back) {
      ++dropped_control_changed_;
      return absl::OkStatus();
    }
  }
  Emit();
  return absl::OkStatus();
}

void V4l2Source::Emit() {
  const DeviceSequence& sequence = sequences_[next_];
  const float slot_saturation = static_cast<float>(options_.sample.is_signed
                                                       ? (1 << (options_.sample.bits - 1)) - 1
                                                       : (1 << options_.sample.bits) - 1);
  const auto per_buffer = static_cast<uint64_t>(options_.subframes);
  const size_t n = static_cast<size_t>(sequence.subexposures);
  for (size_t f = 0; f < sequence.frames.size(); ++f) {
    RawFrame frame;
    frame.config = sequence.frames[f];
    frame.config.cycle = cycle_;
    // The frame's number and time are its first buffer's; a superframe's phase images share
    // their buffer's number, so they are numbered apart within it.
    const size_t first = f * n;
    const DequeuedBuffer& buffer = slot_buffers_[first];
    frame.config.sequence = sequence_base_ + buffer.sequence * per_buffer + first % per_buffer;
    if (!first_timestamp_ns_.has_value()) first_timestamp_ns_ = buffer.timestamp_ns;
    frame.config.timestamp_s =
        static_cast<double>(buffer.timestamp_ns - *first_timestamp_ns_) * 1e-9;
    frame.geometry = options_.geometry;
    if (n == 1) {
      frame.pixels = slots_[first];
      frame.saturation_level = slot_saturation;
    } else {
      // The sum of the scaled sub-exposures; saturated where any of them is.
      float saturation = 0.0f;
      for (size_t k = 0; k < n; ++k) {
        saturation += static_cast<float>(sequence.scale[first + k]) * slot_saturation;
      }
      frame.pixels.assign(slots_[first].size(), 0.0f);
      for (size_t k = 0; k < n; ++k) {
        const auto scale = static_cast<float>(sequence.scale[first + k]);
        const std::vector<float>& slot = slots_[first + k];
        for (size_t p = 0; p < slot.size(); ++p) {
          frame.pixels[p] = slot[p] >= slot_saturation || frame.pixels[p] >= saturation
                                ? saturation
                                : frame.pixels[p] + scale * slot[p];
        }
      }
      frame.saturation_level = saturation;
    }
    next_sequence_ = std::max(next_sequence_, frame.config.sequence + 1);
    ready_.push_back(std::move(frame));
  }
  consecutive_restarts_ = 0;
  if (++next_ == sequences_.size()) {
    next_ = 0;
    ++cycle_;
  }
}

absl::Status V4l2Source::Next(absl::Duration timeout, RawFrame* frame) {
  if (!started_) return absl::FailedPreconditionError(absl::StrCat(uri_, ": not started"));
  const absl::Time deadline = absl::Now() + timeout;
  while (ready_.empty()) {
    if (options_.assembly.alignment == Alignment::kTrigger && !triggered_) {
      if (absl::Status s = Trigger(); !s.ok()) return s;
    }
    const absl::Time now = absl::Now();
    const absl::Time watchdog = last_progress_ + options_.watchdog;
    if (now >= watchdog) {
      ++watchdog_timeouts_;
      const bool partial = triggered_ && assembler_->trigger_frames_seen() > 0;
      assembler_->Abandon();
      if (partial) {
        // The trigger's last frames never came (a lost frame shows only in the sequence number
        // of the next one): the sequence is given up and taken again; the stream runs on.
        triggered_ = false;
        last_progress_ = now;
        continue;
      }
      if (absl::Status s = Restart(absl::StrCat("no buffer for ",
                                                absl::FormatDuration(options_.watchdog)));
          !s.ok()) {
        return s;
      }
      continue;
    }
    if (now >= deadline) {
      return absl::DeadlineExceededError(
          absl::StrCat(uri_, ": no whole sequence within ", absl::FormatDuration(timeout)));
    }
    absl::StatusOr<DequeuedFrame> dequeued = device_.Dequeue(std::min(deadline, watchdog) - now);
    if (!dequeued.ok()) {
      if (absl::IsDeadlineExceeded(dequeued.status())) continue;
      if (absl::IsUnavailable(dequeued.status())) return dequeued.status();
      ++dequeue_errors_;
      if (absl::Status s = Restart(std::string(dequeued.status().message())); !s.ok()) return s;
      continue;
    }
    last_progress_ = absl::Now();
    if (absl::Status s = HandleBuffer(*dequeued); !s.ok()) return s;
  }
  *frame = std::move(ready_.front());
  ready_.pop_front();
  return absl::OkStatus();
}

std::vector<SourceCounter> V4l2Source::Counters() const {
  const AssemblerCounters& a = assembler_->counters();
  std::vector<SourceCounter> counters = {
      {"buffers", a.buffers, "buffers dequeued from the driver"},
      {"sequences", a.sequences - dropped_control_changed_ - dropped_bad_samples_,
       "whole phase sequences delivered as raw frames"},
  };
  for (int r = 0; r < kDropReasons; ++r) {
    // A sequence given up for a control change counts there, not as abandoned.
    const int64_t dropped = a.dropped[r] - (static_cast<DropReason>(r) == DropReason::kAbandoned
                                                ? abandoned_for_control_
                                                : 0);
    counters.push_back({absl::StrCat("sequences_dropped_",
                                     absl::StrReplaceAll(DropReasonName(static_cast<DropReason>(r)),
                                                         {{" ", "_"}})),
                        dropped,
                        absl::StrCat("sequences dropped whole: ",
                                     DropReasonName(static_cast<DropReason>(r)))});
  }
  counters.push_back({"sequences_dropped_control_changed",
                      dropped_control_changed_ + abandoned_for_control_,
                      "sequences dropped: another program set a ToF control (an event, or the "
                      "read-back at their end)"});
  counters.push_back({"sequences_dropped_bad_samples", dropped_bad_samples_,
                      "sequences dropped: a buffer's samples did not fit the format"});
  counters.push_back({"discarded_buffers", a.discarded_buffers,
                      "buffers that went to no delivered sequence"});
  counters.push_back({"driver_frames_lost", a.driver_frames_lost,
                      "frames the driver's sequence numbers skipped"});
  counters.push_back({"watchdog_timeouts", watchdog_timeouts_,
                      "times no buffer came within timeout_ms"});
  counters.push_back({"dequeue_errors", dequeue_errors_, "VIDIOC_DQBUF errors other than ENODEV"});
  counters.push_back({"restarts", restarts_, "stream restarts (STREAMOFF, STREAMON)"});
  return counters;
}

}  // namespace

absl::StatusOr<std::unique_ptr<CaptureSource>> OpenV4l2Source(absl::string_view uri) {
  return V4l2Source::Open(uri);
}

absl::StatusOr<std::string> V4l2UriWithTakes(absl::string_view uri, int takes) {
  absl::StatusOr<internal::SourceUri> parsed = internal::ParseSourceUri(uri);
  if (!parsed.ok()) return parsed.status();
  internal::SetSourceUriKey(&*parsed, "takes", absl::StrCat(takes));
  std::string changed = internal::FormatSourceUri(*parsed);
  if (absl::StatusOr<V4l2Options> options = ParseV4l2Uri(changed); !options.ok()) {
    return options.status();
  }
  return changed;
}

}  // namespace transient::v4l2

namespace transient::internal {

extern const SourceScheme kV4l2Scheme;
const SourceScheme kV4l2Scheme = {
    .name = "v4l2",
    .syntax = "v4l2:/dev/videoN?profile=generic|mlx7502x&key=value&...",
    .description = "a raw-phase ToF sensor through V4L2 (transient devices lists the nodes)",
    .keys = v4l2::V4l2Keys(),
    .capabilities = {.adjustable_takes = true},
    .open = v4l2::OpenV4l2Source,
    .with_takes = v4l2::V4l2UriWithTakes,
};

}  // namespace transient::internal
