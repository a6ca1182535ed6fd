#!/usr/bin/python3
"""A minimal Python client of transientd: prints its info and frame rates, saves one depth image.

Uses Debian's python3-grpcio, python3-protobuf and python3-numpy (run it with /usr/bin/python3,
not a pyenv python without grpc) and the stubs that the build generates from proto/ with protoc
and grpc_python_plugin (`ninja transient_proto_python`, into build/proto/python):

    /usr/bin/python3 tools/python/transient_client.py --connect 127.0.0.1:50051 \\
        --frames 30 --products depth,range --out depth.npy

It prints GetInfo (camera, schedule, calibration), then once a second the rate of frames
received and the frames missed (dropped for this client because it was slow), and a summary.
The last depth image received is saved as float32 metres, shape (height, width), NaN where
invalid; `--out ''` saves nothing. Images may be 32FC1, 16FC1 or 16UC1 (millimetres, 0 =
invalid); `--compression zstd` needs the Python module zstandard (Debian python3-zstandard).

Exit status: 0 on success, 1 when an RPC fails (its code and details are printed), 2 on a usage
error, missing stubs, or a daemon not reachable within 5 s.
"""

import argparse
import os
import sys
import time

import numpy as np

CONNECT_TIMEOUT_S = 5.0
REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEFAULT_STUBS = os.environ.get("TRANSIENT_PY_STUBS") or os.path.join(REPO_ROOT, "build", "proto",
                                                                      "python")

EXIT_RPC_ERROR = 1
EXIT_USAGE = 2


class ClientError(Exception):
    """An error of this client (not of an RPC): its message is printed, then exit 2."""


def load_stubs(stubs_dir):
    """Imports transient/v1/transient_pb2{,_grpc}.py from stubs_dir."""
    expected = os.path.join(stubs_dir, "transient", "v1", "transient_pb2.py")
    if not os.path.isfile(expected):
        raise ClientError(
            f"no generated stubs at {expected}; build them with `ninja transient_proto_python` "
            "and pass the build's proto/python as --stubs or TRANSIENT_PY_STUBS")
    sys.path.insert(0, os.path.abspath(stubs_dir))
    from transient.v1 import transient_pb2, transient_pb2_grpc  # pylint: disable=import-outside-toplevel
    return transient_pb2, transient_pb2_grpc


def parse_products(text, pb2):
    """'depth,range' or product numbers ('2,1') to Product values, in the order given."""
    products = []
    for item in filter(None, (s.strip() for s in text.split(","))):
        if item.isdigit():
            products.append(int(item))  # passed through; the daemon judges unknown numbers
            continue
        try:
            products.append(pb2.Product.Value(item.upper()))
        except ValueError:
            names = ", ".join(n.lower() for n in pb2.Product.keys() if n != "PRODUCT_UNSPECIFIED")
            raise ClientError(f"--products: unknown product '{item}'; expected some of {names}")
    if not products:
        raise ClientError("--products: expected at least one product")
    return products


def load_zstandard():
    """The zstandard module, or a ClientError saying how to get it."""
    try:
        import zstandard  # pylint: disable=import-outside-toplevel
    except ImportError:
        raise ClientError("zstd-compressed images need the Python module zstandard "
                          "(Debian: apt install python3-zstandard); use --compression none")
    return zstandard


# Wire encoding -> (numpy dtype, little endian).
_DTYPES = {"32FC1": "<f4", "16FC1": "<f2", "16UC1": "<u2", "8UC1": "u1"}


def decode_image(image, pb2):
    """An Image as a (height, width) numpy array; 16UC1 millimetres become float32 metres.

    Raises ClientError for an encoding, compression or size that does not add up.
    """
    dtype = _DTYPES.get(image.encoding)
    if dtype is None:
        raise ClientError(f"image {image.name}: unsupported encoding '{image.encoding}'; "
                          f"expected one of {', '.join(_DTYPES)}")
    data = image.data
    if image.compression == pb2.ZSTD:
        data = load_zstandard().ZstdDecompressor().decompress(data)
    elif image.compression != pb2.COMPRESSION_NONE:
        raise ClientError(f"image {image.name}: unknown compression {image.compression}")
    itemsize = np.dtype(dtype).itemsize
    width, height, step = image.width, image.height, image.step
    if step < width * itemsize or len(data) != step * height:
        raise ClientError(f"image {image.name}: {len(data)} bytes, expected step {step} >= "
                          f"{width} * {itemsize} and {step} * {height} bytes in all")
    rows = np.frombuffer(data, dtype=np.uint8).reshape(height, step)[:, :width * itemsize]
    pixels = rows.copy().view(dtype).reshape(height, width)
    if image.encoding == "16FC1":
        return pixels.astype(np.float32)
    if image.encoding == "16UC1":  # REP 118: millimetres, 0 = invalid
        metres = (pixels / 1000.0).astype(np.float32)
        metres[pixels == 0] = np.nan
        return metres
    if image.encoding == "32FC1":
        return pixels.astype(np.float32)
    return pixels


