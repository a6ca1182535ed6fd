#!/usr/bin/python3
"""A disk that fills during a recording: transientd's data directory on a real 16 MiB tmpfs,
which another writer fills (posix_fallocate) while the recording runs. The recording ends with an
error, the stream goes on, and the file opens in h5py with every frame the daemon had reported
flushed readable.

The tmpfs is mounted in a mount namespace of an unprivileged user namespace (unshare(1) -rm),
so the test needs no root; the whole test re-executes itself in it.

    TRANSIENTD=build/service/transientd TRANSIENT_TEST_WORKDIR=/tmp/full_disk \\
    PYTHONPATH=tools/python:build/proto/python /usr/bin/python3 tests/python/full_disk_test.py
"""

import os
import shutil
import subprocess
import sys
import time

import h5py
import numpy as np

import transient
from transientd_fixture import Daemon

IN_NAMESPACE = "TRANSIENT_FULL_DISK_NAMESPACE"
TMPFS_BYTES = 16 << 20
# The camera's pace (12.5 frames of 14 raw frames a second): frames wait in HDF5's memory for
# the writer's flush, at most a second, when the disk fills.
SOURCE = "sim:mirrors?width=64&height=48"
TIMEOUT_S = 60.0


def fail(message):
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def wait_for(condition, what):
    deadline = time.monotonic() + TIMEOUT_S
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    fail(f"no {what} within {TIMEOUT_S:g} s")
    return None


def fill(directory):
    """Takes every free byte of the file system of `directory`; returns the bytes taken."""
    free = os.statvfs(directory).f_bavail * os.statvfs(directory).f_frsize
    with open(os.path.join(directory, "filler"), "wb") as f:
        taken = 0
        for size in (free, 1 << 20, 64 << 10, 4096):  # what is left after each step
            while True:
                try:
                    os.posix_fallocate(f.fileno(), taken, size)
                    taken += size
                except OSError:
                    break
        return taken


def run(workdir):
    data = os.path.join(workdir, "data")
    os.makedirs(data)
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={TMPFS_BYTES},mode=0700",
                    "transient-test", data], check=True)
    daemon = Daemon(os.environ["TRANSIENTD"], workdir, source=SOURCE,
                    extra_args=["--uncalibrated"], data_dir=data)
    try:
        with transient.Client(daemon.wait_until_serving()) as client:
            client.start_recording("capture.h5")
            wait_for(lambda: client.stats().recording.flushed_frames > 0, "flushed frame")
            taken = fill(data)
            print(f"ok: the recording has flushed frames; another writer took the last "
                  f"{taken} bytes of the {TMPFS_BYTES >> 20} MiB tmpfs")
            recording = wait_for(lambda: (lambda r: None if r.active else r)(
                client.stats().recording), "end of the recording")
            print(f"ok: the recording ended: {recording.raw_frames} raw frames, "
                  f"{recording.flushed_frames} flushed; error: {recording.error}")
            if not recording.error.startswith("stopped: "):
                fail(f"the recording ended without saying why: {recording}")
            if recording.flushed_frames == 0:
                fail("no frame was flushed")
            # The stream goes on.
            frames = client.frames(["depth"])
            frame = next(f for f in frames if not f.announcement)
            frames.close()
            print(f"ok: frames still stream (sequence {frame.sequence})")
        daemon.stop()
        print("ok: SIGTERM stopped transientd with status 0")
    finally:
        daemon.kill()

    with h5py.File(os.path.join(data, "capture.h5"), "r") as f:
        pixels = f["frames/pixels"]
        if pixels.shape[0] < recording.flushed_frames:
            fail(f"the file holds {pixels.shape[0]} frames, {recording.flushed_frames} were "
                 f"flushed")
        flushed = pixels[:recording.flushed_frames]
        if not np.isfinite(flushed).all() or flushed.max() <= 0:
            fail("a flushed frame reads back without finite, positive values")
    print(f"ok: h5py reads all {recording.flushed_frames} flushed frames "
          f"({pixels.shape[0]} in the file)")


def main():
    workdir = os.environ["TRANSIENT_TEST_WORKDIR"]
    if os.environ.get(IN_NAMESPACE) != "1":
        shutil.rmtree(workdir, ignore_errors=True)
        os.makedirs(workdir)
        env = dict(os.environ, **{IN_NAMESPACE: "1"})
        sys.exit(subprocess.run(["unshare", "--user", "--map-root-user", "--mount",
                                 sys.executable, *sys.argv], env=env, check=False).returncode)
    run(workdir)
    print("PASS")


if __name__ == "__main__":
    main()
