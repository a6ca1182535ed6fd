#!/usr/bin/python3
"""The transient package (tools/python/transient) against the real transientd.

Images the daemon sends of the same frame in every encoding decode to the same values (float16
and millimetres to the float32 values rounded as the daemon rounds them, zstd bit-identical);
images that do not add up raise ImageError naming what is wrong; every RPC of the Client answers,
and the daemon's refusals arrive as RpcError with their code and message.

    TRANSIENTD=build/service/transientd TRANSIENT_TEST_WORKDIR=/tmp/client_test \\
    PYTHONPATH=tools/python:build/proto/python /usr/bin/python3 tests/python/client_test.py
"""

import os
import shutil
import subprocess
import sys
import threading
import time
import unittest
from unittest import mock

import numpy as np

import transient
from transient.v1 import transient_pb2 as pb2
from transient.v1 import transient_pb2_grpc as pb2_grpc
from transientd_fixture import HEIGHT, WIDTH, Daemon, closed_address

try:
    import zstandard
except ImportError:
    zstandard = None

# The mirrors scene lit so brightly that about half of the pixels saturate (flag bit 3), so that
# every encoding carries invalid pixels (NaN, 0 mm) beside valid ones.
# At the camera's own pace, as transientd_fixture.py says why.
SOURCE = "sim:mirrors?width=48&height=36&brightness=6e7"
# The mirrors scene lies between these depths; a wrong unit (mm) or garbage falls outside.
PLAUSIBLE_DEPTH_M = (0.5, 10.0)
# Streams opened at once and read in threads: how long they may take to share a frame.
CAPTURE_TIMEOUT_S = 30.0
# A 16UC4 code is off by at most half a step (0.5 / 65535) per channel; the inverse of thesis eq.
# 4.4 multiplies that by at most 1/3 + sqrt(3) (b1), plus float32 rounding of values <= 1.
MOMENT_CODE_TOLERANCE = (1.0 / 3.0 + 3.0 ** 0.5) * 0.5 / 65535 + 1e-6
# PixelFlag bit of a pixel saturated in a raw frame (reconstruct/include/.../image.h).
FLAG_SATURATED = 1 << 3
# Variance of the normalised depth, b2 - b1^2 >= 0 (Jensen), up to float32 rounding.
VARIANCE_TOLERANCE = 1e-6

DAEMON = None  # started once for the module


def setUpModule():  # pylint: disable=invalid-name
    global DAEMON  # pylint: disable=global-statement
    workdir = os.environ["TRANSIENT_TEST_WORKDIR"]
    shutil.rmtree(workdir, ignore_errors=True)
    DAEMON = Daemon(os.environ["TRANSIENTD"], workdir, source=SOURCE)
    try:
        DAEMON.wait_until_serving()
    except Exception:
        DAEMON.kill()
        raise


def tearDownModule():  # pylint: disable=invalid-name
    try:
        DAEMON.stop()
    finally:
        DAEMON.kill()


def capture_same_frame(requests):
    """Opens one stream per request at once and returns, for one frame sequence that all of
    them received, each stream's transient.v1.Frame message, in the order of `requests`."""
    import grpc  # pylint: disable=import-outside-toplevel

    received = [{} for _ in requests]  # per stream: sequence -> Frame
    lock = threading.Condition()
    stop = threading.Event()
    errors = []

    def read(index, call):
        try:
            for frame in call:
                if frame.images:
                    with lock:
                        received[index][frame.sequence] = frame
                        lock.notify()
                if stop.is_set():
                    return
        except grpc.RpcError as error:
            if not stop.is_set():
                errors.append(error)
                with lock:
                    lock.notify()

    with grpc.insecure_channel(DAEMON.address) as channel:
        stub = pb2_grpc.TransientStub(channel)
        calls = [stub.StreamFrames(request) for request in requests]
        threads = [threading.Thread(target=read, args=(i, call)) for i, call in enumerate(calls)]
        for thread in threads:
            thread.start()
        try:
            deadline = time.monotonic() + CAPTURE_TIMEOUT_S
            with lock:
                while True:
                    common = set.intersection(*(set(r) for r in received))
                    if common or errors or time.monotonic() > deadline:
                        break
                    lock.wait(timeout=0.1)
        finally:
            stop.set()
            for call in calls:
                call.cancel()
            for thread in threads:
                thread.join()
    if errors:
        raise errors[0]
    if not common:
        raise AssertionError(f"no frame common to {len(requests)} streams in "
                             f"{CAPTURE_TIMEOUT_S:g} s")
    sequence = min(common)
    return [r[sequence] for r in received]


