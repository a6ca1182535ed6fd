"""Client of transientd over gRPC: info, frames as numpy arrays, pixels, configuration,
calibration, recording and statistics (proto/transient/v1/transient.proto)."""

import dataclasses
import os
import stat

try:
    import grpc
except ModuleNotFoundError as error:
    raise ImportError("transient.client needs grpcio: Debian's python3-grpcio, with "
                      "/usr/bin/python3 rather than a python without it") from error

from transient.errors import RpcError, TransientError, UnreachableError
from transient.images import decode_image, require_zstandard
from transient.v1 import transient_pb2 as pb2
from transient.v1 import transient_pb2_grpc as pb2_grpc

DEFAULT_ADDRESS = "127.0.0.1:50051"


@dataclasses.dataclass(frozen=True)
class Frame:
    """One transient frame, or a state announcement (`images` empty).

    sequence: frame number since the daemon started its source.
    capture_time_s: source timestamp of the cycle's first raw frame, seconds.
    publish_time_s: when the daemon published it, seconds since the Unix epoch.
    missed: frames this subscriber lost since its previous Frame (it read too slowly).
    state: the source's state, "streaming", "reconnecting" or "ended".
    roi: (x, y, width, height) of the images in sensor pixels.
    latency_s: from the cycle's last raw frame to publication, seconds.
    images: the decoded images by name ("depth", "slices/3", ...), in the daemon's order.
    """

    sequence: int
    capture_time_s: float
    publish_time_s: float
    missed: int
    state: str
    roi: tuple
    latency_s: float
    images: dict

    @property
    def announcement(self):
        """True for a frame without images: it only announces a change of `state`."""
        return not self.images

    @classmethod
    def from_message(cls, message, raw=False):
        """Decodes a transient.v1.Frame; ImageError for an image that does not add up."""
        images = {}
        for image in message.images:
            decoded = decode_image(image, raw=raw)
            images[decoded.name] = decoded
        roi = message.roi
        return cls(sequence=message.sequence, capture_time_s=message.capture_time_s,
                   publish_time_s=message.publish_time.ToNanoseconds() * 1e-9,
                   missed=message.missed, state=_name(pb2.SourceState, message.state),
                   roi=(roi.x, roi.y, roi.width, roi.height), latency_s=message.latency_s,
                   images=images)


def product_numbers(products):
    """Product names ("depth", case-insensitive) or numbers as numbers, in the order given.

    Numbers pass unchecked (the daemon judges them); an unknown name raises ValueError.
    """
    if isinstance(products, (str, int)):
        products = [products]
    return [_enum_value(pb2.Product, p, "product") for p in products]


