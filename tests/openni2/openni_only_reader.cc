// A program that knows nothing of transient: it uses only OpenNI2's public API (OpenNI.h), as
// NiViewer2, ROS's openni2_camera or PCL's grabber do, and writes what it read for a test to
// compare (tests/openni2/openni2_driver_test.cc). It closes a device as transientd does
// (transient/openni2/close_device.h, OpenNI.h alone), around a race in OpenNI2's file player.
//
//   openni_only_reader live URI FRAMES OUT [WxH] [mm|100um]
//       opens URI, prints the device's and the depth stream's properties, reads FRAMES depth
//       frames (of that mode, when given) and writes them to OUT
//   openni_only_reader record URI FRAMES FILE.oni [ir]
//       records FRAMES frames of the depth stream (and the IR stream) with OpenNI2's Recorder
//   openni_only_reader play FILE.oni OUT
//       plays FILE.oni in manual mode (a frame per waitForAnyStream, none dropped), writes every
//       frame of its depth (and IR) stream to OUT in the order read, and prints the frame counts
//
// OUT holds, per frame: int64 frame index, uint64 timestamp (us), int32 width, int32 height,
// int32 pixel format, then width * height uint16 pixels, little endian, row by row.
// Exit status 0 on success; 1 with a message on standard error otherwise.
#include <OpenNI.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "transient/openni2/close_device.h"

namespace {

int Fail(const std::string& what) {
  std::fprintf(stderr, "openni_only_reader: %s: %s\n", what.c_str(),
               openni::OpenNI::getExtendedError());
  return 1;
}

bool WriteFrame(std::FILE* out, const openni::VideoFrameRef& frame) {
  const int64_t index = frame.getFrameIndex();
  const uint64_t timestamp = frame.getTimestamp();
  const int32_t header[3] = {frame.getWidth(), frame.getHeight(),
                             static_cast<int32_t>(frame.getVideoMode().getPixelFormat())};
  if (std::fwrite(&index, sizeof index, 1, out) != 1) return false;
  if (std::fwrite(&timestamp, sizeof timestamp, 1, out) != 1) return false;
  if (std::fwrite(header, sizeof header, 1, out) != 1) return false;
  const auto* data = static_cast<const uint8_t*>(frame.getData());
  for (int row = 0; row < frame.getHeight(); ++row) {
    const size_t bytes = static_cast<size_t>(frame.getWidth()) * sizeof(uint16_t);
    if (std::fwrite(data + static_cast<size_t>(row) * frame.getStrideInBytes(), 1, bytes, out) !=
        bytes) {
      return false;
    }
  }
  return true;
}

// Reads `frames` frames of `stream` into `out` (when not null); false on a timeout.
bool ReadFrames(openni::VideoStream& stream, int frames, std::FILE* out) {
  openni::VideoStream* streams[] = {&stream};
  for (int n = 0; n < frames; ++n) {
    int ready = -1;
    if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, 10000) != openni::STATUS_OK) {
      return false;
    }
    openni::VideoFrameRef frame;
    if (stream.readFrame(&frame) != openni::STATUS_OK) return false;
    if (out != nullptr && !WriteFrame(out, frame)) return false;
  }
  return true;
}

void PrintProperties(openni::Device& device, openni::VideoStream& depth) {
  char serial[64] = {};
  int size = sizeof serial;
  if (device.getProperty(openni::DEVICE_PROPERTY_SERIAL_NUMBER, serial, &size) ==
      openni::STATUS_OK) {
    std::printf("serial=%s\n", serial);
  }
  const openni::VideoMode mode = depth.getVideoMode();
  std::printf("mode=%dx%d@%d format=%d\n", mode.getResolutionX(), mode.getResolutionY(),
              mode.getFps(), static_cast<int>(mode.getPixelFormat()));
  std::printf("hfov=%.9f vfov=%.9f\n", depth.getHorizontalFieldOfView(),
              depth.getVerticalFieldOfView());
  std::printf("max=%d min=%d\n", depth.getMaxPixelValue(), depth.getMinPixelValue());
  std::printf("registration=%d\n",
              device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR)
                  ? 1 : 0);
}

}  // namespace