def image(frame, name):
    """The Image message called `name` of a Frame message."""
    for candidate in frame.images:
        if candidate.name == name:
            return candidate
    raise AssertionError(f"frame {frame.sequence} has no image {name}: "
                         f"{[i.name for i in frame.images]}")


def half_rounded(values):
    """float32 values through IEEE binary16 (round to nearest even), as the daemon sends them."""
    return values.astype(np.float16).astype(np.float32)


def millimetre_codes(metres):
    """The daemon's 16UC1 codes of float32 metres: round half away from zero in double, 0 for
    NaN and for what falls outside 1..65535 mm (wire/image_codec.cc MetresToMillimetres)."""
    mm = metres.astype(np.float64) * 1000.0
    with np.errstate(invalid="ignore"):
        whole = np.trunc(mm)
        rounded = whole + ((mm - whole) >= 0.5)
        valid = (rounded >= 1.0) & (rounded <= 65535.0)
    return np.where(valid, rounded, 0).astype(np.uint16)


def assert_same_values(test, actual, expected):
    """Same dtype, shape and values, exactly; NaN where the other has NaN."""
    test.assertEqual(actual.dtype, expected.dtype)
    test.assertEqual(actual.shape, expected.shape)
    np.testing.assert_array_equal(actual, expected)


def assert_same_bits(test, actual, expected):
    test.assertEqual(actual.dtype, expected.dtype)
    test.assertEqual(actual.shape, expected.shape)
    np.testing.assert_array_equal(actual.view(np.uint8), expected.view(np.uint8))