class Client:
    """A connection to transientd.

        with transient.Client("127.0.0.1:50051") as client:
            print(client.info().camera)
            for frame in client.frames(["depth"], encoding="float16"):
                depth_m = frame.images["depth"].array  # float32 metres, NaN invalid

    Every RPC error raises RpcError with the gRPC code and the daemon's message.
    """

    def __init__(self, address=DEFAULT_ADDRESS, *, connect_timeout_s=5.0, rpc_timeout_s=10.0,
                 ca_file=None, cert_file=None, key_file=None, server_name=None,
                 token_file=None):
        """Connects to `address` (host:port), waiting at most connect_timeout_s seconds;
        UnreachableError when no daemon answers by then (a TLS handshake the daemon refuses
        never answers). rpc_timeout_s is the deadline of each call except the streams (frames,
        calibrate).

        For a daemon that requires them (transientd --tls-cert, --client-ca, --token-file;
        docs/security.md), files, never the secrets themselves: ca_file, the PEM CA of the
        daemon's certificate (TLS); cert_file and key_file, a PEM client certificate and its
        key; server_name, the name the daemon's certificate carries when not the host of
        `address`; token_file, the bearer token sent with every call. ValueError for a file
        that cannot be used, naming it."""
        if not connect_timeout_s > 0:
            raise ValueError(f"connect_timeout_s = {connect_timeout_s}. Violated constraint: "
                             "connect_timeout_s > 0")
        if bool(cert_file) != bool(key_file):
            raise ValueError("cert_file, key_file: expected both or neither")
        if not ca_file and (cert_file or server_name):
            raise ValueError("ca_file: required with a client certificate or a server name")
        self.address = address
        self._rpc_timeout_s = rpc_timeout_s
        self._metadata = ()
        if token_file:
            self._metadata = (("authorization", "Bearer " + _read_token(token_file)),)
        # Frames can exceed gRPC's default 4 MB message limit.
        options = [("grpc.max_receive_message_length", -1)]
        if ca_file:
            if server_name:
                options.append(("grpc.ssl_target_name_override", server_name))
            credentials = grpc.ssl_channel_credentials(
                root_certificates=_read_file(ca_file, "ca_file"),
                private_key=_read_file(key_file, "key_file", secret=True) if key_file else None,
                certificate_chain=_read_file(cert_file, "cert_file") if cert_file else None)
            self._channel = grpc.secure_channel(address, credentials, options=options)
        else:
            self._channel = grpc.insecure_channel(address, options=options)
        try:
            grpc.channel_ready_future(self._channel).result(timeout=connect_timeout_s)
        except grpc.FutureTimeoutError:
            self._channel.close()
            raise UnreachableError(address, connect_timeout_s) from None
        self._stub = pb2_grpc.TransientStub(self._channel)

    def close(self):
        """Closes the connection; streams still open end with RpcError CANCELLED."""
        self._channel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()

    def info(self):
        """transient.v1.Info: sensor size and intrinsics (pixels), source, schedule (Hz),
        calibration, products, state, version and unambiguous range (m)."""
        return self._call("GetInfo", pb2.GetInfoRequest())

    def frames(self, products=("depth",), *, encoding="float32", compression="none", roi=None,
               max_rate_hz=0.0, slices=None, moment_depth=None, queue_frames=0, raw=False):
        """Frames of the chosen products, as an iterator of Frame; leave the loop (or close()
        the iterator) to end the stream. It also ends when the source does (a replay's end).

        products: names ("depth", "range", "amplitude", "c0", "flags", "moment_state",
            "slices", "cumulative", "direct_indirect", "moment_depth", "confidence") or
            numbers; a camera whose harmonics are not 1..m (the Kinect v2) serves only range,
            depth, amplitude, flags, moment_depth and confidence (Info.products lists them).
        encoding: "float32" (32FC1), "float16" (16FC1) or "mm" (16UC1 millimetres; also its
            proto name "uint16_mm";
            range and depth only); decoded to float32 alike (see Image). FLAGS is always 8UC1
            and MOMENT_DEPTH 16UC4 or 32FC4.
        compression: "none" or "zstd" (needs the zstandard module, checked here).
        roi: (x, y, width, height) in pixels; None for the whole sensor.
        max_rate_hz: at most this many frames per second; 0 for every frame.
        slices: for slices and cumulative: a number of uniform bins over one period, or a
            transient.v1.SliceSpec or a dict of its fields; None for 64 bins.
        moment_depth: for moment_depth: a transient.v1.MomentDepthRequest or a dict of its
            fields (near_m, far_m, sigma_px, bits 64 or 128, from_returns).
        queue_frames: frames the daemon keeps for this client before dropping the oldest;
            0 for 4.
        raw: keep 16UC1 millimetres, 16UC4 codes and float16 as they came (see Image).

        Raises ValueError for an unknown name here, and while iterating RpcError for a
        request the daemon refuses (INVALID_ARGUMENT naming the field) and ImageError for an
        image that does not add up.
        """
        request = pb2.StreamRequest(
            products=product_numbers(products),
            encoding=_encoding(encoding),
            compression=_compression(compression),
            max_rate_hz=max_rate_hz, queue_frames=queue_frames)
        if request.compression == pb2.ZSTD:
            require_zstandard()
        if roi is not None:
            x, y, width, height = roi
            request.roi.CopyFrom(pb2.Roi(x=x, y=y, width=width, height=height))
        if isinstance(slices, int):
            request.slices.bins = slices
        elif slices is not None:
            request.slices.CopyFrom(_message(pb2.SliceSpec, slices))
        if moment_depth is not None:
            request.moment_depth.CopyFrom(_message(pb2.MomentDepthRequest, moment_depth))
        return self._stream_frames(request, raw)

    def get_pixel(self, x, y, *, bins=0, bounds_r=0.0):
        """transient.v1.Pixel: the density (per radian), cumulative distribution, error bounds
        and Pisarenko returns (ns, m) of pixel (x, y) of the latest frame, sampled at `bins`
        times of flight over one period (0 = 256). bounds_r in (0, 1) smooths the bounds
        (0 = 0.9). RpcError INVALID_ARGUMENT outside the sensor, UNAVAILABLE before a frame."""
        return self._call("GetPixel", pb2.GetPixelRequest(x=x, y=y, bins=bins,
                                                          bounds_r=bounds_r))

    def get_config(self):
        """transient.v1.Config in use: range_method, bias_epsilon, threshold (relative),
        smoothing_sigma_px (pixels), takes, video."""
        return self._call("GetConfig", pb2.GetConfigRequest())

    def set_config(self, config=None, **fields):
        """Changes the fields given, as a transient.v1.Config or keywords (range_method "mese" or
        "pisarenko", bias_epsilon, threshold in (0, 1), smoothing_sigma_px in pixels, takes,
        video); returns the Config now in use. An invalid value raises RpcError
        INVALID_ARGUMENT naming the field, and then nothing changes."""
        update = pb2.Config()
        if config is not None:
            update.CopyFrom(config)
        if isinstance(fields.get("range_method"), str):
            fields["range_method"] = _enum_value(pb2.Method, fields["range_method"],
                                                 "range_method")
        try:
            update.MergeFrom(pb2.Config(**fields))
        except ValueError as error:
            raise TypeError(f"set_config: {error}; expected some of "
                            f"{', '.join(pb2.Config.DESCRIPTOR.fields_by_name)}") from None
        return self._call("SetConfig", update)

    def calibrate(self, source_uri="", *, takes=0, output_path="", keep_current=False,
                  progress=None, timeout_s=None):
        """Calibrates against a Dirac at zero (thesis §8.3.2) and returns the
        transient.v1.CalibrateResult (takes averaged, frames rejected, usable pixels).

        source_uri: the Dirac's source; "" for a simulator's calibration scene.
        takes: takes averaged, 1..256 (0 = 20). output_path: also write a calibration file of
        that name in the daemon's data directory (transientd --data-dir; a name relative to it,
        never an existing file). keep_current: do not apply the result.
        progress: called as progress(done, total) after each take.
        timeout_s: deadline of the whole calibration in seconds; None for none.
        """
        request = pb2.CalibrateRequest(source_uri=source_uri, takes=takes,
                                       output_path=output_path, keep_current=keep_current)
        result = None
        try:
            for message in self._stub.Calibrate(request, timeout=timeout_s,
                                                metadata=self._metadata):
                if progress is not None:
                    progress(message.done, message.total)
                if message.HasField("result"):
                    result = message.result
        except grpc.RpcError as error:
            raise _rpc_error("Calibrate", error) from error
        if result is None:
            raise TransientError("Calibrate: the stream ended without a result")
        return result

    def start_recording(self, path, *, max_frames=0, deflate_level=0):
        """Starts recording the source's raw frames into a new HDF5 capture file named `path` in
        the daemon's data directory (transientd --data-dir; a name relative to it: absolute
        paths, "..", symbolic links and existing files are refused). max_frames: transient
        frames, 0 = until stop_recording. deflate_level 1..9 (0 = 1). Returns
        transient.v1.Recording; the recording stops by itself before it passes the daemon's
        quota or fills its disk (Recording.error says why)."""
        return self._call("StartRecording", pb2.StartRecordingRequest(
            path=path, max_frames=max_frames, deflate_level=deflate_level))

    def stop_recording(self):
        """Stops the recording; returns its transient.v1.Recording (frames written, flushed)."""
        return self._call("StopRecording", pb2.StopRecordingRequest())

    def stats(self):
        """transient.v1.Stats: counters of every pipeline stage and subscriber, latency (ms),
        frames per second, the recording."""
        return self._call("GetStats", pb2.GetStatsRequest())

    def _call(self, method, request):
        try:
            return getattr(self._stub, method)(request, timeout=self._rpc_timeout_s,
                                               metadata=self._metadata)
        except grpc.RpcError as error:
            raise _rpc_error(method, error) from error

    def _stream_frames(self, request, raw):
        # No deadline: it lasts until closed.
        call = self._stub.StreamFrames(request, metadata=self._metadata)
        try:
            for message in call:
                yield Frame.from_message(message, raw=raw)
        except grpc.RpcError as error:
            if error.code() == grpc.StatusCode.OUT_OF_RANGE:
                return  # the source has ended: the end of the iteration
            raise _rpc_error("StreamFrames", error) from error
        finally:
            call.cancel()


