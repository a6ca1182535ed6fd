// The emulated V4L2 ToF sensor's kernel side (emulated_tof_sensor.h).
#include "tests/drivers/v4l2/emulated_tof_sensor.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <umockdev.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cerrno>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <utility>
#include <stdexcept>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "v4l2/frame_unpacker.h"

namespace transient::v4l2::testing {

struct EmulatedTofSensor::State {
  UMockdevTestbed* testbed = nullptr;
  struct Node {
    EmulatedNode behaviour;
    UMockdevIoctlBase* handler = nullptr;
    std::string file;  // the regular file behind /dev/<name>, which holds the buffers
    bool unplugged = false;
    uint32_t fourcc = 0;
    size_t bytes_per_line = 0, image_bytes = 0;
    int buffers = 0;
    size_t buffer_stride = 0;  // page-aligned
    std::deque<int> queued;    // buffer indices in QBUF order
    bool streaming = false;
    std::deque<EmulatedFrame> frames;
    uint32_t next_sequence = 0;
    std::map<uint32_t, std::vector<int64_t>> values;  // current control values
    std::vector<SequenceFault> faults;
    int64_t sequences_started = 0;
    int64_t clock_ns = 1'000'000'000;
    uint32_t frames_lost_pending = 0;
    State* owner = nullptr;
    std::vector<uint32_t> subscribed;    // V4L2_EVENT_CTRL subscriptions (one file handle)
    std::deque<std::pair<uint32_t, int64_t>> pending_events;  // (control, new value)
    // realtime: when and with which timestamp the previous frame was delivered.
    std::optional<std::pair<int64_t, int64_t>> last_delivery;
  };
  // The handler runs on umockdev's thread, the test on its own: one lock for all nodes (a
  // trigger on a subdevice starts frames on its video node).
  std::mutex mutex;
  std::vector<std::unique_ptr<Node>> nodes;

