// Which buffer is which phase: the alignment of a V4L2 raw-phase stream into whole phase
// sequences. Sensors like the MLX7502x deliver one buffer per phase of a sequence and nothing in
// the buffer says which phase it is (../shared/research/v4l2.md §1.1, §1.4, §5.4), so the
// position comes from one of three rules:
//   kTrigger:  the caller starts every sequence (a software trigger) and names the driver
//              sequence number its first frame gets: drivers count frames from 0 at STREAMON,
//              lost ones included, so with N frames per trigger the k-th trigger's frames are
//              numbers k*N .. k*N+N-1 (../shared/research/v4l2.md §2.4). A buffer takes the
//              phase its number gives; one of an earlier trigger (late) or of none is discarded.
//   kSequence: the driver's sequence number, which counts dropped frames too, from the first
//              buffer after Reset(): phase = (sequence - first) mod N; a timestamp gap above
//              `gap_ns` inside a sequence, between consecutive driver sequence numbers, means
//              the count no longer matches the sensor, and the buffer after it becomes phase 0.
//   kGap:      a pause above `gap_ns` before a buffer starts a sequence (the idle time between
//              sequences, what the Melexis and Arducam examples use); the first buffer after
//              Reset() waits for one, and so does a pause across a lost frame (which side of
//              the pause lost it, nothing says).
// A sequence is emitted only whole: N buffers in phase order, consecutive driver sequence
// numbers, no error flag, every buffer the expected size. Otherwise the whole sequence is
// dropped and counted by reason, never demodulated (a missing bucket corrupts the phasor).
// Pure: the caller dequeues and unpacks; this decides where each buffer goes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"

namespace transient::v4l2 {

enum class Alignment { kTrigger, kSequence, kGap };

// "trigger", "sequence", "gap"; InvalidArgument naming the choices otherwise.
absl::Status ParseAlignment(const std::string& text, Alignment* alignment);
const char* AlignmentName(Alignment alignment);

// What the caller read from a dequeued struct v4l2_buffer.
struct DequeuedBuffer {
  uint32_t sequence = 0;      // v4l2_buffer.sequence
  int64_t timestamp_ns = 0;   // v4l2_buffer.timestamp
  bool error_flag = false;    // V4L2_BUF_FLAG_ERROR
  size_t bytes_used = 0;      // v4l2_buffer.bytesused
};

enum class DropReason {
  kErrorFlag,      // a buffer flagged V4L2_BUF_FLAG_ERROR
  kWrongSize,      // bytesused differs from the format's image size (a short or garbled frame)
  kSequenceGap,    // the driver's sequence number skipped (frames lost for want of buffers)
  kTimestampGap,   // a pause inside a sequence (kSequence) or too few buffers before the pause (kGap)
  kOverlong,       // kGap: more than N buffers without a pause (counted once, no open sequence)
  kAbandoned,      // the caller gave the open sequence up (a timeout, a restart, a new trigger)
};
constexpr int kDropReasons = 6;
const char* DropReasonName(DropReason reason);

struct AssemblerCounters {
  int64_t buffers = 0;              // buffers offered
  int64_t discarded_buffers = 0;    // buffers that went to no emitted sequence
  int64_t sequences = 0;            // whole sequences emitted
  int64_t dropped[kDropReasons] = {};  // sequences dropped, by DropReason
  int64_t driver_frames_lost = 0;   // frames the driver's sequence numbers skipped

  int64_t dropped_total() const;
};

struct AssemblerOptions {
  int phases = 4;               // buffers per sequence, 1..64
  Alignment alignment = Alignment::kSequence;
  size_t expected_bytes = 0;    // bytesused of a whole buffer (the format's sizeimage), > 0
  // The pause between sequences (ns): kGap splits at it (> 0 needed); kSequence resyncs at one
  // inside a sequence (0: no check); kTrigger ignores it.
  int64_t gap_ns = 5'000'000;

  // InvalidArgument naming the field.
  absl::Status Validate() const;
};

// Where one buffer goes.
struct Placement {
  std::optional<int> phase;  // its position 0..N-1 in the open sequence; none: discard it
  bool completes = false;    // with it the sequence is whole: emit phases 0..N-1 now
};

class SequenceAssembler {
 public:
  // `options` must pass Validate().
  explicit SequenceAssembler(const AssemblerOptions& options);

  // After STREAMON (again): the next buffer starts the count (kSequence) or may start a sequence
  // (kGap); an open sequence is dropped as abandoned.
  void Reset();

  // kTrigger: the caller has just started a sequence whose first frame the driver numbers
  // `first_sequence`. An open one is dropped as abandoned.
  void BeginSequence(uint32_t first_sequence);
  // kTrigger: every frame of the sequence last begun has come, or was counted lost, or the
  // sequence was abandoned: the caller may trigger the next.
  bool TriggerDone() const { return trigger_seen_ >= options_.phases; }
  // kTrigger: how many of its frames have come or were counted lost (0: none yet).
  int trigger_frames_seen() const { return trigger_seen_; }

  // The caller gives up the open sequence (a dequeue timeout); counted as abandoned.
  void Abandon();

  // Where `buffer` goes. A buffer that breaks the open sequence drops it (counted once) and is
  // itself discarded unless it can start the next one.
  Placement Add(const DequeuedBuffer& buffer);

  const AssemblerCounters& counters() const { return counters_; }
  const AssemblerOptions& options() const { return options_; }

 private:
  // Drops the open sequence (if any) for `reason`; its placed buffers count as discarded.
  void Drop(DropReason reason);
  Placement Discard();
  Placement Place(const DequeuedBuffer& buffer, int phase);
  Placement AddTriggered(const DequeuedBuffer& buffer, bool continuous);
  Placement AddCounted(const DequeuedBuffer& buffer, bool gap_before, bool continuous);
  Placement AddAfterPause(const DequeuedBuffer& buffer, bool gap_before, bool continuous);

  AssemblerOptions options_;
  AssemblerCounters counters_;
  int filled_ = 0;        // phases placed in the open sequence
  bool open_ = false;     // a sequence is open: its next phase is `filled_`
  bool synced_ = false;   // kSequence: first_sequence_ holds
  bool expect_pause_ = false;  // kGap: a sequence just completed; the next buffer needs a pause
  uint32_t first_sequence_ = 0;          // kSequence / kTrigger: the driver sequence of a phase 0
  int trigger_seen_ = 0;                 // kTrigger: frames of the last trigger come or lost
  std::optional<DequeuedBuffer> last_;   // the stream's previous buffer, whatever its fate
};

}  // namespace transient::v4l2