def _read_file(path, what, secret=False):
    """A PEM file's bytes; ValueError naming `what` when it cannot be read, or when it is a
    `secret` that every user of the machine may read."""
    try:
        if secret and os.stat(path).st_mode & stat.S_IROTH:
            raise ValueError(f"{what} {path}: readable by every user of the machine "
                             f"(chmod 600 {path})")
        with open(path, "rb") as f:
            return f.read()
    except OSError as error:
        raise ValueError(f"{what} {path}: cannot be read ({error.strerror})") from None


def _read_token(path):
    """The bearer token in `path` (transientd's rules, wire/credentials.h): 16..4096 printable
    ASCII bytes without spaces, a trailing newline dropped, the file not readable by others."""
    token = _read_file(path, "token_file", secret=True).rstrip(b"\r\n")
    if not 16 <= len(token) <= 4096:
        raise ValueError(f"token_file {path}: a token of {len(token)} bytes; expected 16..4096")
    if any(c <= 0x20 or c > 0x7e for c in token):
        raise ValueError(f"token_file {path}: the token holds a space, control or non-ASCII "
                         "character")
    return token.decode("ascii")


def _rpc_error(method, error):
    return RpcError(method, error.code(), error.details())


def _name(enum, number):
    """An enum value's name in lower case ("streaming"), or its number if unknown here."""
    try:
        return enum.Name(number).lower()
    except ValueError:
        return number