class DecodesEveryEncodingOfTheSameFrame(unittest.TestCase):
    """One frame in float32, float16, millimetres, zstd and both moment depth formats."""

    @classmethod
    def setUpClass(cls):
        products = [pb2.DEPTH, pb2.RANGE, pb2.AMPLITUDE, pb2.FLAGS]
        requests = [
            pb2.StreamRequest(products=products, encoding=pb2.FLOAT32, queue_frames=16),
            pb2.StreamRequest(products=products, encoding=pb2.FLOAT16, queue_frames=16),
            pb2.StreamRequest(products=[pb2.DEPTH, pb2.RANGE], encoding=pb2.UINT16_MM,
                              queue_frames=16),
            pb2.StreamRequest(products=[pb2.MOMENT_DEPTH], queue_frames=16,
                              moment_depth=pb2.MomentDepthRequest(bits=64)),
            pb2.StreamRequest(products=[pb2.MOMENT_DEPTH], queue_frames=16,
                              moment_depth=pb2.MomentDepthRequest(bits=128)),
        ]
        if zstandard is not None:
            requests.append(pb2.StreamRequest(products=products, encoding=pb2.FLOAT32,
                                              compression=pb2.ZSTD, queue_frames=16))
        frames = capture_same_frame(requests)
        cls.float32, cls.float16, cls.mm, cls.moments64, cls.moments128 = frames[:5]
        cls.zstd = frames[5] if zstandard is not None else None

    def test_float32_depth_is_plausible_metres_or_nan(self):
        depth = transient.decode_image(image(self.float32, "depth"))
        self.assertEqual((depth.product, depth.unit, depth.encoding), ("depth", "m", "32FC1"))
        self.assertEqual(depth.array.dtype, np.float32)
        self.assertEqual(depth.array.shape, (HEIGHT, WIDTH))
        finite = np.isfinite(depth.array)
        self.assertTrue(0.1 < finite.mean() < 0.9, f"{finite.mean():.0%} valid; {SOURCE} should "
                        "saturate some pixels and not others")
        self.assertTrue(np.isnan(depth.array[~finite]).all())  # never an infinity
        low, high = PLAUSIBLE_DEPTH_M
        self.assertTrue(low <= depth.array[finite].min() <= depth.array[finite].max() <= high,
                        f"{depth.array[finite].min()}..{depth.array[finite].max()} m")

    def test_float16_is_float32_rounded_to_half(self):
        for name in ("depth", "range", "amplitude"):
            reference = transient.decode_image(image(self.float32, name)).array
            decoded = transient.decode_image(image(self.float16, name))
            self.assertEqual(decoded.encoding, "16FC1")
            assert_same_values(self, decoded.array, half_rounded(reference))
            raw = transient.decode_image(image(self.float16, name), raw=True).array
            assert_same_values(self, raw, reference.astype(np.float16))

    def test_millimetres_become_metres_and_zero_nan(self):
        for name in ("depth", "range"):
            reference = transient.decode_image(image(self.float32, name)).array
            codes = millimetre_codes(reference)
            raw = transient.decode_image(image(self.mm, name), raw=True)
            self.assertEqual((raw.encoding, raw.unit, raw.array.dtype), ("16UC1", "mm", np.uint16))
            np.testing.assert_array_equal(raw.array, codes)
            metres = transient.decode_image(image(self.mm, name))
            self.assertEqual((metres.unit, metres.array.dtype), ("m", np.float32))
            expected = np.where(codes == 0, np.nan, codes / 1000.0).astype(np.float32)
            assert_same_values(self, metres.array, expected)
            self.assertTrue((codes == 0).any() and (codes != 0).any())

    @unittest.skipIf(zstandard is None, "no zstandard module (Debian python3-zstandard)")
    def test_zstd_decodes_to_the_same_bits(self):
        for name in ("depth", "range", "amplitude", "flags"):
            compressed = image(self.zstd, name)
            self.assertEqual(compressed.compression, pb2.ZSTD)
            self.assertNotEqual(len(compressed.data), compressed.height * compressed.step)
            assert_same_bits(self, transient.decode_image(compressed).array,
                             transient.decode_image(image(self.float32, name)).array)

    def test_flags_are_bits_and_explain_every_invalid_depth(self):
        flags = transient.decode_image(image(self.float32, "flags"))
        self.assertEqual((flags.encoding, flags.unit, flags.array.dtype),
                         ("8UC1", "bits", np.uint8))
        self.assertEqual(flags.array.shape, (HEIGHT, WIDTH))
        depth = transient.decode_image(image(self.float32, "depth")).array
        saturated = (flags.array & FLAG_SATURATED) != 0
        self.assertTrue(saturated.any())
        np.testing.assert_array_equal(np.isnan(depth), saturated)

    def test_moment_depth_64_bits_dequantizes_to_the_128_bit_moments(self):
        quantized = transient.decode_image(image(self.moments64, "moment_depth"))
        exact = transient.decode_image(image(self.moments128, "moment_depth"))
        self.assertEqual((quantized.encoding, exact.encoding), ("16UC4", "32FC4"))
        self.assertEqual((quantized.moment_depth.bits, exact.moment_depth.bits), (64, 128))
        for decoded in (quantized, exact):
            self.assertEqual(decoded.array.shape, (HEIGHT, WIDTH, 4))
            self.assertEqual(decoded.array.dtype, np.float32)
        np.testing.assert_allclose(quantized.array, exact.array, rtol=0,
                                   atol=MOMENT_CODE_TOLERANCE)
        codes = transient.decode_image(image(self.moments64, "moment_depth"), raw=True).array
        self.assertEqual(codes.dtype, np.uint16)
        np.testing.assert_array_equal(
            transient.dequantize_moment_depth(codes).astype(np.float32), quantized.array)
        # Moments of depths normalised to [-1, 1]: |b_k| <= 1 and a variance b2 - b1^2 >= 0.
        b = exact.array.astype(np.float64)
        self.assertLessEqual(np.abs(b).max(), 1.0 + VARIANCE_TOLERANCE)
        self.assertGreaterEqual((b[..., 1] - b[..., 0] ** 2).min(), -VARIANCE_TOLERANCE)


