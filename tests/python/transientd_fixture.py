"""transientd started for a Python test: on 127.0.0.1 with a port it picks, its log in a work
directory, stopped with SIGTERM (which must end it with status 0)."""

import os
import signal
import socket
import subprocess
import time

# A small simulated sensor at its own pace (about 12.5 frames/s). As fast as the daemon could
# reconstruct it (pace=fast), the daemon took a core for the whole test under the sanitizers:
# service.python_client 16 s of CPU against 11 s, in the same wall time (docs/tests.md).
SOURCE = "sim:mirrors?width=48&height=36"
WIDTH, HEIGHT = 48, 36
PORT_FILE_TIMEOUT_S = 30.0
STOP_TIMEOUT_S = 10.0


class DaemonError(Exception):
    """transientd did not start, or did not stop as it should; the message holds its log."""


class Daemon:
    """transientd on 127.0.0.1 with a port chosen at run time, its log in workdir, and its data
    directory (recordings, calibration files) `data_dir`, by default workdir/data."""

    def __init__(self, binary, workdir, source=SOURCE, extra_args=(), data_dir=None):
        os.makedirs(workdir, exist_ok=True)
        self.data_dir = data_dir or os.path.join(workdir, "data")
        self.port_file = os.path.join(workdir, "port")
        if os.path.exists(self.port_file):
            os.remove(self.port_file)
        self.log_path = os.path.join(workdir, "transientd.log")
        self.log = open(self.log_path, "wb")  # pylint: disable=consider-using-with
        self.process = subprocess.Popen(  # pylint: disable=consider-using-with
            [binary, "--listen", "127.0.0.1:0", "--port-file", self.port_file, "--source",
             source, "--data-dir", self.data_dir, *extra_args],
            stdout=self.log, stderr=subprocess.STDOUT)
        self.address = None

    def wait_until_serving(self):
        """Waits for the port file; DaemonError if transientd exits or writes none in time."""
        self.address = f"127.0.0.1:{self._wait_for_port()}"
        return self.address

    def log_text(self):
        self.log.flush()
        with open(self.log_path, "rb") as f:
            return f.read().decode(errors="replace")

    def _wait_for_port(self):
        deadline = time.monotonic() + PORT_FILE_TIMEOUT_S
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise DaemonError(f"transientd exited with {self.process.returncode} before "
                                  f"serving:\n{self.log_text()}")
            try:
                with open(self.port_file) as f:
                    text = f.read().strip()
                if text:
                    return int(text)
            except FileNotFoundError:
                pass
            time.sleep(0.05)
        raise DaemonError(f"transientd wrote no port file in {PORT_FILE_TIMEOUT_S:g} s:\n"
                          f"{self.log_text()}")

    def stop(self):
        """SIGTERM; DaemonError unless the daemon exits 0 within STOP_TIMEOUT_S."""
        self.process.send_signal(signal.SIGTERM)
        try:
            status = self.process.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            raise DaemonError(f"transientd still running {STOP_TIMEOUT_S:g} s after SIGTERM:\n"
                              f"{self.log_text()}") from None
        if status != 0:
            raise DaemonError(f"transientd exited with {status} after SIGTERM:\n"
                              f"{self.log_text()}")

    def kill(self):
        """Ends the daemon if still running (after a failure) and closes its log."""
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        self.log.close()


def closed_address():
    """127.0.0.1 with a port just released, on which nobody listens."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"127.0.0.1:{s.getsockname()[1]}"