def print_info(info, pb2):
    cam, sched = info.camera, info.schedule
    print(f"camera: {cam.width}x{cam.height} {cam.model or '?'} serial {cam.serial or '?'}, "
          f"fx {cam.fx:.2f} fy {cam.fy:.2f} cx {cam.cx:.2f} cy {cam.cy:.2f}, "
          f"distortion [{', '.join(f'{d:.4g}' for d in cam.distortion)}]")
    print(f"source: {info.source_uri} ({pb2.SourceState.Name(info.state)}), "
          f"daemon {info.version}")
    # The daemon's description says it all when it has one.
    print("schedule: " + (sched.description or
                          f"f = {sched.base_frequency_hz / 1e6:.3f} MHz, order {sched.order}, "
                          f"sampling {sched.sampling}, zeroth {sched.zeroth}, takes {sched.takes}, "
                          f"{sched.raw_frames_per_frame} raw frames per frame") +
          f"; unambiguous range {info.unambiguous_range_m:.3f} m")
    print(f"calibration: {info.calibration}")
    print("products: " + ", ".join(pb2.Product.Name(p).lower() for p in info.products))


def stream(stub, args, pb2, products):
    """Receives args.frames frames; returns the last depth image (or None) and prints rates."""
    request = pb2.StreamRequest(
        products=products, max_rate_hz=args.max_rate,
        encoding=pb2.Encoding.Value(args.encoding.upper()),
        compression=pb2.ZSTD if args.compression == "zstd" else pb2.COMPRESSION_NONE)
    responses = stub.StreamFrames(request)
    depth = None
    frames = missed = 0
    window_frames = window_missed = 0
    start = window_start = time.monotonic()
    try:
        for frame in responses:
            if not frame.images:  # a state announcement, not a frame
                print(f"source state: {pb2.SourceState.Name(frame.state)}")
                continue
            frames += 1
            window_frames += 1
            missed += frame.missed
            window_missed += frame.missed
            for image in frame.images:
                if image.product == pb2.DEPTH:
                    depth = decode_image(image, pb2)
            now = time.monotonic()
            if now - window_start >= 1.0:
                print(f"{now - start:6.1f} s: {window_frames / (now - window_start):6.2f} "
                      f"frames/s, {window_missed} missed, sequence {frame.sequence}, "
                      f"latency {frame.latency_s * 1e3:.1f} ms")
                window_start, window_frames, window_missed = now, 0, 0
            if frames >= args.frames:
                break
    finally:
        responses.cancel()
    elapsed = time.monotonic() - start
    rate = frames / elapsed if elapsed > 0 else 0.0
    print(f"received {frames} frames in {elapsed:.2f} s ({rate:.2f} frames/s), {missed} missed")
    return depth


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--connect", default="127.0.0.1:50051", help="daemon address host:port")
    parser.add_argument("--stubs", default=DEFAULT_STUBS,
                        help="directory of the generated transient/v1/transient_pb2*.py "
                        "(default: $TRANSIENT_PY_STUBS, else build/proto/python)")
    parser.add_argument("--frames", type=int, default=30, help="frames to receive (default 30)")
    parser.add_argument("--out", default="depth.npy",
                        help="where to save the last depth image (.npy, float32 metres, NaN "
                        "invalid); '' saves nothing")
    parser.add_argument("--products", default="depth,range",
                        help="comma-separated product names or numbers (default depth,range)")
    parser.add_argument("--encoding", default="float32",
                        choices=["float32", "float16", "uint16_mm"])
    parser.add_argument("--compression", default="none", choices=["none", "zstd"])
    parser.add_argument("--max-rate", type=float, default=0.0,
                        help="frames per second at most; 0 = every frame")
    args = parser.parse_args(argv)
    if args.frames < 1:
        parser.error(f"--frames = {args.frames}. Violated constraint: --frames >= 1")

    try:
        import grpc  # pylint: disable=import-outside-toplevel
    except ImportError:
        print(f"error: {sys.executable} has no grpc module; run /usr/bin/python3 with Debian's "
              "python3-grpcio", file=sys.stderr)
        return EXIT_USAGE

    try:
        pb2, pb2_grpc = load_stubs(args.stubs)
        products = parse_products(args.products, pb2)
        if args.out and pb2.DEPTH not in products:
            raise ClientError("--out needs depth among --products (or --out '')")
        if args.compression == "zstd":
            load_zstandard()
        # Frames can exceed gRPC's default 4 MB message limit.
        options = [("grpc.max_receive_message_length", -1)]
        with grpc.insecure_channel(args.connect, options=options) as channel:
            try:
                grpc.channel_ready_future(channel).result(timeout=CONNECT_TIMEOUT_S)
            except grpc.FutureTimeoutError:
                raise ClientError(f"transientd at {args.connect} not reachable within "
                                  f"{CONNECT_TIMEOUT_S:g} s")
            stub = pb2_grpc.TransientStub(channel)
            print_info(stub.GetInfo(pb2.GetInfoRequest(), timeout=10), pb2)
            depth = stream(stub, args, pb2, products)
    except ClientError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except grpc.RpcError as error:
        print(f"error: RPC failed: {error.code().name}: {error.details()}", file=sys.stderr)
        return EXIT_RPC_ERROR
    except KeyboardInterrupt:
        return 130

    if args.out:
        if depth is None:
            print("error: no depth image received", file=sys.stderr)
            return EXIT_RPC_ERROR
        np.save(args.out, depth)
        finite = np.isfinite(depth)
        summary = (f"{np.nanmin(depth):.3f}..{np.nanmax(depth):.3f} m" if finite.any() else
                   "all invalid")
        print(f"saved depth {depth.shape[1]}x{depth.shape[0]} to {args.out}: {summary}, "
              f"{finite.mean() * 100:.1f}% valid")
    return 0


if __name__ == "__main__":
    sys.exit(main())