  Node& Find(const std::string& name) {
    for (auto& node : nodes) {
      if (node->behaviour.name == name) return *node;
    }
    throw std::runtime_error(absl::StrCat("no emulated node ", name));
  }
  // The node holding `node`'s controls.
  Node& ControlsOf(Node& node) {
    return node.behaviour.controls_on.empty() ? node : Find(node.behaviour.controls_on);
  }
  // The node whose frames `node`'s controls program.
  Node& FramesOf(Node& node) {
    for (auto& other : nodes) {
      if (other->behaviour.controls_on == node.behaviour.name) return *other;
    }
    return node;
  }
};

namespace {


template <size_t N>
void CopyText(uint8_t (&field)[N], const std::string& text) {
  std::memset(field, 0, N);
  std::memcpy(field, text.data(), std::min(text.size(), N - 1));
}
template <size_t N>
void CopyText(char (&field)[N], const std::string& text) {
  std::memset(field, 0, N);
  std::memcpy(field, text.data(), std::min(text.size(), N - 1));
}

// The caller's struct at the ioctl's argument, read in and written back on completion.
template <typename T>
T* Argument(UMockdevIoctlClient* client) {
  GError* error = nullptr;
  UMockdevIoctlData* data =
      umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(client), 0, sizeof(T), &error);
  if (data == nullptr) {
    if (error != nullptr) g_error_free(error);
    return nullptr;
  }
  return reinterpret_cast<T*>(data->data);
}

void Complete(UMockdevIoctlClient* client, int error) {
  umockdev_ioctl_client_complete(client, error == 0 ? 0 : -1, error);
}

using State = EmulatedTofSensor::State;
using NodeState = EmulatedTofSensor::State::Node;

constexpr const char* kPhaseSequenceName = kTofPhaseSequence.name;
constexpr const char* kFrequencyName = kTofFrequencyModulation.name;
constexpr const char* kIntegrationName = kTofTimeIntegration.name;

const ControlDescription* ControlById(const NodeState& node, uint32_t id) {
  for (const ControlDescription& control : node.behaviour.controls) {
    if (control.id == id) return &control;
  }
  return nullptr;
}

const ControlDescription* ControlByName(const NodeState& node, const std::string& name) {
  for (const ControlDescription& control : node.behaviour.controls) {
    if (control.name == name) return &control;
  }
  return nullptr;
}

std::vector<int64_t> ValueOf(const NodeState& node, const std::string& name) {
  const ControlDescription* control = ControlByName(node, name);
  if (control == nullptr) return {};
  auto it = node.values.find(control->id);
  return it == node.values.end() ? std::vector<int64_t>{} : it->second;
}

size_t ElementBytes(uint32_t type) {
  if (type == V4L2_CTRL_TYPE_U8) return 1;
  if (type == V4L2_CTRL_TYPE_U16) return 2;
  if (type == V4L2_CTRL_TYPE_U32) return 4;
  return 0;
}

// The V4L2 core's ROUND_TO_RANGE for integer elements: clamped to the range, rounded to the
// nearest step from the minimum (half a step up).
int64_t RoundToRange(const ControlDescription& control, int64_t value) {
  const auto step = static_cast<int64_t>(std::max<uint64_t>(control.step, 1));
  if (value >= control.maximum - step / 2) {
    value = control.maximum;
  } else {
    value += step / 2;
  }
  value = std::clamp(value, control.minimum, control.maximum);
  return control.minimum + (value - control.minimum) / step * step;
}

std::vector<int64_t> DefaultValue(const ControlDescription& control) {
  if (control.type == V4L2_CTRL_TYPE_BUTTON) return {};
  const size_t count = control.dynamic_array() ? 1 : std::max<uint32_t>(control.elements, 1);
  return std::vector<int64_t>(count, control.default_value);
}

template <typename T>
T LoadElement(const uint8_t* at) {
  T value;
  std::memcpy(&value, at, sizeof(T));
  return value;
}

int64_t TriggerMode(NodeState& controls) {
  const ControlDescription* mode = ControlById(controls, kCameraTriggerMode.id);
  if (mode == nullptr) mode = ControlByName(controls, kCameraTriggerMode.name);
  if (mode == nullptr) return 0;
  return controls.values[mode->id].empty() ? 0 : controls.values[mode->id][0];
}

// Another program set control `id` of `node`: its value, and an event where one is subscribed
// (the kernel tells every other file handle that subscribed, research §2.5).
void ChangedBySomeoneElse(NodeState& node, uint32_t id, std::vector<int64_t> values) {
  if (std::find(node.subscribed.begin(), node.subscribed.end(), id) != node.subscribed.end()) {
    node.pending_events.emplace_back(id, values.empty() ? 0 : values[0]);
  }
  node.values[id] = std::move(values);
}

// Starts a sequence on `video` with the current values of `controls`: renders its frames (or
// what the sequence's fault makes of them) into the delivery queue.
void StartSequence(NodeState& video, NodeState& controls) {
  ProgrammedSequence program;
  program.index = video.sequences_started++;
  const std::vector<int64_t> frequency = ValueOf(controls, kFrequencyName);
  program.frequency_hz = frequency.empty() ? 0.0 : static_cast<double>(frequency[0]);
  program.phases_deg = ValueOf(controls, kPhaseSequenceName);
  program.integration_us = ValueOf(controls, kIntegrationName);
  std::vector<SequenceFault> faults;
  for (const SequenceFault& fault : video.faults) {
    if (fault.sequence == program.index) faults.push_back(fault);
  }
  for (const SequenceFault& fault : faults) {
    if (fault.kind == SequenceFault::kStall) return;
    if (fault.kind == SequenceFault::kUnplug) {
      video.unplugged = controls.unplugged = true;
      return;
    }
  }
  const ImageGeometry geometry = video.behaviour.sensor;
  const std::vector<std::vector<int32_t>> samples = video.behaviour.renderer(program, geometry);
  video.clock_ns += video.behaviour.idle_ns;
  for (size_t k = 0; k < samples.size(); ++k) {
    video.clock_ns += video.behaviour.frame_ns;
    EmulatedFrame frame;
    frame.bytes = PackSamples(video.fourcc, geometry, video.bytes_per_line,
                              video.behaviour.sample_bits, samples[k]);
    frame.bytes.resize(video.image_bytes, 0);
    frame.timestamp_ns = video.clock_ns;
    bool lost = false;
    for (const SequenceFault& fault : faults) {
      if (fault.frame != static_cast<int>(k)) continue;
      if (fault.kind == SequenceFault::kErrorFlag) frame.error_flag = true;
      if (fault.kind == SequenceFault::kShortFrame) frame.bytes.resize(frame.bytes.size() / 2);
      if (fault.kind == SequenceFault::kLostFrame) lost = true;
    }
    if (lost) {
      ++video.frames_lost_pending;
      continue;
    }
    frame.frames_lost_before = std::exchange(video.frames_lost_pending, 0);
    video.frames.push_back(std::move(frame));
  }
  for (const SequenceFault& fault : faults) {
    if (fault.kind != SequenceFault::kControlChanged) continue;
    if (const ControlDescription* f = ControlByName(controls, kFrequencyName)) {
      ChangedBySomeoneElse(controls, f->id, {fault.value});
    }
  }
}

// VIDIOC_G_EXT_CTRLS / VIDIOC_S_EXT_CTRLS as the V4L2 core answers them.
int AnswerControls(State& state, NodeState& node, unsigned long request,
                   UMockdevIoctlClient* client) {
  GError* error = nullptr;
  UMockdevIoctlData* header_data = umockdev_ioctl_data_resolve(
      umockdev_ioctl_client_get_arg(client), 0, sizeof(v4l2_ext_controls), &error);
  if (header_data == nullptr) {
    if (error != nullptr) g_error_free(error);
    return EFAULT;
  }
  auto* header = reinterpret_cast<v4l2_ext_controls*>(header_data->data);
  if (header->which != V4L2_CTRL_WHICH_CUR_VAL) return EINVAL;
  const uint32_t count = header->count;
  header->error_idx = count;
  if (count == 0) return 0;
  UMockdevIoctlData* array_data =
      umockdev_ioctl_data_resolve(header_data, offsetof(v4l2_ext_controls, controls),
                                  count * sizeof(v4l2_ext_control), &error);
  if (array_data == nullptr) {
    if (error != nullptr) g_error_free(error);
    return EFAULT;
  }
  auto* controls = reinterpret_cast<v4l2_ext_control*>(array_data->data);
  // Validate everything first: the core applies all controls or none.
  std::vector<std::pair<const ControlDescription*, std::vector<int64_t>>> staged;
  for (uint32_t i = 0; i < count; ++i) {
    v4l2_ext_control& c = controls[i];
    const ControlDescription* description = ControlById(node, c.id);
    header->error_idx = i;
    if (description == nullptr) return EINVAL;
    const size_t element_bytes = ElementBytes(description->type);
    const size_t capacity = std::max<uint32_t>(description->elements, 1);
    uint8_t* payload = nullptr;
    if (element_bytes > 0) {
      if (c.size == 0) return EINVAL;
      UMockdevIoctlData* payload_data = umockdev_ioctl_data_resolve(
          array_data, i * sizeof(v4l2_ext_control) + offsetof(v4l2_ext_control, ptr), c.size,
          &error);
      if (payload_data == nullptr) {
        if (error != nullptr) g_error_free(error);
        return EFAULT;
      }
      payload = payload_data->data;
    }
    if (request == VIDIOC_G_EXT_CTRLS) {
      if (description->type == V4L2_CTRL_TYPE_BUTTON) return EACCES;  // write-only
      const std::vector<int64_t>& value = node.values[description->id];
      if (element_bytes == 0) {
        c.value = value.empty() ? 0 : static_cast<int32_t>(value[0]);
        continue;
      }
      const size_t needed = value.size() * element_bytes;
      if (c.size < needed) {
        c.size = static_cast<uint32_t>(needed);
        return ENOSPC;
      }
      for (size_t e = 0; e < value.size(); ++e) {
        if (element_bytes == 2) {
          const auto v = static_cast<uint16_t>(value[e]);
          std::memcpy(payload + e * 2, &v, 2);
        } else if (element_bytes == 4) {
          const auto v = static_cast<uint32_t>(value[e]);
          std::memcpy(payload + e * 4, &v, 4);
        } else {
          payload[e] = static_cast<uint8_t>(value[e]);
        }
      }
      c.size = static_cast<uint32_t>(needed);
      continue;
    }
    if (description->id == node.behaviour.refuse_control) return EINVAL;
    std::vector<int64_t> value;
    if (element_bytes == 0) {
      if (description->type == V4L2_CTRL_TYPE_MENU &&
          (c.value < description->minimum || c.value > description->maximum)) {
        return EINVAL;
      }
      if (description->type != V4L2_CTRL_TYPE_BUTTON) {
        value.push_back(description->type == V4L2_CTRL_TYPE_INTEGER
                            ? RoundToRange(*description, c.value)
                            : c.value);
      }
    } else {
      if (c.size % element_bytes != 0) return EINVAL;
      const size_t elements = c.size / element_bytes;
      if (description->dynamic_array() ? elements > capacity : elements != capacity) {
        return EINVAL;
      }
      for (size_t e = 0; e < elements; ++e) {
        const uint8_t* at = payload + e * element_bytes;
        const int64_t raw = element_bytes == 2   ? LoadElement<uint16_t>(at)
                            : element_bytes == 4 ? LoadElement<uint32_t>(at)
                                                 : *at;
        value.push_back(RoundToRange(*description, raw));
      }
    }
    if (description->type == V4L2_CTRL_TYPE_BUTTON &&
        (description->id == kCameraTrigger.id || description->name == kCameraTrigger.name) &&
        TriggerMode(node) != 1) {
      return EBUSY;  // the driver grabs the button unless the trigger mode is internal
    }
    staged.emplace_back(description, std::move(value));
  }
  header->error_idx = count;
  if (request == VIDIOC_G_EXT_CTRLS) return 0;
  for (auto& [description, value] : staged) {
    if (description->type == V4L2_CTRL_TYPE_BUTTON) {
      NodeState& video = state.FramesOf(node);
      if (video.streaming && video.behaviour.renderer) StartSequence(video, node);
      continue;
    }
    node.values[description->id] = std::move(value);
  }
  return 0;
}

// The streaming ioctls, as the V4L2 API documentation describes a driver's side.
int AnswerStreaming(State& sensor, NodeState& state, unsigned long request,
                    UMockdevIoctlClient* client) {
  const EmulatedNode& node = state.behaviour;
  if (request == VIDIOC_S_FMT) {
    auto* format = Argument<v4l2_format>(client);
    if (format == nullptr) return EFAULT;
    if (format->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return EINVAL;
    if (state.streaming || state.buffers > 0) return EBUSY;
    v4l2_pix_format& pix = format->fmt.pix;
    // A driver adjusts what it cannot do: to its first format and its one size.
    bool known = false;
    for (const EmulatedFormat& f : node.formats) known = known || f.fourcc == pix.pixelformat;
    if (!known && !node.formats.empty()) pix.pixelformat = node.formats[0].fourcc;
    pix.width = static_cast<uint32_t>(node.sensor.width);
    pix.height = static_cast<uint32_t>(node.sensor.height);
    pix.field = V4L2_FIELD_NONE;
    const absl::StatusOr<size_t> row = RowBytes(pix.pixelformat, node.sensor.width);
    const size_t row_bytes = row.ok() ? *row : 2 * static_cast<size_t>(node.sensor.width);
    pix.bytesperline = static_cast<uint32_t>(row_bytes + node.row_padding);
    pix.sizeimage = pix.bytesperline * pix.height;
    state.fourcc = pix.pixelformat;
    state.bytes_per_line = pix.bytesperline;
    state.image_bytes = pix.sizeimage;
    return 0;
  }
  if (request == VIDIOC_REQBUFS) {
    auto* request_buffers = Argument<v4l2_requestbuffers>(client);
    if (request_buffers == nullptr) return EFAULT;
    if (request_buffers->memory != V4L2_MEMORY_MMAP) return EINVAL;
    if (state.streaming) return EBUSY;
    if (state.image_bytes == 0 && request_buffers->count > 0) return EINVAL;
    const int count = std::min(static_cast<int>(request_buffers->count), node.max_buffers);
    const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
    state.buffer_stride = (state.image_bytes + page - 1) / page * page;
    state.buffers = count;
    state.queued.clear();
    if (truncate(state.file.c_str(), static_cast<off_t>(state.buffer_stride * std::max(count, 1))) != 0) {
      return EIO;
    }
    request_buffers->count = static_cast<uint32_t>(count);
    return 0;
  }
  if (request == VIDIOC_QUERYBUF || request == VIDIOC_QBUF) {
    auto* buffer = Argument<v4l2_buffer>(client);
    if (buffer == nullptr) return EFAULT;
    if (buffer->index >= static_cast<uint32_t>(state.buffers)) return EINVAL;
    if (request == VIDIOC_QBUF) {
      for (int queued : state.queued) {
        if (queued == static_cast<int>(buffer->index)) return EINVAL;  // queued twice
      }
      state.queued.push_back(static_cast<int>(buffer->index));
    }
    buffer->length = static_cast<uint32_t>(state.image_bytes);
    buffer->m.offset = static_cast<uint32_t>(buffer->index * state.buffer_stride);
    buffer->flags = V4L2_BUF_FLAG_MAPPED | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
    return 0;
  }
  if (request == VIDIOC_STREAMON || request == VIDIOC_STREAMOFF) {
    if (state.buffers == 0) return EINVAL;
    state.streaming = request == VIDIOC_STREAMON;
    if (state.streaming) {
      state.next_sequence = 0;  // drivers count from 0 at each start
      state.frames_lost_pending = 0;
    }
    if (!state.streaming) state.queued.clear();
    return 0;
  }
  if (request == VIDIOC_DQBUF) {
    auto* buffer = Argument<v4l2_buffer>(client);
    if (buffer == nullptr) return EFAULT;
    if (!state.streaming) return EINVAL;
    if (state.frames.empty() && state.behaviour.renderer && !state.queued.empty()) {
      // Continuous mode: the sensor takes one sequence after another.
      NodeState& controls = sensor.ControlsOf(state);
      if (TriggerMode(controls) == 0) StartSequence(state, controls);
      if (state.unplugged) return ENODEV;
    }
    if (state.queued.empty() || state.frames.empty()) return EAGAIN;
    if (state.behaviour.realtime && state.last_delivery.has_value()) {
      const int64_t now = absl::ToUnixNanos(absl::Now());
      const auto [wall, timestamp] = *state.last_delivery;
      if (now - wall < state.frames.front().timestamp_ns - timestamp) return EAGAIN;
    }
    const int index = state.queued.front();
    state.queued.pop_front();
    EmulatedFrame frame = std::move(state.frames.front());
    state.frames.pop_front();
    state.last_delivery.emplace(absl::ToUnixNanos(absl::Now()), frame.timestamp_ns);
    const size_t length = std::min(frame.bytes.size(), state.image_bytes);
    const int fd = open(state.file.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd < 0) return EIO;
    const ssize_t written = pwrite(fd, frame.bytes.data(), length,
                                   static_cast<off_t>(static_cast<size_t>(index) * state.buffer_stride));
    close(fd);
    if (written != static_cast<ssize_t>(length)) return EIO;
    state.next_sequence += frame.frames_lost_before;
    *buffer = {};
    buffer->index = static_cast<uint32_t>(index);
    buffer->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer->memory = V4L2_MEMORY_MMAP;
    buffer->bytesused = static_cast<uint32_t>(length);
    buffer->flags = V4L2_BUF_FLAG_MAPPED | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC |
                    (frame.error_flag ? V4L2_BUF_FLAG_ERROR : 0);
    buffer->field = V4L2_FIELD_NONE;
    buffer->sequence = state.next_sequence++;
    buffer->timestamp.tv_sec = frame.timestamp_ns / 1'000'000'000;
    buffer->timestamp.tv_usec = (frame.timestamp_ns % 1'000'000'000) / 1000;
    buffer->length = static_cast<uint32_t>(state.image_bytes);
    buffer->m.offset = static_cast<uint32_t>(static_cast<size_t>(index) * state.buffer_stride);
    return 0;
  }
  return ENOTTY;
}

// The kernel's answers, as linux/videodev2.h and the V4L2 API documentation give them.
int Answer(State& sensor, NodeState& state, UMockdevIoctlClient* client) {
  std::lock_guard<std::mutex> lock(sensor.mutex);
  if (state.unplugged) return ENODEV;
  const EmulatedNode& node = state.behaviour;
  const unsigned long request = umockdev_ioctl_client_get_request(client);
  if (request == VIDIOC_QUERYCAP) {
    if (node.querycap_errno != 0) return node.querycap_errno;
    auto* cap = Argument<v4l2_capability>(client);
    if (cap == nullptr) return EFAULT;
    *cap = {};
    CopyText(cap->driver, node.driver);
    CopyText(cap->card, node.card);
    CopyText(cap->bus_info, node.bus_info);
    cap->version = 0x060100;
    cap->device_caps = node.device_caps;
    cap->capabilities = node.device_caps | V4L2_CAP_DEVICE_CAPS;
    return 0;
  }
  if (request == VIDIOC_ENUM_FMT) {
    auto* description = Argument<v4l2_fmtdesc>(client);
    if (description == nullptr) return EFAULT;
    if (description->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return EINVAL;
    if (description->index >= node.formats.size()) return EINVAL;
    const EmulatedFormat& format = node.formats[description->index];
    description->flags = 0;
    description->pixelformat = format.fourcc;
    CopyText(description->description, format.description);
    return 0;
  }
  if (request == VIDIOC_QUERY_EXT_CTRL) {
    auto* query = Argument<v4l2_query_ext_ctrl>(client);
    if (query == nullptr) return EFAULT;
    const uint32_t next_flags = V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;
    const bool next = (query->id & next_flags) != 0;
    const uint32_t id = query->id & ~next_flags;
    const ControlDescription* found = nullptr;
    for (const ControlDescription& control : node.controls) {
      if (next ? control.id > id : control.id == id) {
        found = &control;
        break;
      }
    }
    if (found == nullptr) return EINVAL;
    *query = {};
    query->id = found->id;
    query->type = found->type;
    CopyText(query->name, found->name);
    query->minimum = found->minimum;
    query->maximum = found->maximum;
    query->step = found->step;
    query->default_value = found->default_value;
    query->flags = found->flags;
    const bool array = found->elements > 1 || found->dynamic_array();
    query->elem_size = found->type == V4L2_CTRL_TYPE_U16 ? 2 : 4;
    query->elems = found->elements;
    query->nr_of_dims = array ? 1 : 0;
    query->dims[0] = array ? found->elements : 0;
    return 0;
  }
  if (request == VIDIOC_SUBSCRIBE_EVENT) {
    auto* subscription = Argument<v4l2_event_subscription>(client);
    if (subscription == nullptr) return EFAULT;
    if (!node.events) return ENOTTY;
    if (subscription->type != V4L2_EVENT_CTRL || ControlById(state, subscription->id) == nullptr) {
      return EINVAL;
    }
    state.subscribed.push_back(subscription->id);
    return 0;
  }
  if (request == VIDIOC_DQEVENT) {
    auto* event = Argument<v4l2_event>(client);
    if (event == nullptr) return EFAULT;
    if (state.pending_events.empty()) return ENOENT;
    const auto [id, value] = state.pending_events.front();
    state.pending_events.pop_front();
    *event = {};
    event->type = V4L2_EVENT_CTRL;
    event->id = id;
    event->u.ctrl.changes = V4L2_EVENT_CTRL_CH_VALUE;
    event->u.ctrl.value = static_cast<int32_t>(value);
    event->pending = static_cast<uint32_t>(state.pending_events.size());
    return 0;
  }
  if (request == VIDIOC_G_EXT_CTRLS || request == VIDIOC_S_EXT_CTRLS) {
    return AnswerControls(sensor, state, request, client);
  }
  // What the kernel says to an ioctl the driver does not know: ENOTTY.
  return AnswerStreaming(sensor, state, request, client);
}

gboolean HandleIoctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer data) {
  auto* node = static_cast<NodeState*>(data);
  Complete(client, Answer(*node->owner, *node, client));
  return TRUE;
}

}  // namespace

std::vector<ControlDescription> Mlx7502xControls(uint32_t tof_base) {
  std::vector<ControlDescription> controls = {
      {.id = 0x00981ad0, .name = "Output Mode", .type = V4L2_CTRL_TYPE_MENU, .minimum = 0,
       .maximum = 4, .step = 1},
      {.id = kCameraTrigger.id, .name = kCameraTrigger.name, .type = kCameraTrigger.type},
      {.id = kCameraTriggerMode.id, .name = kCameraTriggerMode.name, .type = kCameraTriggerMode.type,
       .minimum = 0, .maximum = 2, .step = 1},
      {.id = tof_base, .name = kPhaseSequenceName, .type = V4L2_CTRL_TYPE_U16, .minimum = 0,
       .maximum = 315, .step = 45, .elements = 8, .flags = V4L2_CTRL_FLAG_DYNAMIC_ARRAY},
      {.id = tof_base + 1, .name = kFrequencyName, .type = V4L2_CTRL_TYPE_U32,
       .minimum = 4'000'000, .maximum = 100'000'000, .default_value = 40'000'000,
       .step = 1'000'000, .elements = 1, .flags = V4L2_CTRL_FLAG_DYNAMIC_ARRAY},
      {.id = tof_base + 2, .name = kIntegrationName, .type = V4L2_CTRL_TYPE_U16, .minimum = 5,
       .maximum = 1000, .default_value = 198, .step = 1, .elements = 8,
       .flags = V4L2_CTRL_FLAG_DYNAMIC_ARRAY},
  };
  // VIDIOC_QUERY_EXT_CTRL enumerates in ascending IDs.
  std::sort(controls.begin(), controls.end(),
            [](const ControlDescription& a, const ControlDescription& b) { return a.id < b.id; });
  return controls;
}

std::vector<uint8_t> PackSamples(uint32_t fourcc, ImageGeometry geometry, size_t bytes_per_line,
                                 int bits, const std::vector<int32_t>& samples) {
  std::vector<uint8_t> bytes(bytes_per_line * static_cast<size_t>(geometry.height), 0);
  const uint32_t mask = bits >= 32 ? 0xffffffffu : (1u << bits) - 1u;
  const bool raw12 = fourcc == kFourccY12P || fourcc == kFourccSBGGR12P;
  for (int y = 0; y < geometry.height; ++y) {
    uint8_t* row = bytes.data() + static_cast<size_t>(y) * bytes_per_line;
    for (int x = 0; x < geometry.width; ++x) {
      const uint32_t code =
          static_cast<uint32_t>(samples[static_cast<size_t>(y) * geometry.width + x]) & mask;
      if (raw12) {
        // Two pixels in three bytes: their high 8 bits, then both low nibbles (P1 high).
        uint8_t* pair = row + static_cast<size_t>(x / 2) * 3;
        pair[x % 2] = static_cast<uint8_t>(code >> 4);
        pair[2] = static_cast<uint8_t>(x % 2 == 0 ? (pair[2] & 0xf0) | (code & 0x0f)
                                                  : (pair[2] & 0x0f) | ((code & 0x0f) << 4));
      } else {
        row[2 * x] = static_cast<uint8_t>(code & 0xff);
        row[2 * x + 1] = static_cast<uint8_t>(code >> 8);
      }
    }
  }
  return bytes;
}

EmulatedTofSensor::EmulatedTofSensor() : state_(std::make_unique<State>()) {
  state_->testbed = umockdev_testbed_new();
}

EmulatedTofSensor::~EmulatedTofSensor() {
  for (auto& node : state_->nodes) {
    umockdev_testbed_detach_ioctl(state_->testbed,
                                  absl::StrCat("/dev/", node->behaviour.name).c_str(), nullptr);
    g_object_unref(node->handler);
  }
  g_object_unref(state_->testbed);
}

bool EmulatedTofSensor::Available() { return umockdev_in_mock_environment(); }

void EmulatedTofSensor::AddNode(const EmulatedNode& behaviour) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  auto node = std::make_unique<State::Node>();
  node->behaviour = behaviour;
  node->owner = state_.get();
  for (const ControlDescription& control : behaviour.controls) {
    node->values[control.id] = DefaultValue(control);
  }
  const int minor = static_cast<int>(state_->nodes.size());
  // A regular file behind the node (its content would hold mmap'd buffers), 81:N to stat.
  const std::string description = absl::StrCat(
      "P: /devices/platform/emulated-tof/video4linux/", behaviour.name, "\nN: ", behaviour.name,
      "=00000000\nE: SUBSYSTEM=video4linux\nE: DEVNAME=/dev/", behaviour.name, "\nA: dev=81:",
      minor, "\n");
  GError* error = nullptr;
  if (!umockdev_testbed_add_from_string(state_->testbed, description.c_str(), &error)) {
    const std::string message = error != nullptr ? error->message : "unknown error";
    if (error != nullptr) g_error_free(error);
    throw std::runtime_error(absl::StrCat("umockdev: cannot add ", behaviour.name, ": ", message));
  }
  gchar* root = umockdev_testbed_get_root_dir(state_->testbed);
  node->file = absl::StrCat(root, "/dev/", behaviour.name);
  g_free(root);
  node->handler = umockdev_ioctl_base_new();
  g_signal_connect(node->handler, "handle-ioctl", G_CALLBACK(HandleIoctl), node.get());
  if (!umockdev_testbed_attach_ioctl(state_->testbed,
                                     absl::StrCat("/dev/", behaviour.name).c_str(), node->handler,
                                     &error)) {
    const std::string message = error != nullptr ? error->message : "unknown error";
    if (error != nullptr) g_error_free(error);
    throw std::runtime_error(
        absl::StrCat("umockdev: cannot attach ioctls to ", behaviour.name, ": ", message));
  }
  state_->nodes.push_back(std::move(node));
}

void EmulatedTofSensor::PushFrame(const std::string& name, EmulatedFrame frame) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  state_->Find(name).frames.push_back(std::move(frame));
}

void EmulatedTofSensor::InjectFault(const std::string& name, SequenceFault fault) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  state_->Find(name).faults.push_back(fault);
}

void EmulatedTofSensor::Unplug(const std::string& name) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  State::Node& node = state_->Find(name);
  node.unplugged = true;
  state_->ControlsOf(node).unplugged = true;
}

void EmulatedTofSensor::Replug(const std::string& name) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  State::Node& node = state_->Find(name);
  for (State::Node* n : {&node, &state_->ControlsOf(node)}) {
    n->unplugged = false;
    n->streaming = false;
    n->buffers = 0;
    n->queued.clear();
    n->frames.clear();
    n->image_bytes = n->bytes_per_line = 0;
    n->fourcc = 0;
  }
}

void EmulatedTofSensor::SetControl(const std::string& name, uint32_t id,
                                   std::vector<int64_t> values) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  ChangedBySomeoneElse(state_->Find(name), id, std::move(values));
}

std::vector<int64_t> EmulatedTofSensor::Control(const std::string& name, uint32_t id) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->Find(name).values[id];
}

int64_t EmulatedTofSensor::SequencesStarted(const std::string& name) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->Find(name).sequences_started;
}

}  // namespace transient::v4l2::testing
