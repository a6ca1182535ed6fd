// Images on the wire: ROI resolution, encoding to 32FC1/16FC1/16UC1/8UC1 with optional zstd,
// and the bounds-checked inverse for clients.
#include "transient/wire/image_codec.h"

#include <zstd.h>

#include <bit>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "transient/wire/product_registry.h"

namespace transient::wire {
namespace {

// Level 1: images are compressed per frame at video rate, where speed matters more than the
// last few percent of ratio.
constexpr int kZstdLevel = 1;

// The largest image DecodeImage accepts: its float output and its (decompressed) data stay
// within 256 MiB, so a corrupt or hostile header cannot make a client allocate more.
constexpr uint64_t kMaxDecodedBytes = uint64_t{256} << 20;
constexpr uint64_t kMaxDecodedPixels = kMaxDecodedBytes / sizeof(float);

// REP 118: 16UC1 holds millimetres, 0 is invalid.
constexpr double kMillimetresPerMetre = 1000.0;
constexpr double kMaxMillimetres = 65535.0;

void StoreLe16(uint16_t value, char* out) {
  out[0] = static_cast<char>(value & 0xFF);
  out[1] = static_cast<char>(value >> 8);
}

void StoreLe32(uint32_t value, char* out) {
  out[0] = static_cast<char>(value & 0xFF);
  out[1] = static_cast<char>((value >> 8) & 0xFF);
  out[2] = static_cast<char>((value >> 16) & 0xFF);
  out[3] = static_cast<char>(value >> 24);
}

uint16_t LoadLe16(const unsigned char* in) {
  return static_cast<uint16_t>(in[0] | (in[1] << 8));
}

uint32_t LoadLe32(const unsigned char* in) {
  return uint32_t{in[0]} | (uint32_t{in[1]} << 8) | (uint32_t{in[2]} << 16) |
         (uint32_t{in[3]} << 24);
}

// 0 (invalid) for NaN, infinities, non-positive lengths and those that round above 65535 mm.
uint16_t MetresToMillimetres(float metres) {
  // In double, so that e.g. 1.2345f (1.23450005...) gives 1235 and not float's 1234.5 tie.
  const double mm = std::round(static_cast<double>(metres) * kMillimetresPerMetre);
  if (!(mm >= 1.0 && mm <= kMaxMillimetres)) return 0;
  return static_cast<uint16_t>(mm);
}

int BytesPerPixel(v1::Encoding encoding) {
  switch (encoding) {
    case v1::ENCODING_UNSPECIFIED:
    case v1::FLOAT32:
      return 4;
    case v1::FLOAT16:
    case v1::UINT16_MM:
      return 2;
    default:
      return 0;
  }
}

bool IsKnownEncoding(v1::Encoding encoding) { return BytesPerPixel(encoding) != 0; }

std::string ProductName(v1::Product product) {
  const std::string& name = v1::Product_Name(product);
  return name.empty() ? absl::StrCat(static_cast<int>(product)) : name;
}

std::string EncodingEnumName(v1::Encoding encoding) {
  const std::string& name = v1::Encoding_Name(encoding);
  return name.empty() ? absl::StrCat(static_cast<int>(encoding)) : name;
}

// Sets out->data to `raw`, zstd-compressed if asked, and out->compression.
absl::Status SetData(std::string raw, v1::Compression compression, v1::Image* out) {
  switch (compression) {
    case v1::COMPRESSION_NONE:
      out->set_data(std::move(raw));
      break;
    case v1::ZSTD: {
      std::string compressed(ZSTD_compressBound(raw.size()), '\0');
      const size_t size =
          ZSTD_compress(compressed.data(), compressed.size(), raw.data(), raw.size(), kZstdLevel);
      if (ZSTD_isError(size)) {
        return absl::InternalError(absl::StrCat("zstd compression of ", raw.size(),
                                                " bytes failed: ", ZSTD_getErrorName(size)));
      }
      compressed.resize(size);
      out->set_data(std::move(compressed));
      break;
    }
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("compression=", static_cast<int>(compression),
                       ". Violated constraint: COMPRESSION_NONE or ZSTD"));
  }
  out->set_compression(compression);
  return absl::OkStatus();
}

void SetGeometry(const PixelRect& rect, int bytes_per_pixel, const char* encoding,
                 v1::Image* out) {
  out->set_width(static_cast<uint32_t>(rect.width));
  out->set_height(static_cast<uint32_t>(rect.height));
  out->set_encoding(encoding);
  out->set_step(static_cast<uint32_t>(rect.width) * static_cast<uint32_t>(bytes_per_pixel));
}

// Whether `rect` is non-empty and inside `sensor`: the callers' precondition.
[[maybe_unused]] bool RectInside(const PixelRect& rect, ImageGeometry sensor) {
  return rect.x >= 0 && rect.y >= 0 && rect.width > 0 && rect.height > 0 &&
         int64_t{rect.x} + rect.width <= sensor.width &&
         int64_t{rect.y} + rect.height <= sensor.height;
}

}  // namespace

