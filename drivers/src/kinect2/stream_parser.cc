// The Kinect v2's depth stream into sub-frames and frames (stream_parser.h).
#include "kinect2/stream_parser.h"

#include <algorithm>
#include <cstring>

namespace transient::kinect2 {

void StreamParser::Reset() {
  filled_ = 0;
  synced_ = true;
}

void StreamParser::Drop(int64_t* counter) {
  if (filled_ > 0) ++*counter;
  filled_ = 0;
}

void StreamParser::Feed(const IsoPacket& packet, absl::Time now) {
  ++counts_.packets;
  const size_t length = packet.data.size();
  // A packet shorter than the largest ends a sub-packet, or is idle between two.
  const bool ends = length < kIsoPacketBytes;
  if (packet.status != 0) {
    ++counts_.packet_errors;
    // Its bytes are lost, and with them the sub-packet it was part of.
    if (filled_ > 0 || synced_) ++counts_.subpackets_lost;
    filled_ = 0;
    synced_ = false;
    return;
  }
  if (!synced_) {
    synced_ = ends;  // the rest of a lost sub-packet: skip to its end
    return;
  }
  if (length == 0) {
    Drop(&counts_.subpackets_short);
    return;
  }
  if (filled_ + length > kSubPacketBytes) {
    ++counts_.subpackets_too_long;
    filled_ = 0;
    synced_ = ends;  // where it ends, the next one starts
    return;
  }
  std::memcpy(buffer_.data() + filled_, packet.data.data(), length);
  filled_ += length;
  if (filled_ == kSubPacketBytes) {
    filled_ = 0;
    const Footer footer =
        ParseFooter(std::span<const uint8_t, kFooterBytes>(buffer_.data() + kSubImageBytes,
                                                           kFooterBytes));
    if (footer.length != kSubImageBytes || footer.subsequence >= kSubFrames) {
      ++counts_.bad_footers;
      return;
    }
    SubFrame subframe;
    subframe.footer = footer;
    subframe.payload.assign(buffer_.begin(), buffer_.begin() + kSubImageBytes);
    subframe.arrival = now;
    ++counts_.subframes;
    emit_(std::move(subframe));
    return;
  }
  if (ends) Drop(&counts_.subpackets_short);  // it ended before it was whole
}

void FrameAssembler::Reset() {
  have_frame_ = false;
  slots_.clear();
  have_ = 0;
}

void FrameAssembler::Add(SubFrame&& subframe) {
  const uint32_t sequence = subframe.footer.sequence;
  const uint32_t k = subframe.footer.subsequence;
  if (k >= static_cast<uint32_t>(kCorrelationSubFrames)) {
    ++counts_.subframes_ninth;
    return;
  }
  // Late: of a frame already delivered or dropped, or older (sequences compared modulo 2^32).
  if (have_done_ && static_cast<int32_t>(sequence - done_sequence_) <= 0) {
    ++counts_.subframes_stray;
    return;
  }
  if (have_frame_ && sequence != sequence_) {
    ++counts_.frames_incomplete;  // a sub-frame of it never came
    have_done_ = true;
    done_sequence_ = sequence_;
    Reset();
  }
  if (!have_frame_) {
    have_frame_ = true;
    sequence_ = sequence;
    slots_.assign(kCorrelationSubFrames, SubFrame{});
    have_ = 0;
  }
  SubFrame& slot = slots_[k];
  if (!slot.payload.empty()) {
    ++counts_.subframes_stray;  // twice: which one is right cannot be told; drop the frame
    ++counts_.frames_incomplete;
    have_done_ = true;
    done_sequence_ = sequence_;
    Reset();
    return;
  }
  slot = std::move(subframe);
  if (++have_ < kCorrelationSubFrames) return;
  ++counts_.frames;
  have_done_ = true;
  done_sequence_ = sequence_;
  std::vector<SubFrame> frame = std::move(slots_);
  Reset();
  emit_(std::move(frame));
}

}  // namespace transient::kinect2
