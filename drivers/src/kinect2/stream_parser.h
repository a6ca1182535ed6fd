// The Kinect v2's isochronous depth stream taken apart into sub-frames, and sub-frames into
// depth frames. Pure: it works on the packets of completed iso transfers, not on libusb
// (../shared/research/libusb.md §1.3, §1.6, §7.5).
//
// The stream is framed by byte count: a sub-packet (kSubPacketBytes: a sub-image and its
// footer) arrives in iso packets of at most kIsoPacketBytes; its last packet is shorter, and
// zero-length packets fill the idle intervals between sub-frames. Each packet is given to Feed
// with its own data (the bytes at its own offset in the transfer, whatever happened to the
// packets before it: libfreenect2 skips a failed packet without advancing its offset, so every
// later packet of that transfer is read from the wrong place; taking each packet's own span
// makes that impossible). A failed packet loses the sub-packet it belongs to; the parser then
// waits for a packet shorter than kIsoPacketBytes (the end of a sub-packet, or an idle one)
// before it takes bytes again. A sub-packet is delivered only when exactly kSubPacketBytes came
// and its footer says length kSubImageBytes and a sub-frame 0..9.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "kinect2/kinect2_format.h"

namespace transient::kinect2 {

// One iso packet of a completed transfer: its actual bytes (at its own offset) and status
// (0 = completed; anything else = its data is lost).
struct IsoPacket {
  std::span<const uint8_t> data;
  int status = 0;
};

struct SubFrame {
  Footer footer;
  std::vector<uint8_t> payload;  // kSubImageBytes
  absl::Time arrival;            // when its last packet was parsed
};

// What the parser saw, for the source's counters.
struct StreamCounts {
  int64_t packets = 0;
  int64_t packet_errors = 0;        // packets with a failed status
  int64_t subframes = 0;            // delivered
  int64_t subpackets_lost = 0;      // cut by a failed packet (a failed idle packet between
                                    // sub-frames counts too: which it was cannot be told)
  int64_t subpackets_short = 0;     // ended (short or zero-length packet) before they were whole
  int64_t subpackets_too_long = 0;  // more bytes than a sub-packet before it ended
  int64_t bad_footers = 0;          // whole, but the footer's length or sub-frame was wrong
};

class StreamParser {
 public:
  using Emit = std::function<void(SubFrame&&)>;
  explicit StreamParser(Emit emit) : emit_(std::move(emit)) {}

  void Feed(const IsoPacket& packet, absl::Time now);
  // Forgets a partial sub-packet (a new stream: the next packet starts one).
  void Reset();
  const StreamCounts& counts() const { return counts_; }

 private:
  void Drop(int64_t* counter);

  Emit emit_;
  std::vector<uint8_t> buffer_ = std::vector<uint8_t>(kSubPacketBytes);
  size_t filled_ = 0;
  bool synced_ = true;  // the next packet starts a sub-packet
  StreamCounts counts_;
};

// Groups sub-frames by their footer's sequence into depth frames. A frame is complete when its
// correlation sub-frames 0..8 have all come; it is delivered then (sub-frame 9, undocumented,
// is counted and not used). A frame still incomplete when a sub-frame of another sequence
// arrives is dropped whole and counted, as is a sub-frame that comes twice.
struct AssemblerCounts {
  int64_t frames = 0;             // complete frames delivered
  int64_t frames_incomplete = 0;  // dropped: a sub-frame missing
  int64_t subframes_ninth = 0;    // sub-frame 9 seen (not used)
  int64_t subframes_stray = 0;    // of a frame already delivered or dropped, or a duplicate
};

class FrameAssembler {
 public:
  // The nine correlation sub-frames of one depth frame, in sub-frame order 0..8.
  using Emit = std::function<void(std::vector<SubFrame>&&)>;
  explicit FrameAssembler(Emit emit) : emit_(std::move(emit)) {}

  void Add(SubFrame&& subframe);
  void Reset();
  const AssemblerCounts& counts() const { return counts_; }

 private:
  Emit emit_;
  bool have_frame_ = false;
  uint32_t sequence_ = 0;        // of the frame being gathered
  std::vector<SubFrame> slots_;  // kCorrelationSubFrames; empty payload = not yet
  int have_ = 0;
  bool have_done_ = false;
  uint32_t done_sequence_ = 0;  // the last frame delivered or dropped
  AssemblerCounts counts_;
};

}  // namespace transient::kinect2