absl::StatusOr<PixelRect> ResolveRoi(const v1::Roi& roi, ImageGeometry sensor) {
  if (sensor.width <= 0 || sensor.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("sensor ", sensor.width, "x", sensor.height,
                                                   ". Violated constraint: width, height > 0"));
  }
  const auto sensor_text = [&] { return absl::StrCat(sensor.width, "x", sensor.height); };
  if (roi.width() == 0 && roi.height() == 0) {
    // An offset with no size is ambiguous (a forgotten width?); refuse it rather than guess.
    if (roi.x() != 0 || roi.y() != 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "roi: x=", roi.x(), ", y=", roi.y(),
          " with width = height = 0 (the whole sensor). Violated constraint: x = y = 0 when "
          "width = height = 0, or a size inside the ",
          sensor_text(), " sensor"));
    }
    return PixelRect{.x = 0, .y = 0, .width = sensor.width, .height = sensor.height};
  }
  if (roi.width() == 0 || roi.height() == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("roi: width=", roi.width(), ", height=", roi.height(),
                     " is empty in one dimension. Violated constraint: both > 0, or both 0 for "
                     "the whole ",
                     sensor_text(), " sensor"));
  }
  // uint64 sums: x and width are uint32 from the wire and may each be close to 2^32.
  if (uint64_t{roi.x()} + roi.width() > static_cast<uint64_t>(sensor.width)) {
    return absl::InvalidArgumentError(absl::StrCat("roi: x=", roi.x(), " + width=", roi.width(),
                                                   " reaches outside the ", sensor_text(),
                                                   " sensor"));
  }
  if (uint64_t{roi.y()} + roi.height() > static_cast<uint64_t>(sensor.height)) {
    return absl::InvalidArgumentError(absl::StrCat("roi: y=", roi.y(), " + height=",
                                                   roi.height(), " reaches outside the ",
                                                   sensor_text(), " sensor"));
  }
  // All four now fit in int: each is at most the sensor's int width or height.
  return PixelRect{.x = static_cast<int>(roi.x()),
                   .y = static_cast<int>(roi.y()),
                   .width = static_cast<int>(roi.width()),
                   .height = static_cast<int>(roi.height())};
}

absl::Status CheckEncoding(v1::Product product, v1::Encoding encoding) {
  if (!IsKnownEncoding(encoding)) {
    return absl::InvalidArgumentError(
        absl::StrCat("encoding=", EncodingEnumName(encoding), " for product ",
                     ProductName(product), ". Violated constraint: FLOAT32, FLOAT16 or UINT16_MM"));
  }
  const ProductSpec* spec = FindProduct(product);
  if (spec == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("product=", ProductName(product), ". Violated constraint: one of ",
                     ProductName(Products().front().product), "..",
                     ProductName(Products().back().product)));
  }
  // FLAGS and MOMENT_DEPTH have encodings of their own and ignore the one requested.
  if (encoding != v1::UINT16_MM || spec->encodings != EncodingRule::kFloat) {
    return absl::OkStatus();
  }
  std::vector<std::string> lengths;
  for (const ProductSpec& other : Products()) {
    if (other.encodings == EncodingRule::kFloatOrMillimetres) {
      lengths.push_back(ProductName(other.product));
    }
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "encoding=UINT16_MM for product ", ProductName(product),
      ". Violated constraint: UINT16_MM (millimetres) only for the lengths ",
      absl::StrJoin(lengths, " and ")));
}

