// Reading back the PNG and TIFF files of the `transient` tool in tests, with libpng and libtiff
// directly. The libraries' headers stay in image_readers.cc: tiff.h defines macros such as
// COMPRESSION_NONE that collide with the wire protocol's enum values.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace transient::tools::testing {

struct RawPng {
  uint32_t width = 0;
  uint32_t height = 0;
  int bit_depth = 0;
  int colour_type = 0;         // PNG_COLOR_TYPE_*
  std::vector<uint8_t> bytes;  // the rows as stored (16-bit samples big-endian), concatenated
};

// Adds a test failure and returns an empty image when the file cannot be read.
RawPng ReadPng(const std::string& path);

struct RawTiff {
  uint32_t width = 0;
  uint32_t height = 0;
  uint16_t bits_per_sample = 0;
  uint16_t samples_per_pixel = 0;
  uint16_t sample_format = 0;  // SAMPLEFORMAT_*
  std::vector<float> values;   // when 32-bit single-channel
};

RawTiff ReadTiff(const std::string& path);

}  // namespace transient::tools::testing
