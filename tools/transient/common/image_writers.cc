// PNG (libpng) and float TIFF (libtiff) writers and the colour map of the `transient` tool.
#include "tools/transient/common/image_writers.h"

#include <png.h>
#include <tiffio.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "absl/strings/str_cat.h"
namespace transient::tools {
namespace {

absl::Status CheckPlane(const std::string& path, ImageGeometry geometry, size_t values,
                        int values_per_pixel) {
  if (geometry.width <= 0 || geometry.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": image of ", geometry.width, "x",
                                                   geometry.height,
                                                   " px: expected width > 0 and height > 0"));
  }
  const int64_t expected = geometry.pixel_count() * values_per_pixel;
  if (static_cast<int64_t>(values) != expected) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", values, " values for ",
                                                   geometry.width, "x", geometry.height,
                                                   " px: expected ", expected));
  }
  return absl::OkStatus();
}

// ENOSPC becomes ResourceExhausted, EACCES PermissionDenied, ENOENT NotFound...
absl::Status PathError(const std::string& path, const char* what, int error_number) {
  return absl::ErrnoToStatus(error_number, absl::StrCat(path, ": ", what));
}

// Only a regular file is ours to remove: `path` may name a device such as /dev/full.
void RemoveQuietly(const std::string& path) {
  std::error_code ignored;
  if (std::filesystem::is_regular_file(path, ignored)) std::filesystem::remove(path, ignored);
}

// libpng reports errors by calling its error function, which must not return: it records the
// message and longjmps back into WritePngRows.
struct PngErrorState {
  char message[256] = {};
};

void PngError(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof(state->message), "%s", message);
  png_longjmp(png, 1);
}

void PngWarning(png_structp, png_const_charp) {}

// No object with a destructor lives in this frame, so that the longjmp of an error skips
// nothing. `rows` are `height` pointers to rows of samples already in PNG byte order.
bool WritePngRows(std::FILE* file, ImageGeometry geometry, int bit_depth, int colour_type,
                  png_bytep* rows, PngErrorState* state) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, state, PngError, PngWarning);
  if (png == nullptr) {
    std::snprintf(state->message, sizeof(state->message), "cannot start libpng");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    std::snprintf(state->message, sizeof(state->message), "cannot start libpng");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(geometry.width),
               static_cast<png_uint_32>(geometry.height), bit_depth, colour_type,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

// `bytes` holds the whole image in PNG byte order, `row_bytes` per row.
absl::Status WritePng(const std::string& path, ImageGeometry geometry, int bit_depth,
                      int colour_type, std::vector<uint8_t>& bytes, size_t row_bytes) {
  std::vector<png_bytep> rows(static_cast<size_t>(geometry.height));
  for (size_t y = 0; y < rows.size(); ++y) rows[y] = bytes.data() + y * row_bytes;

  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) return PathError(path, "cannot create the PNG file", errno);
  PngErrorState state;
  errno = 0;
  const bool written = WritePngRows(file, geometry, bit_depth, colour_type, rows.data(), &state);
  int error_number = errno;
  if (std::fflush(file) != 0 || std::ferror(file) != 0) error_number = errno;
  const bool flushed = std::ferror(file) == 0;
  const bool closed = std::fclose(file) == 0;
  if (!closed) error_number = errno;
  if (written && flushed && closed) return absl::OkStatus();
  RemoveQuietly(path);
  if (!written && error_number == 0) {
    return absl::InternalError(absl::StrCat(path, ": libpng: ", state.message));
  }
  return PathError(path, "cannot write the PNG file", error_number != 0 ? error_number : EIO);
}

// libtiff's per-file error handler (libtiff >= 4.5): keeps the first message.
struct TiffErrorState {
  char message[256] = {};
};