const char* EncodingName(v1::Encoding encoding) {
  switch (encoding) {
    case v1::ENCODING_UNSPECIFIED:
    case v1::FLOAT32:
      return "32FC1";
    case v1::FLOAT16:
      return "16FC1";
    case v1::UINT16_MM:
      return "16UC1";
    default:
      // Never a valid ROS encoding, so a client refuses it rather than misreads the data.
      return "unknown";
  }
}

absl::Status EncodeFloatPlane(std::span<const float> plane, ImageGeometry sensor,
                              const PixelRect& rect, v1::Encoding encoding,
                              v1::Compression compression, v1::Image* out) {
  assert(plane.size() == static_cast<size_t>(sensor.pixel_count()));
  assert(RectInside(rect, sensor));
  const int bytes_per_pixel = BytesPerPixel(encoding);
  if (bytes_per_pixel == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("encoding=", EncodingEnumName(encoding),
                     ". Violated constraint: FLOAT32, FLOAT16 or UINT16_MM"));
  }
  std::string raw(static_cast<size_t>(rect.pixel_count()) * bytes_per_pixel, '\0');
  char* write = raw.data();
  for (int row = rect.y; row < rect.y + rect.height; ++row) {
    const float* read = plane.data() + static_cast<size_t>(row) * sensor.width + rect.x;
    for (int col = 0; col < rect.width; ++col, write += bytes_per_pixel) {
      switch (encoding) {
        case v1::FLOAT16:
          StoreLe16(FloatToHalf(read[col]), write);
          break;
        case v1::UINT16_MM:
          StoreLe16(MetresToMillimetres(read[col]), write);
          break;
        default:  // FLOAT32 and UNSPECIFIED
          StoreLe32(std::bit_cast<uint32_t>(read[col]), write);
          break;
      }
    }
  }
  if (absl::Status status = SetData(std::move(raw), compression, out); !status.ok()) {
    return status;
  }
  SetGeometry(rect, bytes_per_pixel, EncodingName(encoding), out);
  return absl::OkStatus();
}

absl::Status EncodeBytePlane(std::span<const uint8_t> plane, ImageGeometry sensor,
                             const PixelRect& rect, v1::Compression compression,
                             v1::Image* out) {
  assert(plane.size() == static_cast<size_t>(sensor.pixel_count()));
  assert(RectInside(rect, sensor));
  std::string raw(static_cast<size_t>(rect.pixel_count()), '\0');
  char* write = raw.data();
  for (int row = rect.y; row < rect.y + rect.height; ++row) {
    const uint8_t* read = plane.data() + static_cast<size_t>(row) * sensor.width + rect.x;
    for (int col = 0; col < rect.width; ++col) *write++ = static_cast<char>(read[col]);
  }
  if (absl::Status status = SetData(std::move(raw), compression, out); !status.ok()) {
    return status;
  }
  SetGeometry(rect, 1, "8UC1", out);
  return absl::OkStatus();
}

