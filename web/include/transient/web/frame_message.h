// The binary WebSocket message that carries one frame of transientd to the viewer page
// (docs/web.md "Messages"): a JSON header that describes the images, then their values, half
// floats or bytes, so that the page colour-maps them on its GPU without decoding anything.
//
//   bytes 0..3    "TRF1"
//   bytes 4..7    header length H, uint32 little endian
//   bytes 8..     the header, H bytes of UTF-8 JSON, padded with spaces to a multiple of 4
//   then          the images, each at the header's `offset` (from the payload's start, a
//                 multiple of 4) for `length` bytes: "f16" IEEE binary16 little endian, one
//                 per pixel, row-major (NaN = no value), or "u8" one byte per pixel
//
// Header: {"sequence", "captureTimeS", "latencyMs" (end of capture to the gateway), "missed"
// (frames the daemon dropped for the gateway), "width", "height", "images": [{"name", "unit",
// "type", "offset", "length", "tofNs" (slices only)}]}. The frame is the same for every page.
#pragma once

#include <cstdint>
#include <string>

#include "transient/client/frame_stream.h"

namespace transient::web {

inline constexpr char kFrameMagic[4] = {'T', 'R', 'F', '1'};

// The message of `frame` (kImages). Images of more than one value per pixel (moment depth
// maps) are left out.
std::string EncodeFrameMessage(const client::StreamFrame& frame);

}  // namespace transient::web