int TiffError(TIFF*, void* user_data, const char* module, const char* format, va_list args) {
  auto* state = static_cast<TiffErrorState*>(user_data);
  if (state->message[0] != '\0') return 1;
  const int used = std::snprintf(state->message, sizeof(state->message), "%s: ",
                                 module != nullptr ? module : "libtiff");
  if (used >= 0 && static_cast<size_t>(used) < sizeof(state->message)) {
    std::vsnprintf(state->message + used, sizeof(state->message) - used, format, args);
  }
  return 1;  // handled: the global handler (stderr) is not called
}

int TiffWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

// Inferno control points at t = 0, 1/8, ..., 1, approximated by hand from the published map.
constexpr int kControlPoints = 9;
constexpr std::array<std::array<float, 3>, kControlPoints> kInferno = {{
    {0, 0, 4},
    {31, 12, 72},
    {85, 15, 109},
    {136, 34, 106},
    {186, 54, 85},
    {227, 89, 51},
    {249, 140, 10},
    {249, 201, 50},
    {252, 255, 164},
}};

uint8_t ToByte(float value) {
  return static_cast<uint8_t>(std::lround(std::clamp(value, 0.0f, 255.0f)));
}

}  // namespace

absl::Status WritePng16(const std::string& path, ImageGeometry geometry,
                        std::span<const uint16_t> pixels) {
  if (absl::Status status = CheckPlane(path, geometry, pixels.size(), 1); !status.ok()) {
    return status;
  }
  std::vector<uint8_t> bytes(pixels.size() * 2);
  for (size_t i = 0; i < pixels.size(); ++i) {
    bytes[2 * i] = static_cast<uint8_t>(pixels[i] >> 8);  // PNG samples are big-endian
    bytes[2 * i + 1] = static_cast<uint8_t>(pixels[i] & 0xff);
  }
  return WritePng(path, geometry, 16, PNG_COLOR_TYPE_GRAY, bytes,
                  static_cast<size_t>(geometry.width) * 2);
}

absl::Status WritePng8(const std::string& path, ImageGeometry geometry,
                       std::span<const uint8_t> pixels) {
  if (absl::Status status = CheckPlane(path, geometry, pixels.size(), 1); !status.ok()) {
    return status;
  }
  std::vector<uint8_t> bytes(pixels.begin(), pixels.end());
  return WritePng(path, geometry, 8, PNG_COLOR_TYPE_GRAY, bytes,
                  static_cast<size_t>(geometry.width));
}

absl::Status WritePngRgb8(const std::string& path, ImageGeometry geometry,
                          std::span<const uint8_t> rgb) {
  if (absl::Status status = CheckPlane(path, geometry, rgb.size(), 3); !status.ok()) {
    return status;
  }
  std::vector<uint8_t> bytes(rgb.begin(), rgb.end());
  return WritePng(path, geometry, 8, PNG_COLOR_TYPE_RGB, bytes,
                  static_cast<size_t>(geometry.width) * 3);
}