namespace {

// The layouts DecodeImage knows: bytes per channel and channels per pixel.
struct WireLayout {
  uint64_t bytes_per_channel = 0;
  uint64_t channels = 0;
  uint64_t bytes_per_pixel() const { return bytes_per_channel * channels; }
};

absl::StatusOr<WireLayout> LayoutOf(const std::string& encoding) {
  if (encoding == "32FC1") return WireLayout{4, 1};
  if (encoding == "16FC1" || encoding == "16UC1") return WireLayout{2, 1};
  if (encoding == "8UC1") return WireLayout{1, 1};
  if (encoding == "16UC4") return WireLayout{2, 4};
  if (encoding == "32FC4") return WireLayout{4, 4};
  return absl::InvalidArgumentError(absl::StrCat(
      "encoding=\"", encoding, "\". Violated constraint: one of 32FC1, 16FC1, 16UC1, 8UC1, ",
      "16UC4, 32FC4"));
}

// The image's pixel bytes, uncompressed and checked against width, height, step and encoding.
absl::StatusOr<std::string> ImageBytes(const v1::Image& image, WireLayout layout) {
  const auto data_loss = [&image](auto&&... parts) {
    return absl::DataLossError(absl::StrCat("image \"", image.name(), "\": ", parts...));
  };
  const std::string& encoding = image.encoding();
  const uint64_t bytes_per_pixel = layout.bytes_per_pixel();
  const uint64_t width = image.width();
  const uint64_t height = image.height();
  if (width == 0 || height == 0) {
    return data_loss("width=", width, ", height=", height,
                     ". Violated constraint: width, height > 0");
  }
  // Both are uint32, so the product fits in uint64; the limit keeps values * 4 far from overflow.
  const uint64_t pixels = width * height;
  if (pixels * layout.channels > kMaxDecodedPixels) {
    return data_loss("width=", width, " * height=", height, " = ", pixels, " pixels of ",
                     layout.channels, " values. Violated constraint: at most ",
                     kMaxDecodedPixels, " values");
  }
  if (image.step() != width * bytes_per_pixel) {
    return data_loss("step=", image.step(), ". Violated constraint: step = width * ",
                     bytes_per_pixel, " bytes per pixel of ", encoding, " = ",
                     width * bytes_per_pixel);
  }
  const uint64_t expected_bytes = pixels * bytes_per_pixel;

  const std::string& data = image.data();
  switch (image.compression()) {
    case v1::COMPRESSION_NONE:
      if (data.size() != expected_bytes) {
        return data_loss("data holds ", data.size(), " bytes. Violated constraint: width * height",
                         " * ", bytes_per_pixel, " = ", expected_bytes);
      }
      return data;
    case v1::ZSTD: {
      const unsigned long long content_size = ZSTD_getFrameContentSize(data.data(), data.size());
      if (content_size == ZSTD_CONTENTSIZE_ERROR) {
        return data_loss("data (", data.size(), " bytes) does not start with a zstd frame header");
      }
      if (content_size == ZSTD_CONTENTSIZE_UNKNOWN) {
        return data_loss(
            "zstd frame does not declare its content size. Violated constraint: declared, at "
            "most ",
            kMaxDecodedBytes, " bytes");
      }
      if (content_size > kMaxDecodedBytes) {
        return data_loss("zstd frame declares ", content_size,
                         " bytes. Violated constraint: at most ", kMaxDecodedBytes);
      }
      if (content_size != expected_bytes) {
        return data_loss("zstd frame declares ", content_size,
                         " bytes. Violated constraint: width * height * ", bytes_per_pixel, " = ",
                         expected_bytes);
      }
      const size_t frame_size = ZSTD_findFrameCompressedSize(data.data(), data.size());
      if (ZSTD_isError(frame_size)) {
        return data_loss("zstd frame in ", data.size(),
                         " bytes is corrupt: ", ZSTD_getErrorName(frame_size));
      }
      if (frame_size != data.size()) {
        return data_loss("data holds ", data.size(), " bytes after a zstd frame of ", frame_size,
                         ". Violated constraint: exactly one zstd frame");
      }
      std::string decompressed(static_cast<size_t>(expected_bytes), '\0');
      const size_t size =
          ZSTD_decompress(decompressed.data(), decompressed.size(), data.data(), data.size());
      if (ZSTD_isError(size)) {
        return data_loss("zstd decompression failed: ", ZSTD_getErrorName(size));
      }
      if (size != expected_bytes) {
        return data_loss("zstd frame decompressed to ", size,
                         " bytes. Violated constraint: width * height * ", bytes_per_pixel, " = ",
                         expected_bytes);
      }
      return decompressed;
    }
    default:
      return data_loss("compression=", static_cast<int>(image.compression()),
                       ". Violated constraint: COMPRESSION_NONE or ZSTD");
  }
}

}  // namespace

absl::StatusOr<std::vector<float>> DecodeImage(const v1::Image& image) {
  const std::string& encoding = image.encoding();
  absl::StatusOr<WireLayout> layout = LayoutOf(encoding);
  if (!layout.ok()) {
    return absl::DataLossError(
        absl::StrCat("image \"", image.name(), "\": ", layout.status().message()));
  }
  absl::StatusOr<std::string> raw = ImageBytes(image, *layout);
  if (!raw.ok()) return raw.status();
  const auto* bytes = reinterpret_cast<const unsigned char*>(raw->data());
  std::vector<float> values(raw->size() / layout->bytes_per_channel);
  if (encoding == "32FC1" || encoding == "32FC4") {
    for (size_t i = 0; i < values.size(); ++i) {
      values[i] = std::bit_cast<float>(LoadLe32(bytes + 4 * i));
    }
  } else if (encoding == "16FC1") {
    for (size_t i = 0; i < values.size(); ++i) values[i] = HalfToFloat(LoadLe16(bytes + 2 * i));
  } else if (encoding == "16UC1") {
    for (size_t i = 0; i < values.size(); ++i) {
      const uint16_t mm = LoadLe16(bytes + 2 * i);
      values[i] = mm == 0 ? std::nanf("")
                          : static_cast<float>(mm / kMillimetresPerMetre);
    }
  } else if (encoding == "16UC4") {  // codes, exact in float
    for (size_t i = 0; i < values.size(); ++i) values[i] = LoadLe16(bytes + 2 * i);
  } else {  // 8UC1
    for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(bytes[i]);
  }
  return values;
}

