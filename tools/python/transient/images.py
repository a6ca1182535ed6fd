"""Images of the wire protocol (transient.v1.Image) as numpy arrays with their units.

The inverse of the daemon's encoder (wire/image_codec.cc), with the same checks: every field of
an image is checked against the others before a byte of it is used, and an image that does not
add up raises ImageError instead of becoming an array of garbage.
"""

import dataclasses
import math

import numpy as np

from transient.errors import ImageError, TransientError
from transient.v1 import transient_pb2 as pb2

# The largest image decoded: its values and its decompressed data stay within 256 MiB, as in the
# C++ decoder, so that a corrupt or hostile header cannot make a client allocate more.
MAX_DECODED_BYTES = 256 << 20

# Wire encoding -> (numpy dtype of one value, little endian; values per pixel).
_LAYOUTS = {
    "32FC1": ("<f4", 1),
    "16FC1": ("<f2", 1),  # IEEE binary16
    "16UC1": ("<u2", 1),  # REP 118: millimetres, 0 = invalid
    "8UC1": ("u1", 1),  # FLAGS: PixelFlag bits
    "16UC4": ("<u2", 4),  # MOMENT_DEPTH, 64 bits: codes of thesis eq. 4.4
    "32FC4": ("<f4", 4),  # MOMENT_DEPTH, 128 bits: b1..b4
}
_MOMENT_DEPTH_BITS = {"16UC4": 64, "32FC4": 128}
_CODES = 65535.0
_MILLIMETRES_PER_METRE = 1000.0


@dataclasses.dataclass(frozen=True)
class Image:
    """One image of a frame, decoded.

    name: the product's name, and for products of several planes the plane's: "depth",
        "slices/12", "q_real/2", "direct".
    product: the product in lower case ("depth"); its number if this client does not know it.
    array: the values, row-major, (height, width), or (height, width, 4) for moment depth.
        RANGE and DEPTH are float32 metres with NaN where invalid, whatever the encoding: 16UC1
        millimetres become metres and their 0 becomes NaN (raw=True keeps uint16 millimetres,
        0 = invalid). 16FC1 becomes float32 (raw: float16). FLAGS is uint8 PixelFlag bits.
        MOMENT_DEPTH is float32 power moments (b1, b2, b3, b4) of the normalised depth in
        [-1, 1] (see `moment_depth` for the normalisation), dequantized from 16UC4 codes by the
        inverse of thesis eq. 4.4 (raw: the uint16 codes).
    unit: the unit of the array's values: "m", "mm" (raw 16UC1 only), "sensor", "sensor/rad",
        "1/sensor", "bits", "1".
    encoding: the encoding on the wire: 32FC1, 16FC1, 16UC1, 8UC1, 16UC4, 32FC4.
    time_of_flight_ns: SLICES and CUMULATIVE: the plane's round-trip time of flight, ns; else 0.
    moment_depth: MOMENT_DEPTH: its transient.v1.MomentDepthInfo (near_m, far_m, bias); else None.
    """

    name: str
    product: object
    array: np.ndarray
    unit: str
    encoding: str
    time_of_flight_ns: float = 0.0
    moment_depth: object = None


def require_zstandard():
    """The zstandard module, or a TransientError that says how to install it."""
    try:
        import zstandard  # pylint: disable=import-outside-toplevel
    except ImportError:
        raise TransientError(
            "zstd-compressed images need the Python module zstandard (Debian: apt install "
            "python3-zstandard); or ask for compression='none'") from None
    return zstandard


def decode_image(message, raw=False):
    """Decodes a transient.v1.Image into an Image (see there for the arrays and their units).

    raw=True keeps the integers of 16UC1 (millimetres) and 16UC4 (codes) and the half floats
    of 16FC1 instead of converting them. Raises ImageError for an unknown encoding or
    compression, a size, step or length that does not add up, or corrupt zstd data, and
    TransientError when zstd data arrives but the zstandard module is missing.
    """
    name, encoding = message.name, message.encoding
    layout = _LAYOUTS.get(encoding)
    if layout is None:
        raise ImageError(f'image "{name}": encoding "{encoding}" is unknown. Violated '
                         f"constraint: one of {', '.join(_LAYOUTS)}")
    dtype, channels = np.dtype(layout[0]), layout[1]
    width, height = message.width, message.height
    if width == 0 or height == 0:
        raise ImageError(f'image "{name}": width={width}, height={height}. Violated constraint: '
                         "width, height > 0")
    if width * height * channels * 4 > MAX_DECODED_BYTES:  # as float32
        raise ImageError(f'image "{name}": {width}x{height} pixels of {channels} values. '
                         f"Violated constraint: at most {MAX_DECODED_BYTES >> 20} MiB decoded")
    pixel_bytes = channels * dtype.itemsize
    if message.step != width * pixel_bytes:
        raise ImageError(f'image "{name}": step={message.step}. Violated constraint: step = '
                         f"width * {pixel_bytes} bytes per pixel of {encoding} = "
                         f"{width * pixel_bytes}")
    info = _moment_depth_info(message)
    data = _uncompressed(message, height * message.step)
    shape = (height, width) if channels == 1 else (height, width, channels)
    values = np.frombuffer(data, dtype=dtype).reshape(shape)
    array, unit = _in_units(values, encoding, message.unit, raw)
    try:
        product = pb2.Product.Name(message.product).lower()
    except ValueError:
        product = message.product  # a product newer than this client
    return Image(name=name, product=product, array=array, unit=unit, encoding=encoding,
                 time_of_flight_ns=message.time_of_flight_ns, moment_depth=info)


