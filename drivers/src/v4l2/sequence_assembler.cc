// Aligning a V4L2 raw-phase stream into whole phase sequences (sequence_assembler.h).
#include "v4l2/sequence_assembler.h"

#include <cstdint>

#include "absl/strings/str_cat.h"

namespace transient::v4l2 {
namespace {

constexpr int kMaxPhases = 64;

}  // namespace

absl::Status ParseAlignment(const std::string& text, Alignment* alignment) {
  for (Alignment a : {Alignment::kTrigger, Alignment::kSequence, Alignment::kGap}) {
    if (text == AlignmentName(a)) {
      *alignment = a;
      return absl::OkStatus();
    }
  }
  return absl::InvalidArgumentError(
      absl::StrCat("align=", text, " is not one of trigger, sequence, gap"));
}

const char* AlignmentName(Alignment alignment) {
  switch (alignment) {
    case Alignment::kTrigger:
      return "trigger";
    case Alignment::kSequence:
      return "sequence";
    case Alignment::kGap:
      return "gap";
  }
  return "?";
}

const char* DropReasonName(DropReason reason) {
  switch (reason) {
    case DropReason::kErrorFlag:
      return "error flag";
    case DropReason::kWrongSize:
      return "wrong size";
    case DropReason::kSequenceGap:
      return "sequence gap";
    case DropReason::kTimestampGap:
      return "timestamp gap";
    case DropReason::kOverlong:
      return "overlong";
    case DropReason::kAbandoned:
      return "abandoned";
  }
  return "?";
}

int64_t AssemblerCounters::dropped_total() const {
  int64_t total = 0;
  for (int64_t n : dropped) total += n;
  return total;
}

absl::Status AssemblerOptions::Validate() const {
  if (phases < 1 || phases > kMaxPhases) {
    return absl::InvalidArgumentError(
        absl::StrCat("phases per sequence ", phases, " is outside 1..", kMaxPhases));
  }
  if (expected_bytes == 0) {
    return absl::InvalidArgumentError("the expected buffer size is 0");
  }
  if (gap_ns < 0 || (alignment == Alignment::kGap && gap_ns == 0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "gap ", gap_ns, " ns must be ", alignment == Alignment::kGap ? "positive" : "at least 0",
        " for align=", AlignmentName(alignment)));
  }
  return absl::OkStatus();
}

SequenceAssembler::SequenceAssembler(const AssemblerOptions& options) : options_(options) {
  trigger_seen_ = options_.phases;  // no trigger pending
}

void SequenceAssembler::Reset() {
  if (open_) Drop(DropReason::kAbandoned);
  trigger_seen_ = options_.phases;
  synced_ = false;
  expect_pause_ = false;
  last_.reset();
}

void SequenceAssembler::BeginSequence(uint32_t first_sequence) {
  if (open_) Drop(DropReason::kAbandoned);
  open_ = true;
  filled_ = 0;
  first_sequence_ = first_sequence;
  trigger_seen_ = 0;
}

void SequenceAssembler::Abandon() {
  if (open_) Drop(DropReason::kAbandoned);
  trigger_seen_ = options_.phases;
}

void SequenceAssembler::Drop(DropReason reason) {
  ++counters_.dropped[static_cast<int>(reason)];
  counters_.discarded_buffers += filled_;
  filled_ = 0;
  open_ = false;
}

Placement SequenceAssembler::Discard() {
  ++counters_.discarded_buffers;
  return {};
}

// The buffer takes `phase` of the open sequence unless it is flagged or the wrong size, which
// drops the sequence.
Placement SequenceAssembler::Place(const DequeuedBuffer& buffer, int phase) {
  if (buffer.error_flag || buffer.bytes_used != options_.expected_bytes) {
    Drop(buffer.error_flag ? DropReason::kErrorFlag : DropReason::kWrongSize);
    return Discard();
  }
  filled_ = phase + 1;
  if (filled_ < options_.phases) return {.phase = phase, .completes = false};
  ++counters_.sequences;
  filled_ = 0;
  open_ = false;
  expect_pause_ = options_.alignment == Alignment::kGap;
  return {.phase = phase, .completes = true};
}

