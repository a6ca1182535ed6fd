#!/usr/bin/python3
"""transientd seen from Python (Debian's grpcio): the example client, and the standard services.

    python_client_test.py CHECK --transientd PATH --client PATH --stubs DIR --workdir DIR

CHECK `client`: tools/python/transient_client.py (a thin user of the transient package) saves a
plausible depth image, also from 16UC1 millimetres, reports an RPC error (unknown product) with
its code and exit 1, and an unreachable daemon with exit 2.
CHECK `standard_services`: health checking and server reflection answer raw-bytes requests.
Both start transientd on a free port with a small simulated sensor and stop it with SIGTERM,
which must end it with status 0 within 10 s (tests/python/transientd_fixture.py).
"""

import argparse
import os
import shutil
import subprocess
import sys

import numpy as np

# The daemon fixture shared with the tests of the transient package.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
from transientd_fixture import HEIGHT, WIDTH, Daemon, closed_address  # noqa: E402

RPC_TIMEOUT_S = 10.0
# The mirrors scene lies between these depths; a wrong unit (mm) or garbage falls outside.
PLAUSIBLE_DEPTH_M = (0.5, 10.0)
MIN_FINITE_FRACTION = 0.5

# Health: HealthCheckResponse{status: SERVING} is field 1 (varint) = 1.
SERVING = b"\x08\x01"


def fail(message):
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def run_client(args, daemon_address, *client_args):
    command = [sys.executable, args.client, "--connect", daemon_address, "--stubs", args.stubs,
               *client_args]
    print("$ " + " ".join(command))
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    print(result.stdout + result.stderr)
    return result


def check_client(args, daemon):
    out = os.path.join(args.workdir, "depth.npy")
    result = run_client(args, daemon.address, "--frames", "10", "--out", out)
    if result.returncode != 0:
        fail(f"client exited with {result.returncode}")
    if "received 10 frames" not in result.stdout or "camera: 48x36" not in result.stdout:
        fail("client output lacks its info or summary lines")
    depth = np.load(out)
    if depth.shape != (HEIGHT, WIDTH) or depth.dtype != np.float32:
        fail(f"depth is {depth.dtype} {depth.shape}, expected float32 ({HEIGHT}, {WIDTH})")
    finite = np.isfinite(depth)
    if finite.mean() < MIN_FINITE_FRACTION:
        fail(f"only {finite.mean():.0%} of depth is finite")
    low, high = PLAUSIBLE_DEPTH_M
    values = depth[finite]
    if values.min() < low or values.max() > high:
        fail(f"depth spans {values.min():.3f}..{values.max():.3f} m, outside {low}..{high} m")
    print(f"ok: depth.npy float32 {depth.shape}, {finite.mean():.0%} finite, "
          f"{values.min():.3f}..{values.max():.3f} m")

    # Millimetres on the wire come back as the same metres (within half a millimetre).
    out_mm = os.path.join(args.workdir, "depth_mm.npy")
    result = run_client(args, daemon.address, "--frames", "3", "--encoding", "uint16_mm",
                        "--out", out_mm)
    if result.returncode != 0:
        fail(f"client with --encoding uint16_mm exited with {result.returncode}")
    depth_mm = np.load(out_mm)
    if depth_mm.dtype != np.float32 or depth_mm.shape != (HEIGHT, WIDTH):
        fail(f"16UC1 depth is {depth_mm.dtype} {depth_mm.shape}")
    mm_values = depth_mm[np.isfinite(depth_mm)]
    if mm_values.size == 0 or mm_values.min() < low or mm_values.max() > high:
        fail("16UC1 depth is not in metres within the plausible range")
    print("ok: 16UC1 depth decodes to metres")

    # An unknown product number is the daemon's INVALID_ARGUMENT, printed with exit 1.
    result = run_client(args, daemon.address, "--frames", "1", "--products", "42", "--out", "")
    if result.returncode != 1:
        fail(f"client with product 42 exited with {result.returncode}, expected 1")
    if "INVALID_ARGUMENT" not in result.stderr or "products" not in result.stderr:
        fail("client did not print INVALID_ARGUMENT naming products")
    print("ok: unknown product -> INVALID_ARGUMENT, exit 1")

    # Nobody listens on a port just released: exit 2 naming the address, after about 5 s.
    closed = closed_address()
    result = run_client(args, closed, "--frames", "1")
    if result.returncode != 2 or closed not in result.stderr:
        fail(f"client against {closed} exited with {result.returncode}, expected 2 naming it")
    print("ok: unreachable daemon -> exit 2")


def check_standard_services(args, daemon):
    import grpc  # Debian's python3-grpcio; imported here so a usage error needs none

    with grpc.insecure_channel(daemon.address) as channel:
        check = channel.unary_unary("/grpc.health.v1.Health/Check")  # raw bytes both ways
        for service in ("", "transient.v1.Transient"):
            name = service.encode()
            request = b"\x0a" + bytes([len(name)]) + name if name else b""
            response = check(request, timeout=RPC_TIMEOUT_S)
            if response != SERVING:
                fail(f"health of '{service}' is {response!r}, expected SERVING {SERVING!r}")
            print(f"ok: health of '{service}' is SERVING")

        # ServerReflectionRequest{list_services: ""}: field 7, length-delimited, empty.
        reflect = channel.stream_stream(
            "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo")
        responses = reflect(iter([b"\x3a\x00"]), timeout=RPC_TIMEOUT_S)
        answer = next(responses)
        responses.cancel()
        for service in (b"transient.v1.Transient", b"grpc.health.v1.Health"):
            if service not in answer:
                fail(f"reflection's list_services lacks {service!r}: {answer!r}")
        print("ok: reflection lists transient.v1.Transient")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("check", choices=["client", "standard_services"])
    parser.add_argument("--transientd", required=True)
    parser.add_argument("--client", required=True)
    parser.add_argument("--stubs", required=True)
    parser.add_argument("--workdir", required=True)
    args = parser.parse_args()
    shutil.rmtree(args.workdir, ignore_errors=True)
    os.makedirs(args.workdir)

    daemon = Daemon(args.transientd, args.workdir)
    try:
        daemon.wait_until_serving()
        if args.check == "client":
            check_client(args, daemon)
        else:
            check_standard_services(args, daemon)
        daemon.stop()
        print("ok: SIGTERM stopped transientd with status 0")
    finally:
        daemon.kill()
    print("PASS")


if __name__ == "__main__":
    main()