def dequantize_moment_depth(codes):
    """Power moments (b1, b2, b3, b4), float64, from the 16UC4 codes of thesis eq. 4.4.

    The inverse of the optimized affine quantization theta(b) = (1.5 b1 - 2 b3 + 0.5,
    4 b2 - 4 b4, (sqrt(3)/2) b1 - (2 sqrt(3)/9) b3 + 0.5, 0.5 b2 + 0.5 b4), code =
    round(65535 theta), as reconstruct/moment_quantization.cc. `codes` is (..., 4) uint16.
    """
    theta = np.asarray(codes, dtype=np.float64) / _CODES
    x, y = theta[..., 0] - 0.5, theta[..., 2] - 0.5
    sqrt3 = math.sqrt(3.0)
    return np.stack([-x / 3.0 + sqrt3 * y,
                     0.125 * theta[..., 1] + theta[..., 3],
                     -0.75 * x + 0.75 * sqrt3 * y,
                     theta[..., 3] - 0.125 * theta[..., 1]], axis=-1)


def _moment_depth_info(message):
    """The MomentDepthInfo of a 16UC4/32FC4 image, checked against its encoding; else None."""
    bits = _MOMENT_DEPTH_BITS.get(message.encoding)
    if bits is None:
        return None
    if not message.HasField("moment_depth") or message.moment_depth.bits != bits:
        got = message.moment_depth.bits if message.HasField("moment_depth") else "none"
        raise ImageError(f'image "{message.name}": moment_depth.bits={got} with encoding '
                         f'"{message.encoding}". Violated constraint: 64 with 16UC4 or 128 with '
                         "32FC4")
    return message.moment_depth


def _uncompressed(message, expected):
    """The image's data, decompressed, exactly `expected` bytes long."""
    name, data = message.name, message.data
    if message.compression == pb2.COMPRESSION_NONE:
        if len(data) != expected:
            raise ImageError(f'image "{name}": data holds {len(data)} bytes. Violated '
                             f"constraint: height * step = {expected}")
        return data
    if message.compression != pb2.ZSTD:
        raise ImageError(f'image "{name}": compression={message.compression}. Violated '
                         "constraint: COMPRESSION_NONE or ZSTD")
    zstandard = require_zstandard()
    try:
        declared = zstandard.frame_content_size(data)
    except zstandard.ZstdError:
        raise ImageError(f'image "{name}": data ({len(data)} bytes) does not start with a zstd '
                         "frame header") from None
    if declared != expected:  # -1: not declared, and then no bound on what it would take
        raise ImageError(f'image "{name}": the zstd frame declares '
                         f"{'no size' if declared < 0 else f'{declared} bytes'}. Violated "
                         f"constraint: height * step = {expected}")
    decompressor = zstandard.ZstdDecompressor().decompressobj()
    try:
        out = decompressor.decompress(data)
    except zstandard.ZstdError as error:
        raise ImageError(f'image "{name}": corrupt zstd frame: {error}') from None
    if not decompressor.eof:
        raise ImageError(f'image "{name}": the zstd frame is truncated after {len(data)} bytes')
    if decompressor.unused_data:
        raise ImageError(f'image "{name}": {len(decompressor.unused_data)} bytes after the zstd '
                         "frame. Violated constraint: exactly one zstd frame")
    if len(out) != expected:
        raise ImageError(f'image "{name}": the zstd frame holds {len(out)} bytes. Violated '
                         f"constraint: height * step = {expected}")
    return out


def _in_units(values, encoding, unit, raw):
    """(array, unit) of wire values, converted to their unit unless raw; always a copy."""
    if encoding == "16UC1":
        if raw:
            return values.astype(np.uint16), "mm"
        metres = (values / _MILLIMETRES_PER_METRE).astype(np.float32)
        metres[values == 0] = np.nan
        return metres, "m"
    if encoding == "16FC1":
        return values.astype(np.float16 if raw else np.float32), unit
    if encoding == "16UC4" and not raw:
        return dequantize_moment_depth(values).astype(np.float32), unit
    return values.astype(values.dtype.newbyteorder("=")), unit
