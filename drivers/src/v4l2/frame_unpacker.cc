// Unpacking V4L2 raw ToF buffers (frame_unpacker.h).
#include "v4l2/frame_unpacker.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace transient::v4l2 {
namespace {

struct ContainerInfo {
  uint32_t fourcc;
  Container container;
  int container_bits;  // the bits a sample can have in it
};

constexpr ContainerInfo kContainers[] = {
    {kFourccY12, Container::kLittleEndian16, 12},
    {kFourccSBGGR12, Container::kLittleEndian16, 12},
    {kFourccY16, Container::kLittleEndian16, 16},
    {kFourccY12P, Container::kMipiRaw12, 12},
    {kFourccSBGGR12P, Container::kMipiRaw12, 12},
};

const ContainerInfo* FindContainer(uint32_t fourcc) {
  for (const ContainerInfo& info : kContainers) {
    if (info.fourcc == fourcc) return &info;
  }
  return nullptr;
}

std::string KnownFourccs() {
  std::string names;
  for (const ContainerInfo& info : kContainers) {
    absl::StrAppend(&names, names.empty() ? "" : ", ", FourccName(info.fourcc));
  }
  return names;
}

}  // namespace

std::string FourccName(uint32_t fourcc) {
  std::string name;
  for (int i = 0; i < 4; ++i) {
    const auto c = static_cast<unsigned char>((fourcc >> (8 * i)) & 0xff);
    if (c >= 0x20 && c < 0x7f) {
      name.push_back(static_cast<char>(c));
    } else {
      absl::StrAppend(&name, absl::StrFormat("\\x%02x", c));
    }
  }
  // Trailing spaces pad short names ('Y12 '); they say nothing to a reader.
  while (!name.empty() && name.back() == ' ') name.pop_back();
  return name;
}

absl::Status SampleFormat::Validate() const {
  const ContainerInfo* info = FindContainer(fourcc);
  if (info == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat("pixel format '", FourccName(fourcc),
                                                   "' is not one we read; we read ",
                                                   KnownFourccs()));
  }
  if (bits < 1 || bits > info->container_bits) {
    return absl::InvalidArgumentError(absl::StrCat("bits=", bits, " is outside 1..",
                                                   info->container_bits, " for '",
                                                   FourccName(fourcc), "'"));
  }
  if (shift < 0 || bits + shift > info->container_bits) {
    return absl::InvalidArgumentError(
        absl::StrCat("shift=", shift, " with bits=", bits, " does not fit the ",
                     info->container_bits, " bits of a '", FourccName(fourcc), "' sample"));
  }
  return absl::OkStatus();
}

absl::StatusOr<size_t> RowBytes(uint32_t fourcc, int width) {
  const ContainerInfo* info = FindContainer(fourcc);
  if (info == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("pixel format '", FourccName(fourcc), "' is not one we read"));
  }
  if (width <= 0) return absl::InvalidArgumentError(absl::StrCat("width ", width, " is not positive"));
  if (info->container == Container::kMipiRaw12) {
    if (width % 2 != 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "width ", width, " is odd; '", FourccName(fourcc), "' packs samples in pairs"));
    }
    return static_cast<size_t>(width) / 2 * 3;
  }
  return static_cast<size_t>(width) * 2;
}

absl::Status CheckLayout(const FrameLayout& layout, const SampleFormat& format) {
  if (layout.geometry.width <= 0 || layout.geometry.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("frame size ", layout.geometry.width, "x",
                                                   layout.geometry.height, " is not positive"));
  }
  absl::StatusOr<size_t> row = RowBytes(format.fourcc, layout.geometry.width);
  if (!row.ok()) return row.status();
  if (layout.bytes_per_line < *row) {
    return absl::InvalidArgumentError(absl::StrCat(
        "bytes per line ", layout.bytes_per_line, " is less than the ", *row, " bytes of a row of ",
        layout.geometry.width, " '", FourccName(format.fourcc), "' samples"));
  }
  return absl::OkStatus();
}

absl::Status Unpack(std::span<const uint8_t> data, const FrameLayout& layout,
                    const SampleFormat& format, std::span<float> pixels) {
  if (absl::Status status = format.Validate(); !status.ok()) return status;
  if (absl::Status status = CheckLayout(layout, format); !status.ok()) return status;
  const int width = layout.geometry.width, height = layout.geometry.height;
  if (static_cast<int64_t>(pixels.size()) != layout.geometry.pixel_count()) {
    return absl::InvalidArgumentError(absl::StrCat("output holds ", pixels.size(), " pixels, the ",
                                                   width, "x", height, " frame has ",
                                                   layout.geometry.pixel_count()));
  }
  const size_t row_bytes = *RowBytes(format.fourcc, width);
  const size_t needed = layout.bytes_per_line * static_cast<size_t>(height - 1) + row_bytes;
  if (data.size() < needed) {
    return absl::DataLossError(absl::StrCat("short buffer: ", data.size(), " bytes, a ", width,
                                            "x", height, " '", FourccName(format.fourcc),
                                            "' frame with ", layout.bytes_per_line,
                                            " bytes per line needs ", needed));
  }
  const bool packed = FindContainer(format.fourcc)->container == Container::kMipiRaw12;
  const uint32_t used_bits = static_cast<uint32_t>(format.bits + format.shift);
  const uint32_t mask = (uint32_t{1} << format.bits) - 1;
  const int32_t sign_bit = int32_t{1} << (format.bits - 1);
  for (int y = 0; y < height; ++y) {
    const uint8_t* row = data.data() + layout.bytes_per_line * static_cast<size_t>(y);
    float* out = pixels.data() + static_cast<size_t>(y) * width;
    for (int x = 0; x < width; ++x) {
      uint32_t raw;
      if (packed) {
        // MIPI RAW12: byte 0 = P0[11:4], byte 1 = P1[11:4], byte 2 = P1[3:0] << 4 | P0[3:0].
        const uint8_t* pair = row + static_cast<size_t>(x / 2) * 3;
        raw = (x % 2 == 0) ? (uint32_t{pair[0]} << 4) | (pair[2] & 0x0fu)
                           : (uint32_t{pair[1]} << 4) | (pair[2] >> 4);
      } else {
        const uint8_t* word = row + static_cast<size_t>(x) * 2;
        raw = uint32_t{word[0]} | uint32_t{word[1]} << 8;
      }
      if ((raw >> used_bits) != 0) {
        return absl::DataLossError(absl::StrFormat(
            "sample 0x%04x at pixel (%d, %d) has bits above bit %d set: not %d-bit samples%s", raw,
            x, y, used_bits - 1, format.bits,
            format.shift == 0 ? " (if the driver puts them high in the word, set shift)" : ""));
      }
      const uint32_t value = (raw >> format.shift) & mask;
      if (format.is_signed) {
        out[x] = static_cast<float>(static_cast<int32_t>(value ^ static_cast<uint32_t>(sign_bit)) -
                                    sign_bit);
      } else {
        out[x] = static_cast<float>(value);
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace transient::v4l2