Placement SequenceAssembler::Add(const DequeuedBuffer& buffer) {
  ++counters_.buffers;
  bool continuous = false, gap_before = false;
  if (last_.has_value()) {
    const uint32_t step = buffer.sequence - last_->sequence;  // modulo 2^32, like the driver's
    continuous = step == 1;
    if (step > 1 && step < (uint32_t{1} << 31)) counters_.driver_frames_lost += step - 1;
    // A driver's timestamps may jump anywhere (found by fuzzing: a difference past int64):
    // one that overflows forward is a gap, backward none.
    int64_t elapsed_ns = 0;
    if (__builtin_sub_overflow(buffer.timestamp_ns, last_->timestamp_ns, &elapsed_ns)) {
      elapsed_ns = buffer.timestamp_ns > last_->timestamp_ns ? INT64_MAX : INT64_MIN;
    }
    gap_before = options_.gap_ns > 0 && elapsed_ns > options_.gap_ns;
  }
  // A driver sequence that did not move forward (a restart we were not told of) counts from
  // this buffer again.
  const bool restarted = last_.has_value() && !continuous &&
                         buffer.sequence - last_->sequence >= (uint32_t{1} << 31);
  const bool restarted_or_first = restarted || !last_.has_value();
  last_ = buffer;
  switch (options_.alignment) {
    case Alignment::kTrigger:
      return AddTriggered(buffer, continuous);
    case Alignment::kSequence:
      if (restarted_or_first) synced_ = false;
      return AddCounted(buffer, gap_before, continuous);
    case Alignment::kGap:
      return AddAfterPause(buffer, gap_before, continuous);
  }
  return Discard();
}

Placement SequenceAssembler::AddTriggered(const DequeuedBuffer& buffer, bool continuous) {
  (void)continuous;  // the position comes from the number itself
  const uint32_t position = buffer.sequence - first_sequence_;  // modulo 2^32, like the driver's
  const auto phases = static_cast<uint32_t>(options_.phases);
  // A late frame of an earlier trigger, or one after this trigger's last: not of this sequence.
  if (position >= phases) return Discard();
  trigger_seen_ = std::max(trigger_seen_, static_cast<int>(position) + 1);
  if (!open_) return Discard();  // no sequence was started, or it was dropped
  if (static_cast<int>(position) != filled_) {
    Drop(DropReason::kSequenceGap);  // the frames before this one were lost
    return Discard();
  }
  return Place(buffer, filled_);
}

Placement SequenceAssembler::AddCounted(const DequeuedBuffer& buffer, bool gap_before,
                                        bool continuous) {
  const auto position = [&] {
    return static_cast<int>((buffer.sequence - first_sequence_) % static_cast<uint32_t>(options_.phases));
  };
  if (!synced_) {
    if (open_) Drop(DropReason::kSequenceGap);
    synced_ = true;
    first_sequence_ = buffer.sequence;
  } else if (gap_before && continuous && position() != 0) {
    // A pause where the count says mid-sequence, and no frame lost around it: the count no
    // longer matches the sensor. (Across a lost frame the count, which includes it, decides.)
    if (open_) Drop(DropReason::kTimestampGap);
    first_sequence_ = buffer.sequence;
  }
  const int phase = position();
  if (phase == 0) {
    if (open_) Drop(DropReason::kSequenceGap);  // the open one never got its last phases
    open_ = true;
    filled_ = 0;
  } else if (!open_) {
    return Discard();  // waiting for the next phase 0
  } else if (phase != filled_ || !continuous) {
    // A skipped count: a phase missing (or, for a skip of a multiple of N, a whole sequence's
    // worth of frames between this one and the open sequence's last).
    Drop(DropReason::kSequenceGap);
    return Discard();
  }
  return Place(buffer, phase);
}

Placement SequenceAssembler::AddAfterPause(const DequeuedBuffer& buffer, bool gap_before,
                                           bool continuous) {
  if (gap_before) {
    expect_pause_ = false;
    if (!continuous) {
      // The driver lost a frame around the pause: the last phases of the open sequence or the
      // first of this one; which, nothing says. Both go, and the next pause starts afresh.
      if (open_) Drop(DropReason::kSequenceGap);
      ++counters_.dropped[static_cast<int>(DropReason::kSequenceGap)];
      return Discard();
    }
    if (open_) Drop(DropReason::kTimestampGap);  // too few buffers before the pause
    open_ = true;
    filled_ = 0;
    return Place(buffer, 0);
  }
  if (expect_pause_) {
    // More buffers than phases without a pause: the sensor does not pause as configured.
    ++counters_.dropped[static_cast<int>(DropReason::kOverlong)];
    expect_pause_ = false;
    return Discard();
  }
  if (!open_) return Discard();  // waiting for a pause
  if (!continuous) {
    Drop(DropReason::kSequenceGap);
    return Discard();
  }
  return Place(buffer, filled_);
}

}  // namespace transient::v4l2