int ImageChannels(const v1::Image& image) {
  absl::StatusOr<WireLayout> layout = LayoutOf(image.encoding());
  return layout.ok() ? static_cast<int>(layout->channels) : 0;
}

absl::Status EncodeMomentDepth(const MomentDepthMap& map, bool from_returns,
                               const PixelRect& rect, v1::Compression compression,
                               v1::Image* out) {
  const ImageGeometry sensor = map.geometry;
  assert(RectInside(rect, sensor));
  const bool optimized = map.options.format == MomentMapFormat::kOptimized64;
  const int bytes_per_channel = optimized ? 2 : 4;
  const size_t texel_values = static_cast<size_t>(sensor.pixel_count()) * 4;
  if ((optimized ? map.quantized.size() : map.moments.size()) != texel_values) {
    return absl::InternalError(absl::StrCat("moment depth map of ", sensor.width, "x",
                                            sensor.height, " holds no texels of its format"));
  }
  std::string raw(static_cast<size_t>(rect.pixel_count()) * 4 * bytes_per_channel, '\0');
  char* write = raw.data();
  for (int row = rect.y; row < rect.y + rect.height; ++row) {
    const size_t first = (static_cast<size_t>(row) * sensor.width + rect.x) * 4;
    for (size_t i = first; i < first + static_cast<size_t>(rect.width) * 4; ++i) {
      if (optimized) {
        StoreLe16(map.quantized[i], write);
      } else {
        StoreLe32(std::bit_cast<uint32_t>(map.moments[i]), write);
      }
      write += bytes_per_channel;
    }
  }
  if (absl::Status status = SetData(std::move(raw), compression, out); !status.ok()) {
    return status;
  }
  SetGeometry(rect, 4 * bytes_per_channel, optimized ? "16UC4" : "32FC4", out);
  v1::MomentDepthInfo* info = out->mutable_moment_depth();
  const MomentBias bias = optimized ? kQuantized16MomentBias : kFloatMomentBias;
  info->set_near_m(map.options.normalisation.near_m);
  info->set_far_m(map.options.normalisation.far_m);
  info->set_sigma_px(map.options.sigma_px);
  info->set_bits(optimized ? 64 : 128);
  info->set_from_returns(from_returns);
  info->set_bias_alpha(bias.alpha);
  info->set_bias_b_star(bias.b_star_even);
  info->set_empty_pixels(static_cast<uint64_t>(map.empty_texels));
  info->set_clamped_depths(static_cast<uint64_t>(map.clamped_depths));
  return absl::OkStatus();
}

absl::StatusOr<MomentDepthMap> DecodeMomentDepth(const v1::Image& image) {
  const auto data_loss = [&image](auto&&... parts) {
    return absl::DataLossError(absl::StrCat("image \"", image.name(), "\": ", parts...));
  };
  if (!image.has_moment_depth()) {
    return data_loss("no moment_depth info. Violated constraint: MOMENT_DEPTH images carry it");
  }
  const v1::MomentDepthInfo& info = image.moment_depth();
  MomentDepthMap map;
  map.options.normalisation = {.near_m = info.near_m(), .far_m = info.far_m()};
  map.options.sigma_px = info.sigma_px();
  if (info.bits() == 64 && image.encoding() == "16UC4") {
    map.options.format = MomentMapFormat::kOptimized64;
  } else if (info.bits() == 128 && image.encoding() == "32FC4") {
    map.options.format = MomentMapFormat::kFloat128;
  } else {
    return data_loss("bits=", info.bits(), " with encoding=\"", image.encoding(),
                     "\". Violated constraint: 64 with 16UC4 or 128 with 32FC4");
  }
  if (absl::Status status = map.options.Validate(); !status.ok()) {
    return data_loss("moment_depth: ", status.message());
  }
  absl::StatusOr<std::vector<float>> values = DecodeImage(image);
  if (!values.ok()) return values.status();
  map.geometry = {static_cast<int>(image.width()), static_cast<int>(image.height())};
  if (map.options.format == MomentMapFormat::kOptimized64) {
    map.quantized.assign(values->begin(), values->end());  // codes 0..65535, exact in float
  } else {
    for (size_t i = 0; i < values->size(); ++i) {
      if (!std::isfinite((*values)[i])) {
        return data_loss("moment ", i % 4 + 1, " of pixel ", i / 4, " is ", (*values)[i],
                         ". Violated constraint: finite");
      }
    }
    map.moments = *std::move(values);
  }
  map.empty_texels = static_cast<int64_t>(info.empty_pixels());
  map.clamped_depths = static_cast<int64_t>(info.clamped_depths());
  return map;
}

