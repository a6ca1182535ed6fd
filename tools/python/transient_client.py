#!/usr/bin/python3
"""A minimal Python client of transientd: prints its info and frame rates, saves one depth image.

A thin user of the `transient` package beside it (tools/python/transient, see README.md). Run it
with Debian's python3 (python3-grpcio, python3-protobuf, python3-numpy), not a pyenv python
without grpc. From a source tree it finds the package beside it and the stubs that the build
generates from proto/ (`ninja transient_proto_python`, into build/proto/python):

    /usr/bin/python3 tools/python/transient_client.py --connect 127.0.0.1:50051 \\
        --frames 30 --products depth,range --out depth.npy

After `make install` the package and its stubs are found on Debian's sys.path (prefix
/usr/local), and the script runs from anywhere.

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

CONNECT_TIMEOUT_S = 5.0
REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD_STUBS = os.path.join(REPO_ROOT, "build", "proto", "python")

EXIT_RPC_ERROR = 1
EXIT_USAGE = 2


class ClientError(Exception):
    """An error of this script (not of an RPC): its message is printed, then exit 2."""


def import_transient(stubs_dir, explicit):
    """The transient package, with transient.v1 from stubs_dir when that holds the stubs."""
    expected = os.path.join(stubs_dir, "transient", "v1", "transient_pb2.py")
    if os.path.isfile(expected):
        sys.path.insert(0, os.path.abspath(stubs_dir))  # before the import: see __init__.py
    elif explicit:
        raise ClientError(f"no generated stubs at {expected}; build them with "
                          "`ninja transient_proto_python` and pass the build's proto/python as "
                          "--stubs or TRANSIENT_PY_STUBS")
    try:
        import transient  # pylint: disable=import-outside-toplevel
    except ImportError as error:
        raise ClientError(f"{error}; or pass the stubs' directory as --stubs") from None
    return transient


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


def stream(client, args, products):
    """Receives args.frames frames; returns the last depth image (or None) and prints rates."""
    frames_in = client.frames(products, encoding=args.encoding, compression=args.compression,
                              max_rate_hz=args.max_rate)
    depth = None
    frames = missed = 0
    window_frames = window_missed = 0
    start = window_start = time.monotonic()
    try:
        for frame in frames_in:
            if frame.announcement:
                print(f"source state: {frame.state.upper()}")
                continue
            frames += 1
            window_frames += 1
            missed += frame.missed
            window_missed += frame.missed
            for image in frame.images.values():
                if image.product == "depth":
                    depth = image.array
            now = time.monotonic()
            if now - window_start >= 1.0:
                print(f"{now - start:6.1f} s: {window_frames / (now - window_start):6.2f} "
                      f"frames/s, {window_missed} missed, sequence {frame.sequence}, "
                      f"latency {frame.latency_s * 1e3:.1f} ms")
                window_start, window_frames, window_missed = now, 0, 0
            if frames >= args.frames:
                break
    finally:
        frames_in.close()  # cancels the stream
    elapsed = time.monotonic() - start
    rate = frames / elapsed if elapsed > 0 else 0.0
    print(f"received {frames} frames in {elapsed:.2f} s ({rate:.2f} frames/s), {missed} missed")
    return depth


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--connect", default="127.0.0.1:50051", help="daemon address host:port")
    parser.add_argument("--stubs", default=None,
                        help="directory of the generated transient/v1/transient_pb2*.py "
                        "(default: $TRANSIENT_PY_STUBS, else build/proto/python if it holds "
                        "them, else the installed package's)")
    parser.add_argument("--frames", type=int, default=30, help="frames to receive (default 30)")
    parser.add_argument("--out", default="depth.npy",
                        help="where to save the last depth image (.npy, float32 metres, NaN "
                        "invalid); '' saves nothing")
    parser.add_argument("--products", default="depth,range",
                        help="comma-separated product names or numbers (default depth,range)")
    parser.add_argument("--encoding", default="float32",
                        choices=["float32", "float16", "mm", "uint16_mm"])
    parser.add_argument("--compression", default="none", choices=["none", "zstd"])
    parser.add_argument("--max-rate", type=float, default=0.0,
                        help="frames per second at most; 0 = every frame")
    security = parser.add_argument_group(
        "security", "a daemon that requires TLS, a client certificate or a token")
    security.add_argument("--ca", help="connect with TLS, trusting this PEM CA")
    security.add_argument("--cert", help="PEM client certificate (needs --key, --ca)")
    security.add_argument("--key", help="the PEM private key of --cert")
    security.add_argument("--server-name", help="the name on the daemon's certificate")
    security.add_argument("--token-file", help="send the bearer token in this file")
    args = parser.parse_args(argv)
    if args.frames < 1:
        parser.error(f"--frames = {args.frames}. Violated constraint: --frames >= 1")

    try:
        import numpy as np  # pylint: disable=import-outside-toplevel
    except ImportError:
        print(f"error: {sys.executable} has no numpy module; run /usr/bin/python3 with Debian's "
              "python3-numpy and python3-grpcio", file=sys.stderr)
        return EXIT_USAGE

    try:
        stubs = args.stubs or os.environ.get("TRANSIENT_PY_STUBS")
        transient = import_transient(stubs or BUILD_STUBS, explicit=bool(stubs))
    except ClientError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    from transient.v1 import transient_pb2 as pb2  # pylint: disable=import-outside-toplevel

    try:
        items = [s.strip() for s in args.products.split(",") if s.strip()]
        try:
            products = transient.product_numbers(int(s) if s.isdigit() else s for s in items)
        except ValueError as error:
            raise ClientError(f"--products: {error}") from None
        if not products:
            raise ClientError("--products: expected at least one product")
        if args.out and pb2.DEPTH not in products:
            raise ClientError("--out needs depth among --products (or --out '')")
        if args.compression == "zstd":
            transient.images.require_zstandard()
        try:
            client = transient.Client(args.connect, connect_timeout_s=CONNECT_TIMEOUT_S,
                                      ca_file=args.ca, cert_file=args.cert, key_file=args.key,
                                      server_name=args.server_name, token_file=args.token_file)
        except ValueError as error:
            raise ClientError(str(error)) from None
        with client:
            print_info(client.info(), pb2)
            depth = stream(client, args, products)
    except ClientError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except transient.RpcError as error:
        print(f"error: RPC failed: {error.code.name}: {error.details}", file=sys.stderr)
        return EXIT_RPC_ERROR
    except transient.TransientError as error:  # unreachable, zstandard missing, a bad image
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
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