class RefusesImagesThatDoNotAddUp(unittest.TestCase):
    """Real daemon images, damaged one field at a time: ImageError naming what is wrong."""

    @classmethod
    def setUpClass(cls):
        requests = [pb2.StreamRequest(products=[pb2.DEPTH]),
                    pb2.StreamRequest(products=[pb2.MOMENT_DEPTH],
                                      moment_depth=pb2.MomentDepthRequest(bits=64))]
        depth, moments = capture_same_frame(requests)
        cls.depth = image(depth, "depth")
        cls.moments = image(moments, "moment_depth")

    def damaged(self, **fields):
        message = pb2.Image()
        message.CopyFrom(self.depth)
        for field, value in fields.items():
            setattr(message, field, value)
        return message

    def assert_refused(self, message, *parts):
        with self.assertRaises(transient.ImageError) as caught:
            transient.decode_image(message)
        for part in (f'image "{message.name}"', *parts):
            self.assertIn(part, str(caught.exception))

    def test_the_undamaged_image_decodes(self):
        self.assertEqual(transient.decode_image(self.damaged()).array.shape, (HEIGHT, WIDTH))

    def test_a_truncated_image(self):
        self.assert_refused(self.damaged(data=self.depth.data[:-1]),
                            f"data holds {len(self.depth.data) - 1} bytes",
                            f"height * step = {len(self.depth.data)}")

    def test_a_wrong_step(self):
        self.assert_refused(self.damaged(step=self.depth.step + 4),
                            f"step={self.depth.step + 4}", f"= {WIDTH * 4}")
        # Rows of one pixel fewer with the data to match are still not this image.
        self.assert_refused(self.damaged(step=self.depth.step - 4,
                                         data=self.depth.data[:-4 * HEIGHT]), "step=")

    def test_an_unknown_encoding(self):
        self.assert_refused(self.damaged(encoding="64FC1"), 'encoding "64FC1" is unknown',
                            "32FC1, 16FC1, 16UC1, 8UC1, 16UC4, 32FC4")

    def test_an_empty_or_huge_size(self):
        self.assert_refused(self.damaged(width=0), "width=0")
        self.assert_refused(self.damaged(width=1 << 20, height=1 << 20, step=4 << 20),
                            "at most 256 MiB")

    def test_an_unknown_compression(self):
        self.assert_refused(self.damaged(compression=7), "compression=7")

    def test_moment_depth_without_its_info(self):
        message = pb2.Image()
        message.CopyFrom(self.moments)
        message.ClearField("moment_depth")
        self.assert_refused(message, "moment_depth.bits=none", "64 with 16UC4")

    @unittest.skipIf(zstandard is None, "no zstandard module (Debian python3-zstandard)")
    def test_corrupt_zstd(self):
        frame = zstandard.ZstdCompressor().compress(self.depth.data)
        self.assert_refused(self.damaged(compression=pb2.ZSTD, data=frame[:-5]), "truncated")
        self.assert_refused(self.damaged(compression=pb2.ZSTD, data=frame + b"\0\0"),
                            "2 bytes after the zstd frame")
        self.assert_refused(self.damaged(compression=pb2.ZSTD, data=b"not zstd at all"),
                            "does not start with a zstd frame header")
        short = zstandard.ZstdCompressor().compress(self.depth.data[:-4])
        self.assert_refused(self.damaged(compression=pb2.ZSTD, data=short),
                            f"declares {len(self.depth.data) - 4} bytes")
        unsized = zstandard.ZstdCompressor(write_content_size=False).compress(self.depth.data)
        self.assert_refused(self.damaged(compression=pb2.ZSTD, data=unsized), "declares no size")

    def test_zstd_without_the_zstandard_module(self):
        with mock.patch.dict(sys.modules, {"zstandard": None}):  # import zstandard fails
            with self.assertRaises(transient.TransientError) as caught:
                transient.decode_image(self.damaged(compression=pb2.ZSTD))
            self.assertIn("python3-zstandard", str(caught.exception))
            with transient.Client(DAEMON.address) as client:
                with self.assertRaises(transient.TransientError):
                    client.frames(["depth"], compression="zstd")