// Bit layouts: float is 1 sign, 8 exponent (bias 127), 23 mantissa bits; half is 1 sign,
// 5 exponent (bias 15), 10 mantissa bits (IEEE 754-2008, binary32 and binary16).
uint16_t FloatToHalf(float value) {
  const uint32_t bits = std::bit_cast<uint32_t>(value);
  const uint32_t sign = (bits >> 16) & 0x8000;
  const uint32_t exponent = (bits >> 23) & 0xFF;
  const uint32_t mantissa = bits & 0x7FFFFF;

  if (exponent == 0xFF) {
    if (mantissa == 0) return static_cast<uint16_t>(sign | 0x7C00);  // infinity
    // NaN: keep the top payload bits and set the quiet bit, so the payload cannot become 0
    // (which would read as infinity).
    return static_cast<uint16_t>(sign | 0x7C00 | 0x200 | (mantissa >> 13));
  }
  // |value| >= 2^16 is beyond rounding distance of the largest half, 65504: infinity.
  if (exponent >= 127 + 16) return static_cast<uint16_t>(sign | 0x7C00);
  if (exponent >= 127 - 14) {
    // Normal half. Dropping 13 mantissa bits; a carry out of the mantissa correctly bumps the
    // exponent, and from 0x7BFF to 0x7C00 gives infinity for [65520, 65536).
    uint32_t half = ((exponent - (127 - 15)) << 10) | (mantissa >> 13);
    const uint32_t rest = mantissa & 0x1FFF;
    if (rest > 0x1000 || (rest == 0x1000 && (half & 1))) ++half;
    return static_cast<uint16_t>(sign | half);
  }
  // Below 2^-25 (half of the smallest subnormal 2^-24, tie included) rounds to zero; this
  // also covers float zeros and subnormals.
  if (exponent < 127 - 25) return static_cast<uint16_t>(sign);
  // Subnormal half: value = significand * 2^(exponent - 150), in units of 2^-24 that is
  // significand >> (126 - exponent), with shift in [14, 24].
  const uint32_t significand = mantissa | 0x800000;
  const uint32_t shift = 126 - exponent;
  uint32_t half = significand >> shift;
  const uint32_t rest = significand & ((uint32_t{1} << shift) - 1);
  const uint32_t halfway = uint32_t{1} << (shift - 1);
  // A carry to 0x400 is the smallest normal half, as it should be.
  if (rest > halfway || (rest == halfway && (half & 1))) ++half;
  return static_cast<uint16_t>(sign | half);
}

float HalfToFloat(uint16_t bits) {
  const uint32_t sign = uint32_t{bits & 0x8000u} << 16;
  const uint32_t exponent = (bits >> 10) & 0x1F;
  const uint32_t mantissa = bits & 0x3FF;
  if (exponent == 0x1F) {  // infinity or NaN, payload kept
    return std::bit_cast<float>(sign | 0x7F800000 | (mantissa << 13));
  }
  if (exponent == 0) {  // zero or subnormal: mantissa * 2^-24, exact in float
    const float magnitude = static_cast<float>(mantissa) * 0x1p-24f;
    return sign != 0 ? -magnitude : magnitude;
  }
  return std::bit_cast<float>(sign | ((exponent + (127 - 15)) << 23) | (mantissa << 13));
}

}  // namespace transient::wire
