// The emulated V4L2 ToF sensor's kernel side (emulated_tof_sensor.h).
#include "tests/drivers/v4l2/emulated_tof_sensor.h"

#include <linux/videodev2.h>
#include <umockdev.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "absl/strings/str_cat.h"

namespace transient::v4l2::testing {

struct EmulatedTofSensor::State {
  UMockdevTestbed* testbed = nullptr;
  struct Node {
    EmulatedNode behaviour;
    UMockdevIoctlBase* handler = nullptr;
  };
  std::vector<std::unique_ptr<Node>> nodes;
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

// The kernel's answers, as linux/videodev2.h and the V4L2 API documentation give them.
int Answer(const EmulatedNode& node, UMockdevIoctlClient* client) {
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
  return ENOTTY;  // what the kernel says to an ioctl the driver does not know
}

gboolean HandleIoctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer node) {
  Complete(client, Answer(*static_cast<const EmulatedNode*>(node), client));
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
  node->handler = umockdev_ioctl_base_new();
  g_signal_connect(node->handler, "handle-ioctl", G_CALLBACK(HandleIoctl), &node->behaviour);
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

}  // namespace transient::v4l2::testing
