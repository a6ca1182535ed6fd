"""The exceptions of the transient package: every one is a TransientError."""


class TransientError(Exception):
    """An error of the transient client: an RPC, the connection, or an image it cannot decode."""


class UnreachableError(TransientError, ConnectionError):
    """No transientd answered at `address` within `timeout_s` seconds."""

    def __init__(self, address, timeout_s):
        super().__init__(f"transientd at {address} not reachable within {timeout_s:g} s")
        self.address = address
        self.timeout_s = timeout_s


class RpcError(TransientError):
    """An RPC the daemon refused or that failed on the way.

    Attributes: `method` (e.g. "GetPixel"), `code` (a grpc.StatusCode: INVALID_ARGUMENT for a bad
    request, FAILED_PRECONDITION, UNAVAILABLE, ...) and `details`, the daemon's message, which
    names the field, its value and the rule it broke.
    """

    def __init__(self, method, code, details):
        super().__init__(f"{method}: {code.name}: {details}")
        self.method = method
        self.code = code
        self.details = details


class ImageError(TransientError, ValueError):
    """An image that does not add up (size, step, length, encoding, compression) and so is not
    decoded: its message names the image, the field and the rule it broke."""
