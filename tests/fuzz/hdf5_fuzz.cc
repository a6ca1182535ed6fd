// The four HDF5 readers (capture, calibration, moments, reconstruction) and the file
// identification on any bytes, as an untrusted file given to `transient info`, a replay or
// --calibration would reach them. The bytes are written to
// one file in /dev/shm (memory; HDF5 refuses a memfd's /proc/self/fd path), rewritten for each
// input and read through HDF5's ordinary driver.
// Each reader's every frame is read (at most 4). The seeds are small valid files of each kind
// (tests/fuzz/corpus/hdf5, made by `transient sim`, `calibrate`, `moments`, `reconstruct` at
// 8x8 pixels). Property: no crash, no sanitizer report; every refusal is a status.
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "transient/formats/calibration_file.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/file_format.h"
#include "transient/formats/moment_file.h"
#include "transient/formats/reconstruction_reader.h"
#include "transient/formats/transient_frame.h"

namespace {

constexpr int64_t kMostFrames = 4;

struct MemoryFile {
  std::string path;
  int fd = -1;
};

const MemoryFile& TheFile() {
  static const MemoryFile* file = [] {
    const char* directory = ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    std::string pattern = std::string(directory) + "/transient-fuzz-hdf5-XXXXXX";
    auto* made = new MemoryFile;
    made->fd = ::mkstemp(pattern.data());
    if (made->fd < 0) std::abort();
    made->path = pattern;
    return made;
  }();
  return *file;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const MemoryFile& file = TheFile();
  if (::ftruncate(file.fd, 0) != 0 ||
      ::pwrite(file.fd, data, size, 0) != static_cast<ssize_t>(size)) {
    std::abort();
  }
  const std::string& path = file.path;
  (void)transient::IdentifyFile(path);
  (void)transient::ReadCalibrationFile(path);
  if (absl::StatusOr<transient::CaptureReader> capture = transient::CaptureReader::Open(path);
      capture.ok()) {
    transient::RawFrame frame;
    for (int64_t i = 0; i < std::min(capture->frames(), kMostFrames); ++i) {
      (void)capture->Read(i, &frame);
    }
  }
  if (absl::StatusOr<transient::MomentFile> moments = transient::MomentFile::Open(path);
      moments.ok()) {
    transient::MomentImage image;
    for (int64_t i = 0; i < std::min(moments->frames(), kMostFrames); ++i) {
      (void)moments->ReadFrame(i, &image);
    }
  }
  if (absl::StatusOr<transient::ReconstructionReader> reconstruction =
          transient::ReconstructionReader::Open(path);
      reconstruction.ok()) {
    transient::TransientFrame frame;
    for (int64_t i = 0; i < std::min(reconstruction->frames(), kMostFrames); ++i) {
      (void)reconstruction->ReadFrame(i, reconstruction->available(), &frame);
    }
  }
  return 0;
}