class ClientRpcs(unittest.TestCase):
    """Every RPC through the Client, and the daemon's refusals as RpcError."""

    @classmethod
    def setUpClass(cls):
        cls.client = transient.Client(DAEMON.address)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()

    def assert_rpc_error(self, call, code, *parts):
        import grpc  # pylint: disable=import-outside-toplevel
        with self.assertRaises(transient.RpcError) as caught:
            call()
        self.assertEqual(caught.exception.code, getattr(grpc.StatusCode, code))
        for part in (code, *parts):
            self.assertIn(part, str(caught.exception))
        return caught.exception

    def test_info(self):
        info = self.client.info()
        self.assertEqual((info.camera.width, info.camera.height), (WIDTH, HEIGHT))
        self.assertIn(pb2.DEPTH, info.products)
        self.assertGreater(info.unambiguous_range_m, 0)

    def test_frames_of_a_region_decoded(self):
        frames = self.client.frames(["depth", "flags"], encoding="float16", roi=(4, 2, 16, 8))
        try:
            received = [next(frames) for _ in range(3)]
        finally:
            frames.close()
        received = [f for f in received if not f.announcement]
        self.assertTrue(received)
        for frame in received:
            self.assertEqual(frame.roi, (4, 2, 16, 8))
            self.assertEqual(frame.state, "streaming")
            self.assertEqual(list(frame.images), ["depth", "flags"])
            self.assertEqual(frame.images["depth"].array.shape, (8, 16))
            self.assertEqual(frame.images["depth"].array.dtype, np.float32)
            self.assertEqual(frame.images["depth"].unit, "m")
            self.assertGreater(frame.publish_time_s, 1e9)  # Unix time, not an uptime
        sequences = [f.sequence for f in received]
        self.assertEqual(sequences, sorted(set(sequences)))

    def test_the_command_lines_encoding_names_are_the_protos(self):
        # "mm" is `transient client --encoding mm` (wire/product_registry.h), UINT16_MM the proto's.
        for name in ("mm", "uint16_mm", "UINT16_MM"):
            frames = self.client.frames(["depth"], encoding=name)
            try:
                frame = next(f for f in frames if not f.announcement)
            finally:
                frames.close()
            self.assertEqual(frame.images["depth"].encoding, "16UC1", name)
            self.assertEqual(frame.images["depth"].unit, "m", name)

    def test_frames_refused_by_the_daemon(self):
        error = self.assert_rpc_error(lambda: next(self.client.frames([42])),
                                      "INVALID_ARGUMENT", "product")
        self.assertEqual(error.method, "StreamFrames")
        self.assert_rpc_error(lambda: next(self.client.frames(["slices"], encoding="uint16_mm")),
                              "INVALID_ARGUMENT", "UINT16_MM")

    def test_unknown_names_are_refused_before_asking(self):
        with self.assertRaisesRegex(ValueError, "unknown product 'dpeth'.*depth"):
            self.client.frames(["dpeth"])
        with self.assertRaisesRegex(ValueError, "unknown encoding 'float64'"):
            self.client.frames(["depth"], encoding="float64")
        with self.assertRaisesRegex(ValueError, "unknown compression 'lz4'"):
            self.client.frames(["depth"], compression="lz4")

    def test_get_pixel(self):
        pixel = self.client.get_pixel(3, 4, bins=32)
        self.assertEqual((pixel.x, pixel.y, len(pixel.time_of_flight_ns)), (3, 4, 32))
        self.assert_rpc_error(lambda: self.client.get_pixel(WIDTH, 0), "INVALID_ARGUMENT",
                              f"outside the {WIDTH}x{HEIGHT} sensor")

    def test_set_config_changes_only_valid_fields(self):
        original = self.client.get_config()
        try:
            changed = self.client.set_config(threshold=0.25, range_method="pisarenko")
            self.assertAlmostEqual(changed.threshold, 0.25)
            self.assertEqual(changed.range_method, pb2.PISARENKO)
            self.assertEqual(changed.bias_epsilon, original.bias_epsilon)
            self.assert_rpc_error(lambda: self.client.set_config(threshold=2.0),
                                  "INVALID_ARGUMENT", "threshold")
            self.assertEqual(self.client.get_config(), changed)
            with self.assertRaisesRegex(TypeError, "thresold.*threshold"):
                self.client.set_config(thresold=0.3)
        finally:
            self.client.set_config(original)
        self.assertEqual(self.client.get_config(), original)

    def test_calibrate_reports_progress(self):
        progress = []
        result = self.client.calibrate(takes=2, keep_current=True,
                                       progress=lambda done, total: progress.append((done, total)))
        self.assertEqual(result.takes_averaged, 2)
        self.assertFalse(result.applied)
        self.assertEqual(progress[-1], (2, 2))
        self.assertIn((1, 2), progress)
        self.assert_rpc_error(lambda: self.client.calibrate(takes=1000), "INVALID_ARGUMENT",
                              "takes")

    def test_recording(self):
        started = self.client.start_recording("recording.h5")
        self.assertTrue(started.active)
        self.assertEqual(started.path, "recording.h5")
        self.assertTrue(self.client.stats().recording.active)
        stopped = self.client.stop_recording()
        self.assertFalse(stopped.active)
        self.assertTrue(os.path.isfile(os.path.join(DAEMON.data_dir, "recording.h5")))
        self.assert_rpc_error(lambda: self.client.start_recording("recording.h5"),
                              "ALREADY_EXISTS", "recording.h5")
        # Only names inside the daemon's data directory.
        outside = os.path.join(os.environ["TRANSIENT_TEST_WORKDIR"], "outside.h5")
        self.assert_rpc_error(lambda: self.client.start_recording(outside), "INVALID_ARGUMENT",
                              "an absolute path")
        self.assert_rpc_error(lambda: self.client.start_recording("../outside.h5"),
                              "INVALID_ARGUMENT", "..")
        self.assertFalse(os.path.exists(outside))

    def test_stats(self):
        stats = self.client.stats()
        self.assertGreater(stats.frames_reconstructed, 0)
        self.assertEqual(stats.state, pb2.STREAMING)