def _enum_value(enum, value, what):
    """A name (case-insensitive) or number as the enum's number; ValueError for another name."""
    if isinstance(value, int):
        return value
    try:
        return enum.Value(str(value).upper())
    except ValueError:
        names = ", ".join(n.lower() for n in enum.keys() if not n.endswith("UNSPECIFIED"))
        raise ValueError(f"unknown {what} '{value}'; expected one of {names}") from None


# The encoding names of `transient client --encoding` (wire/product_registry.h), beside the
# proto's enum names that _enum_value takes.
_ENCODING_NAMES = {"float32": "FLOAT32", "float16": "FLOAT16", "mm": "UINT16_MM"}


def _encoding(value):
    """"float32", "float16", "mm", a proto enum name (case-insensitive) or a number."""
    if isinstance(value, str) and value.lower() in _ENCODING_NAMES:
        value = _ENCODING_NAMES[value.lower()]
    return _enum_value(pb2.Encoding, value, "encoding")


def _compression(value):
    """None, "none", "zstd" (case-insensitive) or a number as a Compression number."""
    if value is None or isinstance(value, int):
        return value or pb2.COMPRESSION_NONE
    names = {"none": pb2.COMPRESSION_NONE, "zstd": pb2.ZSTD}
    if str(value).lower() not in names:
        raise ValueError(f"unknown compression '{value}'; expected none or zstd")
    return names[str(value).lower()]


def _message(cls, value):
    """A message of type `cls` from itself or a dict of its fields."""
    return value if isinstance(value, cls) else cls(**value)
