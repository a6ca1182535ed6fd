// The emulated V4L2 ToF sensor's kernel side (emulated_tof_sensor.h).
#include "tests/drivers/v4l2/emulated_tof_sensor.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <umockdev.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>

#include "absl/strings/str_cat.h"
#include "v4l2/frame_unpacker.h"

namespace transient::v4l2::testing {

struct EmulatedTofSensor::State {
  UMockdevTestbed* testbed = nullptr;
  struct Node {
    EmulatedNode behaviour;
    UMockdevIoctlBase* handler = nullptr;
    std::string file;  // the regular file behind /dev/<name>, which holds the buffers
    // Runtime state; the handler runs on umockdev's thread, the test pushes frames on its own.
    std::mutex mutex;
    bool unplugged = false;
    uint32_t fourcc = 0;
    size_t bytes_per_line = 0, image_bytes = 0;
    int buffers = 0;
    size_t buffer_stride = 0;  // page-aligned
    std::deque<int> queued;    // buffer indices in QBUF order
    bool streaming = false;
    std::deque<EmulatedFrame> frames;
    uint32_t next_sequence = 0;
  };
  std::vector<std::unique_ptr<Node>> nodes;

  Node& Find(const std::string& name) {
    for (auto& node : nodes) {
      if (node->behaviour.name == name) return *node;
    }
    throw std::runtime_error(absl::StrCat("no emulated node ", name));
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

using NodeState = EmulatedTofSensor::State::Node;

// The streaming ioctls, as the V4L2 API documentation describes a driver's side.
int AnswerStreaming(NodeState& state, unsigned long request, UMockdevIoctlClient* client) {
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
    if (state.streaming) state.next_sequence = 0;  // drivers count from 0 at each start
    if (!state.streaming) state.queued.clear();
    return 0;
  }
  if (request == VIDIOC_DQBUF) {
    auto* buffer = Argument<v4l2_buffer>(client);
    if (buffer == nullptr) return EFAULT;
    if (!state.streaming) return EINVAL;
    if (state.queued.empty() || state.frames.empty()) return EAGAIN;
    const int index = state.queued.front();
    state.queued.pop_front();
    EmulatedFrame frame = std::move(state.frames.front());
    state.frames.pop_front();
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
int Answer(NodeState& state, UMockdevIoctlClient* client) {
  std::lock_guard<std::mutex> lock(state.mutex);
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
  // What the kernel says to an ioctl the driver does not know: ENOTTY.
  return AnswerStreaming(state, request, client);
}

gboolean HandleIoctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer node) {
  Complete(client, Answer(*static_cast<NodeState*>(node), client));
  return TRUE;
}

}  // namespace

std::vector<ControlDescription> Mlx7502xControls() {
  return {
      {.id = 0x00981ad0, .name = "Output Mode", .type = V4L2_CTRL_TYPE_MENU, .minimum = 0,
       .maximum = 4, .step = 1},
      {.id = 0x009a0925, .name = "Camera Trigger", .type = V4L2_CTRL_TYPE_BUTTON},
      {.id = 0x009a0926, .name = "Camera Trigger Mode", .type = V4L2_CTRL_TYPE_MENU,
       .minimum = 0, .maximum = 2, .step = 1},
      {.id = 0x00a60900, .name = "TOF Phase Sequence", .type = V4L2_CTRL_TYPE_U16, .minimum = 0,
       .maximum = 315, .step = 45, .elements = 8, .flags = V4L2_CTRL_FLAG_DYNAMIC_ARRAY},
      {.id = 0x00a60901, .name = "TOF Frequency Modulation", .type = V4L2_CTRL_TYPE_U32,
       .minimum = 4'000'000, .maximum = 100'000'000, .default_value = 40'000'000,
       .step = 1'000'000, .elements = 1, .flags = V4L2_CTRL_FLAG_DYNAMIC_ARRAY},
      {.id = 0x00a60902, .name = "TOF Time Integration", .type = V4L2_CTRL_TYPE_U16,
       .minimum = 5, .maximum = 1000, .default_value = 198, .step = 1, .elements = 8,
       .flags = V4L2_CTRL_FLAG_DYNAMIC_ARRAY},
  };
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
  auto node = std::make_unique<State::Node>();
  node->behaviour = behaviour;
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
  State::Node& node = state_->Find(name);
  std::lock_guard<std::mutex> lock(node.mutex);
  node.frames.push_back(std::move(frame));
}

void EmulatedTofSensor::Unplug(const std::string& name) {
  State::Node& node = state_->Find(name);
  std::lock_guard<std::mutex> lock(node.mutex);
  node.unplugged = true;
}

}  // namespace transient::v4l2::testing