class Connecting(unittest.TestCase):

    def test_an_unreachable_daemon(self):
        address = closed_address()
        start = time.monotonic()
        with self.assertRaises(transient.UnreachableError) as caught:
            transient.Client(address, connect_timeout_s=0.5)
        self.assertLess(time.monotonic() - start, 5.0)
        self.assertIsInstance(caught.exception, ConnectionError)
        self.assertIn(f"transientd at {address} not reachable within 0.5 s",
                      str(caught.exception))

    def test_a_bad_timeout(self):
        with self.assertRaisesRegex(ValueError, "connect_timeout_s > 0"):
            transient.Client(DAEMON.address, connect_timeout_s=0)

    def test_the_end_of_the_source_ends_the_iteration(self):
        # 8 frames of 14 raw frames of 5.7 ms: the stream lasts about 0.6 s.
        workdir = os.path.join(os.environ["TRANSIENT_TEST_WORKDIR"], "ending")
        ending = Daemon(os.environ["TRANSIENTD"], workdir,
                        source="sim:mirrors?width=16&height=12&pace=realtime&frames=8",
                        extra_args=["--uncalibrated"])
        try:
            with transient.Client(ending.wait_until_serving()) as client:
                frames = list(client.frames(["depth"]))  # ends, rather than raising
            print(f"\n  {len(frames)} frames before the end", file=sys.stderr)
            # A client that subscribed after the end gets no frame at all; one that came in
            # time gets the last frames and then the announcement of the end.
            if frames:
                self.assertTrue(frames[-1].announcement)
                self.assertEqual(frames[-1].state, "ended")
                self.assertLessEqual(len(frames), 8 + 1)
            ending.stop()
        finally:
            ending.kill()


TOKEN = "0123456789abcdef0123456789abcdef"


def write_secret(path, content):
    with open(path, "w") as f:
        f.write(content)
    os.chmod(path, 0o600)