absl::Status WriteTiffFloat(const std::string& path, ImageGeometry geometry,
                            std::span<const float> pixels) {
  if (absl::Status status = CheckPlane(path, geometry, pixels.size(), 1); !status.ok()) {
    return status;
  }
  // libtiff opens the file itself; try first so that the errno of a bad path is ours to report.
  if (std::FILE* probe = std::fopen(path.c_str(), "wb"); probe == nullptr) {
    return PathError(path, "cannot create the TIFF file", errno);
  } else {
    std::fclose(probe);
  }
  TiffErrorState state;
  TIFFOpenOptions* options = TIFFOpenOptionsAlloc();
  TIFFOpenOptionsSetErrorHandlerExtR(options, TiffError, &state);
  TIFFOpenOptionsSetWarningHandlerExtR(options, TiffWarning, nullptr);
  errno = 0;
  TIFF* tiff = TIFFOpenExt(path.c_str(), "w", options);
  const int open_errno = errno;
  TIFFOpenOptionsFree(options);
  if (tiff == nullptr) {
    RemoveQuietly(path);
    // Writing the header can already fail on a full disk.
    if (open_errno != 0) return PathError(path, "cannot create the TIFF file", open_errno);
    return absl::InternalError(
        absl::StrCat(path, ": cannot create the TIFF file: ", state.message));
  }
  const uint32_t width = static_cast<uint32_t>(geometry.width);
  const uint32_t height = static_cast<uint32_t>(geometry.height);
  bool ok = TIFFSetField(tiff, TIFFTAG_IMAGEWIDTH, width) == 1 &&
            TIFFSetField(tiff, TIFFTAG_IMAGELENGTH, height) == 1 &&
            TIFFSetField(tiff, TIFFTAG_SAMPLESPERPIXEL, uint16_t{1}) == 1 &&
            TIFFSetField(tiff, TIFFTAG_BITSPERSAMPLE, uint16_t{32}) == 1 &&
            TIFFSetField(tiff, TIFFTAG_SAMPLEFORMAT, uint16_t{SAMPLEFORMAT_IEEEFP}) == 1 &&
            TIFFSetField(tiff, TIFFTAG_PHOTOMETRIC, uint16_t{PHOTOMETRIC_MINISBLACK}) == 1 &&
            TIFFSetField(tiff, TIFFTAG_PLANARCONFIG, uint16_t{PLANARCONFIG_CONTIG}) == 1 &&
            TIFFSetField(tiff, TIFFTAG_COMPRESSION, uint16_t{COMPRESSION_NONE}) == 1 &&
            TIFFSetField(tiff, TIFFTAG_ROWSPERSTRIP, TIFFDefaultStripSize(tiff, 0)) == 1;
  errno = 0;
  std::vector<float> row(width);
  for (uint32_t y = 0; ok && y < height; ++y) {
    // TIFFWriteScanline may modify its buffer; the caller's plane is const.
    std::copy_n(pixels.begin() + static_cast<size_t>(y) * width, width, row.begin());
    ok = TIFFWriteScanline(tiff, row.data(), y, 0) == 1;
  }
  ok = ok && TIFFFlush(tiff) == 1;
  const int error_number = errno;
  TIFFClose(tiff);
  if (ok) return absl::OkStatus();
  RemoveQuietly(path);
  if (error_number != 0) return PathError(path, "cannot write the TIFF file", error_number);
  return absl::InternalError(absl::StrCat(path, ": cannot write the TIFF file: ", state.message));
}

uint16_t MetresToMillimetres(float metres) {
  if (!(metres > 0.0f)) return 0;  // NaN and <= 0
  const double millimetres = std::round(double{metres} * 1000.0);
  if (millimetres > 65535.0) return 0;
  return static_cast<uint16_t>(millimetres);
}

Rgb8 ColourMap(float value, float scale) {
  assert(scale > 0.0f && std::isfinite(scale));
  if (std::isnan(value)) return kNoValueGrey;
  const float t = std::clamp(value / scale, 0.0f, 1.0f);
  const float position = t * (kControlPoints - 1);
  const int lower = std::min(static_cast<int>(position), kControlPoints - 2);
  const float weight = position - static_cast<float>(lower);
  const std::array<float, 3>& a = kInferno[lower];
  const std::array<float, 3>& b = kInferno[lower + 1];
  return {ToByte(a[0] + weight * (b[0] - a[0])), ToByte(a[1] + weight * (b[1] - a[1])),
          ToByte(a[2] + weight * (b[2] - a[2]))};
}

std::vector<uint8_t> ColourMapPlane(std::span<const float> values, float scale) {
  std::vector<uint8_t> rgb(values.size() * 3);
  for (size_t i = 0; i < values.size(); ++i) {
    const Rgb8 colour = ColourMap(values[i], scale);
    rgb[3 * i] = colour.r;
    rgb[3 * i + 1] = colour.g;
    rgb[3 * i + 2] = colour.b;
  }
  return rgb;
}

}  // namespace transient::tools