// LeakSanitizer's scan of this process's TLS at exit crashed ("Tracer caught signal 11" on a
// dynamic TLS range starting at 0xf8) once the driver, loaded with dlopen, grew by one message
// of the protocol (NatsStats): a fault of the sanitizer's DTLS bookkeeping, not of the code
// scanned, which the same reader passes with the scan off. Without TLS as a root, stacks,
// registers, globals and the heap are still scanned: a block only TLS points to is reported as
// a leak, never hidden.
extern "C" const char* __lsan_default_options() { return "use_tls=0"; }

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: openni_only_reader live URI FRAMES OUT [WxH] [mm|100um] | "
                         "record URI FRAMES FILE.oni | play FILE.oni OUT\n");
    return 2;
  }
  const std::string command = argv[1];
  if (openni::OpenNI::initialize() != openni::STATUS_OK) return Fail("OpenNI::initialize");
  openni::Device device;
  if (device.open(argv[2]) != openni::STATUS_OK) return Fail(std::string("open ") + argv[2]);
  openni::VideoStream depth;
  openni::VideoStream ir;  // record and play, where asked and there
  if (depth.create(device, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
    return Fail("create the depth stream");
  }
  int status = 0;
  if (command == "live" && argc >= 5) {
    if (argc >= 6) {
      int width = 0, height = 0;
      if (std::sscanf(argv[5], "%dx%d", &width, &height) != 2) return Fail("bad size");
      const bool hundred_um = argc >= 7 && std::strcmp(argv[6], "100um") == 0;
      openni::VideoMode mode = depth.getVideoMode();
      mode.setResolution(width, height);
      mode.setPixelFormat(hundred_um ? openni::PIXEL_FORMAT_DEPTH_100_UM
                                     : openni::PIXEL_FORMAT_DEPTH_1_MM);
      if (depth.setVideoMode(mode) != openni::STATUS_OK) return Fail("setVideoMode");
    }
    if (depth.setMirroringEnabled(false) != openni::STATUS_OK) return Fail("setMirroringEnabled");
    PrintProperties(device, depth);
    std::FILE* out = std::fopen(argv[4], "wb");
    if (out == nullptr) return Fail(std::string("cannot write ") + argv[4]);
    if (depth.start() != openni::STATUS_OK) return Fail("start");
    if (!ReadFrames(depth, std::atoi(argv[3]), out)) status = Fail("read frames");
    if (std::fclose(out) != 0) status = Fail("write frames");
  } else if (command == "record" && argc >= 5) {
    const bool with_ir = argc >= 6 && std::strcmp(argv[5], "ir") == 0;
    if (with_ir && ir.create(device, openni::SENSOR_IR) != openni::STATUS_OK) {
      return Fail("create the IR stream");
    }
    openni::Recorder recorder;
    if (recorder.create(argv[4]) != openni::STATUS_OK) return Fail("Recorder::create");
    if (recorder.attach(depth) != openni::STATUS_OK) return Fail("Recorder::attach");
    if (with_ir && recorder.attach(ir) != openni::STATUS_OK) return Fail("Recorder::attach IR");
    if (depth.start() != openni::STATUS_OK) return Fail("start");
    if (with_ir && ir.start() != openni::STATUS_OK) return Fail("start IR");
    if (recorder.start() != openni::STATUS_OK) return Fail("Recorder::start");
    if (!ReadFrames(depth, std::atoi(argv[3]), nullptr)) status = Fail("read frames");
    // The recorder first: its destruction finishes the file from the streams attached to it,
    // which must still exist (destroying the IR stream before it crashed libOpenNI2 in about
    // one run in seven on a busy machine, in oniRecorderDestroy).
    recorder.stop();
    recorder.destroy();
  } else if (command == "play") {
    openni::PlaybackControl* playback = device.getPlaybackControl();
    if (playback == nullptr) return Fail("not a recording");
    playback->setRepeatEnabled(false);
    playback->setSpeed(-1.0f);  // manual: one frame per waitForAnyStream
    const int frames = playback->getNumberOfFrames(depth);
    std::printf("frames=%d\n", frames);
    const bool with_ir = device.hasSensor(openni::SENSOR_IR) &&
                         ir.create(device, openni::SENSOR_IR) == openni::STATUS_OK;
    const int ir_frames = with_ir ? playback->getNumberOfFrames(ir) : 0;
    std::printf("ir_frames=%d\n", ir_frames);
    PrintProperties(device, depth);
    std::FILE* out = std::fopen(argv[3], "wb");
    if (out == nullptr) return Fail(std::string("cannot write ") + argv[3]);
    if (depth.start() != openni::STATUS_OK) return Fail("start");
    if (with_ir && ir.start() != openni::STATUS_OK) return Fail("start IR");
    // Both streams in one loop: each wait plays the file's next frame, of either stream.
    openni::VideoStream* streams[] = {&depth, &ir};
    for (int n = 0; n < frames + ir_frames && status == 0; ++n) {
      int ready = -1;
      openni::VideoFrameRef frame;
      if (openni::OpenNI::waitForAnyStream(streams, with_ir ? 2 : 1, &ready, 10000) !=
              openni::STATUS_OK ||
          streams[ready]->readFrame(&frame) != openni::STATUS_OK || !WriteFrame(out, frame)) {
        status = Fail("play frames");
      }
    }
    if (std::fclose(out) != 0) status = Fail("write frames");
  } else {
    std::fprintf(stderr, "openni_only_reader: unknown command %s\n", command.c_str());
    return 2;
  }
  // Streams stopped, then destroyed, then the device closed, as close_device.h explains: the
  // file player crashed in 14 of 300 plays on a busy machine when the streams were stopped and
  // destroyed one after the other (openni2/README.md).
  transient::openni2::CloseDevice(device, {&depth, &ir});
  // No OpenNI::shutdown(): it unloads the drivers, and the sanitizers' leak check at exit could
  // then not name the libraries whose allocations it finds (tests/openni2/lsan.supp).
  return status;
}