class Security(unittest.TestCase):
    """A daemon that requires a bearer token, and one with TLS: the Client's options."""

    def test_a_token_is_sent_with_every_call(self):
        workdir = os.path.join(os.environ["TRANSIENT_TEST_WORKDIR"], "token")
        os.makedirs(workdir, exist_ok=True)
        token_file = os.path.join(workdir, "token")
        write_secret(token_file, TOKEN + "\n")
        daemon = Daemon(os.environ["TRANSIENTD"], workdir,
                        source="sim:mirrors?width=16&height=12",
                        extra_args=["--uncalibrated", "--token-file", token_file])
        try:
            address = daemon.wait_until_serving()
            with transient.Client(address) as anonymous:
                with self.assertRaises(transient.RpcError) as caught:
                    anonymous.info()
                self.assertEqual(caught.exception.code.name, "UNAUTHENTICATED")
                with self.assertRaises(transient.RpcError):
                    next(anonymous.frames(["depth"]))
            with transient.Client(address, token_file=token_file) as client:
                self.assertTrue(client.info().access.token)
                frame = next(f for f in client.frames(["depth"]) if not f.announcement)
                self.assertEqual(frame.images["depth"].array.shape, (12, 16))
                self.assertGreater(client.stats().frames_published, 0)
            # Probes: health answers SERVING without the token; reflection, which could not
            # check it, is off.
            import grpc  # pylint: disable=import-outside-toplevel
            with grpc.insecure_channel(address) as channel:
                health = channel.unary_unary("/grpc.health.v1.Health/Check")(b"", timeout=10)
                self.assertEqual(health, b"\x08\x01")
                reflect = channel.stream_stream(
                    "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo")
                with self.assertRaises(grpc.RpcError) as caught:
                    next(reflect(iter([b"\x3a\x00"]), timeout=10))
                self.assertEqual(caught.exception.code(), grpc.StatusCode.UNIMPLEMENTED)
            shared = os.path.join(workdir, "shared")
            with open(shared, "w") as f:
                f.write(TOKEN)
            os.chmod(shared, 0o644)
            with self.assertRaisesRegex(ValueError, "readable by every user"):
                transient.Client(address, token_file=shared)
            daemon.stop()
        finally:
            daemon.kill()

    def test_tls_with_a_client_certificate(self):
        workdir = os.path.join(os.environ["TRANSIENT_TEST_WORKDIR"], "tls")
        os.makedirs(workdir, exist_ok=True)

        def path(name):
            return os.path.join(workdir, name)

        def openssl(*args):
            subprocess.run(["openssl", *args], check=True, capture_output=True)

        ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]
        openssl("req", "-x509", *ec, "-days", "2", "-subj", "/CN=test ca", "-keyout",
                path("ca.key"), "-out", path("ca.pem"))
        with open(path("server.ext"), "w") as f:
            f.write("subjectAltName=IP:127.0.0.1,DNS:localhost\n")
        for name, ext in (("server", ["-extfile", path("server.ext")]), ("client", [])):
            openssl("req", *ec, "-subj", f"/CN={name}", "-keyout", path(f"{name}.key"),
                    "-out", path(f"{name}.csr"))
            openssl("x509", "-req", "-in", path(f"{name}.csr"), "-CA", path("ca.pem"),
                    "-CAkey", path("ca.key"), "-CAcreateserial", "-days", "2", "-out",
                    path(f"{name}.pem"), *ext)
        daemon = Daemon(os.environ["TRANSIENTD"], workdir,
                        source="sim:mirrors?width=16&height=12",
                        extra_args=["--uncalibrated", "--tls-cert", path("server.pem"),
                                    "--tls-key", path("server.key"), "--client-ca",
                                    path("ca.pem")])
        try:
            address = daemon.wait_until_serving()
            with transient.Client(address, ca_file=path("ca.pem"), cert_file=path("client.pem"),
                                  key_file=path("client.key")) as client:
                access = client.info().access
                self.assertTrue(access.tls and access.client_certificate)
                frame = next(f for f in client.frames(["depth"]) if not f.announcement)
                self.assertEqual(frame.images["depth"].array.shape, (12, 16))
            with transient.Client(address, ca_file=path("ca.pem")) as uncertified:
                with self.assertRaises(transient.RpcError) as caught:
                    uncertified.info()
                self.assertEqual(caught.exception.code.name, "UNAUTHENTICATED")
            # Plain text to the TLS port never connects.
            with self.assertRaises(transient.UnreachableError):
                transient.Client(address, connect_timeout_s=1.0)
            daemon.stop()
        finally:
            daemon.kill()


if __name__ == "__main__":
    unittest.main(verbosity=2)
