// libpng and libtiff readers for the tests of the tool's image files.
#include "tests/tools/image_readers.h"

#include <gtest/gtest.h>
#include <png.h>
#include <tiffio.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>

namespace transient::tools::testing {
namespace {

// C style: a libpng error longjmps out of png_read_png, skipping no destructor in this frame.
bool ReadPngRows(std::FILE* file, RawPng* out) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, file);
  png_read_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
  out->width = png_get_image_width(png, info);
  out->height = png_get_image_height(png, info);
  out->bit_depth = png_get_bit_depth(png, info);
  out->colour_type = png_get_color_type(png, info);
  const size_t row_bytes = png_get_rowbytes(png, info);
  png_bytepp rows = png_get_rows(png, info);
  out->bytes.resize(row_bytes * out->height);
  for (png_uint_32 y = 0; y < out->height; ++y) {
    std::memcpy(out->bytes.data() + y * row_bytes, rows[y], row_bytes);
  }
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

RawPng ReadPng(const std::string& path) {
  RawPng png;
  std::FILE* file = std::fopen(path.c_str(), "rb");
  EXPECT_NE(file, nullptr) << path;
  if (file == nullptr) return png;
  EXPECT_TRUE(ReadPngRows(file, &png)) << path;
  std::fclose(file);
  return png;
}

RawTiff ReadTiff(const std::string& path) {
  RawTiff result;
  TIFF* tiff = TIFFOpen(path.c_str(), "r");
  EXPECT_NE(tiff, nullptr) << path;
  if (tiff == nullptr) return result;
  TIFFGetField(tiff, TIFFTAG_IMAGEWIDTH, &result.width);
  TIFFGetField(tiff, TIFFTAG_IMAGELENGTH, &result.height);
  TIFFGetField(tiff, TIFFTAG_BITSPERSAMPLE, &result.bits_per_sample);
  TIFFGetField(tiff, TIFFTAG_SAMPLESPERPIXEL, &result.samples_per_pixel);
  TIFFGetField(tiff, TIFFTAG_SAMPLEFORMAT, &result.sample_format);
  if (result.bits_per_sample == 32 && result.samples_per_pixel == 1) {
    result.values.resize(size_t{result.width} * result.height);
    for (uint32_t y = 0; y < result.height; ++y) {
      EXPECT_EQ(TIFFReadScanline(tiff, result.values.data() + size_t{y} * result.width, y, 0),
                1);
    }
  }
  TIFFClose(tiff);
  return result;
}

}  // namespace transient::tools::testing
