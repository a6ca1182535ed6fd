"""Python client of transientd, the AMCW time-of-flight daemon: frames as numpy arrays with
their units, and every RPC of proto/transient/v1/transient.proto.

    import transient
    with transient.Client("127.0.0.1:50051") as client:
        for frame in client.frames(["depth"]):
            depth_m = frame.images["depth"].array

The generated stubs are the subpackage transient.v1 (transient_pb2, transient_pb2_grpc).
Installed, they lie in this package's directory; in a build tree they lie in the build's
proto/python, which then has to be on sys.path beside tools/python (see README.md).
"""

import pkgutil

# Let transient.v1 come from another `transient` directory on sys.path (the build's
# proto/python, where protoc writes it) than this package's sources.
__path__ = pkgutil.extend_path(__path__, __name__)

try:
    from transient.v1 import transient_pb2  # checks that the stubs are there
except ModuleNotFoundError as error:
    if not (error.name or "").startswith("transient"):
        raise  # e.g. protobuf itself: Debian's python3-protobuf
    raise ImportError(
        "transient: no generated stubs transient.v1.transient_pb2 on sys.path "
        f"({error}); install the package (make install), or build the target "
        "transient_proto_python and put the build's proto/python on PYTHONPATH beside "
        "tools/python") from error

del transient_pb2

from transient.errors import ImageError, RpcError, TransientError, UnreachableError
from transient.images import Image, decode_image, dequantize_moment_depth
from transient.client import DEFAULT_ADDRESS, Client, Frame, product_numbers

__all__ = [
    "Client", "Frame", "Image", "decode_image", "dequantize_moment_depth", "product_numbers",
    "DEFAULT_ADDRESS", "TransientError", "RpcError", "UnreachableError", "ImageError",
]
