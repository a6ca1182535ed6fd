// Assembly of capture cycles from a stream of raw frames.
#include "transient/reconstruct/cycle_assembler.h"

#include <string>
#include <utility>

#include "absl/strings/str_cat.h"

namespace transient {
namespace {

// Beyond a few, a list of missing exposures stops helping; the count says the rest.
constexpr int kMaxListedExposures = 4;


}  // namespace

absl::StatusOr<CycleAssembler> CycleAssembler::Create(const AcquisitionSchedule& schedule,
                                                      ImageGeometry geometry) {
  if (geometry.width <= 0 || geometry.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("geometry ", geometry.width, "x",
                                                   geometry.height,
                                                   ". Violated constraint: width, height > 0"));
  }
  return CycleAssembler(schedule, geometry);
}

CycleAssembler::CycleAssembler(const AcquisitionSchedule& schedule, ImageGeometry geometry)
    : schedule_(schedule),
      geometry_(geometry),
      slots_(static_cast<size_t>(schedule.raw_frames_per_frame())) {}

void CycleAssembler::DropCurrent() {
  if (received_ > 0) {
    dropped_frames_ += received_;
    ++dropped_cycles_;
  }
  for (std::optional<RawFrame>& slot : slots_) slot.reset();
  received_ = 0;
  ready_ = false;
  current_cycle_.reset();
}

void CycleAssembler::Reset() { DropCurrent(); }

absl::StatusOr<bool> CycleAssembler::Add(RawFrame frame) {
  auto refuse = [this](absl::Status status) {
    ++dropped_frames_;
    return status;
  };
  if (ready_) {
    return refuse(absl::FailedPreconditionError(
        absl::StrCat(DescribeFrame(frame.config), " dropped: cycle ", *current_cycle_,
                     " is complete and waiting; call TakeCycle() before adding frames")));
  }
  if (frame.geometry != geometry_) {
    return refuse(absl::InvalidArgumentError(absl::StrCat(
        DescribeFrame(frame.config), " has geometry ", frame.geometry.width, "x", frame.geometry.height,
        "; expected ", geometry_.width, "x", geometry_.height)));
  }
  if (static_cast<int64_t>(frame.pixels.size()) != geometry_.pixel_count()) {
    return refuse(absl::InvalidArgumentError(absl::StrCat(
        DescribeFrame(frame.config), " holds ", frame.pixels.size(),
        " pixels. Violated constraint: pixels == width*height = ", geometry_.pixel_count())));
  }
  absl::StatusOr<int> index = schedule_.IndexOf(frame.config);
  if (!index.ok()) return refuse(index.status());
  const int64_t cycle = frame.config.cycle;
  const int64_t oldest_allowed = current_cycle_.has_value()
                                     ? *current_cycle_
                                     : (have_completed_ ? last_completed_cycle_ + 1 : cycle);
  if (cycle < oldest_allowed) {
    return refuse(absl::InvalidArgumentError(absl::StrCat(
        DescribeFrame(frame.config), " is late: cycle ", cycle, " is older than cycle ", oldest_allowed,
        current_cycle_.has_value() ? " being assembled" : " expected next")));
  }

  absl::Status lost = absl::OkStatus();
  if (current_cycle_.has_value() && cycle > *current_cycle_) {
    std::string message =
        absl::StrCat(DescribeFrame(frame.config), " starts a new cycle while cycle ", *current_cycle_,
                     " lacks ", slots_.size() - static_cast<size_t>(received_), " of ",
                     slots_.size(), " exposures; dropped it. Missing: ");
    int listed = 0;
    for (size_t i = 0; i < slots_.size(); ++i) {
      if (slots_[i].has_value()) continue;
      if (listed < kMaxListedExposures) {
        absl::StrAppend(&message, listed == 0 ? "" : "; ",
                        DescribeExposure(schedule_.exposures()[i]));
      }
      ++listed;
    }
    if (listed > kMaxListedExposures) {
      absl::StrAppend(&message, "; and ", listed - kMaxListedExposures, " more");
    }
    lost = absl::DataLossError(message);
    DropCurrent();
  }

  std::optional<RawFrame>& slot = slots_[static_cast<size_t>(*index)];
  if (slot.has_value()) {
    return refuse(absl::InvalidArgumentError(absl::StrCat(DescribeFrame(frame.config), " duplicates frame ",
                                                          slot->config.sequence,
                                                          " of the same exposure; dropped it")));
  }
  current_cycle_ = cycle;
  slot = std::move(frame);
  ++received_;
  ready_ = received_ == static_cast<int>(slots_.size());
  if (!lost.ok()) return lost;  // a cycle has at least four exposures: this one is not complete
  return ready_;
}

std::vector<RawFrame> CycleAssembler::TakeCycle() {
  std::vector<RawFrame> frames;
  if (!ready_) return frames;
  frames.reserve(slots_.size());
  for (std::optional<RawFrame>& slot : slots_) {
    frames.push_back(std::move(*slot));
    slot.reset();
  }
  last_completed_cycle_ = *current_cycle_;
  have_completed_ = true;
  received_ = 0;
  ready_ = false;
  current_cycle_.reset();
  return frames;
}

}  // namespace transient
