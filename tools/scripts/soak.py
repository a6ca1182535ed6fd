"""The daemon's soak and fault run (tools/scripts/soak.sh; docs/daemon.md "Soak run").

transientd streams a simulated camera that is unplugged and plugged in again (the simulator's
fault injection: unplug_every/unplug_for) to 20 subscribers over loopback gRPC, each with its
own channel:

  - 14 that keep up: they read every frame at once, with different products, encodings and
    regions; each must lose no frame (Frame.missed is 0 and the sequence has no gap) and see
    every outage announced (RECONNECTING, then STREAMING);
  - 3 that stall: they stop reading for 3 to 10 seconds every few seconds; the daemon drops
    their oldest frames (counted in Frame.missed) and must not queue without bound;
  - 3 that reconnect: a new channel and stream every few frames, then closed.

Meanwhile an operator thread records (started, stopped, left to end by max_frames or by an
outage; every file is checked with h5py against the frames the daemon reports flushed, then
deleted), changes the configuration (and the takes, which reopens the source), asks for
pixels and stats, and sends bad requests, each of which must be refused with its status code
while the streams go on; a raw TCP connection sends garbage to the port. A sampler reads the
daemon's resident memory, open descriptors and threads from /proc.

It fails (exit 1) if a subscriber that kept up lost a frame, if memory or descriptors grew
between the run's second quarter and its last, if a good call failed or a bad one was not
refused as it should be, if the daemon died, or if SIGTERM did not stop it with status 0.
Writes OUT/soak.json (the summary), OUT/samples.csv (one row per sample) and OUT/soak.svg
(memory and descriptors over time).
"""

import argparse
import csv
import json
import os
import random
import socket
import sys
import threading
import time

import grpc
import h5py

import transient
from transient.errors import RpcError
from transient.v1 import transient_pb2 as pb2

from transientd_fixture import Daemon, DaemonError

WIDTH, HEIGHT = 64, 48
# Memory may grow by this much between the second quarter and the last before it counts as
# growth: allocator arenas and gRPC's buffers settle within minutes, a leak keeps going.
RSS_SLACK_FRACTION = 0.10
RSS_SLACK_MIB = 8.0
FD_SLACK = 4

KEPT_UP = [  # (name, Client.frames keyword arguments)
    ("range", dict(products=["range"])),
    ("depth-mm", dict(products=["depth"], encoding="mm")),
    ("amplitude+flags", dict(products=["amplitude", "flags"])),
    ("c0", dict(products=["c0"])),
    ("slices-f16-zstd", dict(products=["slices"], encoding="float16", compression="zstd",
                             slices=64)),
    ("cumulative-32", dict(products=["cumulative"], slices=32)),
    ("moment-state", dict(products=["moment_state"])),
    ("direct-indirect", dict(products=["direct_indirect"])),
    ("moment-depth", dict(products=["moment_depth"])),
    ("range-roi", dict(products=["range"], roi=(8, 4, 32, 24))),
    ("depth-f16", dict(products=["depth"], encoding="float16")),
    ("range+amplitude-zstd", dict(products=["range", "amplitude"], compression="zstd")),
    ("slices-at-times", dict(products=["slices"],
                             slices={"time_of_flight_ns": [2.0, 5.0, 10.0, 20.0]})),
    ("everything-depth", dict(products=["depth", "range", "amplitude", "flags", "c0"])),
]
STALLING = 3
RECONNECTING = 3


class Soak:
    def __init__(self, args):
        self.args = args
        self.stop = threading.Event()
        self.failures = []
        self.lock = threading.Lock()
        self.start_time = time.monotonic()
        self.subscribers = []
        self.operations = {}  # name -> {"ok": n, "refused as expected": n, ...}
        self.recordings = {"started": 0, "files checked": 0, "frames checked": 0,
                           "ended by": {}}
        self.samples = []

    # --- bookkeeping -----------------------------------------------------------------------
    def fail(self, message):
        with self.lock:
            self.failures.append(f"{self.elapsed():7.1f} s: {message}")
        print(f"FAIL {message}", flush=True)

    def elapsed(self):
        return time.monotonic() - self.start_time

    def count(self, operation, outcome):
        with self.lock:
            entry = self.operations.setdefault(operation, {})
            entry[outcome] = entry.get(outcome, 0) + 1

    # --- subscribers -----------------------------------------------------------------------
    def subscriber(self, record, kwargs, stall):
        """Reads frames until the end; `stall` (seconds) > 0 stops reading that long every few
        seconds. Counts frames, missed frames, sequence gaps and announced outages."""
        rng = random.Random(record["name"])
        while not self.stop.is_set():
            try:
                with transient.Client(self.address, connect_timeout_s=10.0) as client:
                    # A client that keeps up asks for a queue deep enough for its scheduling
                    # jitter on a loaded machine (2.5 s of frames); one that stalls gets the
                    # default 4, so that its stalls outlast what the daemon and the transport hold.
                    frames = client.frames(queue_frames=32 if not stall else 4, **kwargs)
                    next_stall = time.monotonic() + rng.uniform(2.0, 8.0)
                    for frame in frames:
                        if self.stop.is_set():
                            break
                        self.on_frame(record, frame)
                        if stall and time.monotonic() > next_stall:
                            time.sleep(rng.uniform(0.5 * stall, stall))
                            record["stalls"] += 1
                            next_stall = time.monotonic() + rng.uniform(2.0, 8.0)
                    frames.close()
                    if not self.stop.is_set():
                        self.fail(f"{record['name']}: the stream ended")
                        return
            except RpcError as error:
                if not self.stop.is_set():
                    self.fail(f"{record['name']}: {error}")
                return

    def reconnecting_subscriber(self, record, kwargs):
        """A new channel and stream for a few frames at a time, then closed."""
        rng = random.Random(record["name"])
        while not self.stop.is_set():
            try:
                with transient.Client(self.address, connect_timeout_s=10.0) as client:
                    frames = client.frames(**kwargs)
                    want = rng.randint(1, 20)
                    got = 0
                    for frame in frames:
                        if not frame.announcement:
                            got += 1
                            record["frames"] += 1
                        if got >= want or self.stop.is_set():
                            break
                    frames.close()
                    record["connections"] += 1
            except RpcError as error:
                if self.stop.is_set():
                    return
                self.fail(f"{record['name']}: {error}")
            time.sleep(rng.uniform(0.0, 0.5))

    def on_frame(self, record, frame):
        # Frame.missed counts the frames lost since the previous message, and an announcement
        # is a message too: frames dropped just before a state change are counted on it.
        record["missed"] += frame.missed
        record["pending_missed"] += frame.missed
        if frame.announcement:
            record["states"].append(frame.state)
            if frame.state == "reconnecting":
                record["outages"] += 1
            return
        record["frames"] += 1
        last = record["last_sequence"]
        if last is not None and frame.sequence != last + 1:
            if frame.sequence <= last:
                record["sequence_backwards"] += 1
            else:
                record["gaps"] += 1
                record["gap_frames"] += frame.sequence - last - 1 - record["pending_missed"]
        record["pending_missed"] = 0
        record["last_sequence"] = frame.sequence

    # --- the operator --------------------------------------------------------------------
    def expect(self, operation, call, refused=None, allowed=()):
        """Runs call(); `refused` is the grpc.StatusCode a bad request must get, `allowed` the
        codes a good one may get in a moment that does not allow it (a source reconnecting)."""
        try:
            result = call()
        except RpcError as error:
            if refused is not None and error.code == refused:
                self.count(operation, "refused as expected")
                return None
            if error.code in allowed:
                self.count(operation, f"{error.code.name} (allowed)")
                return None
            self.fail(f"{operation}: {error}")
            self.count(operation, "unexpected error")
            return None
        if refused is not None:
            self.fail(f"{operation}: accepted, expected {refused.name}")
            self.count(operation, "accepted though bad")
            return None
        self.count(operation, "ok")
        return result

    def operator(self):
        rng = random.Random(7)
        data = self.daemon.data_dir
        recording = None  # the file name of the running recording
        n = 0
        with transient.Client(self.address, connect_timeout_s=10.0) as client:
            while not self.stop.wait(rng.uniform(0.2, 1.0)):
                n += 1
                action = rng.choice(["record", "record", "config", "config", "takes", "pixel",
                                     "stats", "bad", "bad", "bad", "garbage", "calibrate"])
                if action == "record":
                    if recording is None:
                        name = f"soak-{n}.h5"
                        started = self.expect(
                            "StartRecording", lambda: client.start_recording(
                                name, max_frames=rng.choice([0, 0, 5, 20])),
                            allowed=(grpc.StatusCode.UNAVAILABLE,
                                     grpc.StatusCode.FAILED_PRECONDITION))
                        if started is not None:
                            recording = name
                            self.recordings["started"] += 1
                    else:
                        stopped = self.expect(
                            "StopRecording", client.stop_recording,
                            allowed=(grpc.StatusCode.FAILED_PRECONDITION,))
                        self.check_recording(data, recording, stopped or client.stats().recording)
                        recording = None
                elif action == "config":
                    fields = rng.choice([
                        {"threshold": rng.uniform(0.05, 0.3)},
                        {"smoothing_sigma_px": rng.choice([0.0, 0.7, 1.5])},
                        {"range_method": rng.choice(["mese", "pisarenko"])},
                        {"bias_epsilon": rng.choice([1e-4, 1e-3, 1e-2])},
                        {"video": rng.choice([True, False])},
                    ])
                    self.expect("SetConfig", lambda: client.set_config(**fields))
                elif action == "takes":
                    self.expect("SetConfig takes", lambda: client.set_config(
                        takes=rng.choice([1, 2])))
                elif action == "pixel":
                    self.expect("GetPixel", lambda: client.get_pixel(
                        rng.randrange(WIDTH), rng.randrange(HEIGHT), bins=128),
                        allowed=(grpc.StatusCode.UNAVAILABLE,))
                elif action == "stats":
                    self.expect("GetStats", client.stats)
                    self.expect("GetInfo", client.info)
                elif action == "calibrate":
                    name = f"calibration-{n}.h5"
                    result = self.expect("Calibrate", lambda: client.calibrate(
                        takes=4, output_path=name, keep_current=rng.choice([True, False]),
                        timeout_s=60.0), allowed=(grpc.StatusCode.UNAVAILABLE,))
                    if result is not None:
                        os.remove(os.path.join(data, name))
                elif action == "bad":
                    self.bad_request(client, rng)
                else:
                    self.garbage(rng)
            if recording is not None:
                stopped = self.expect("StopRecording", client.stop_recording,
                                      allowed=(grpc.StatusCode.FAILED_PRECONDITION,))
                self.check_recording(data, recording, stopped or client.stats().recording)

    def bad_request(self, client, rng):
        invalid = grpc.StatusCode.INVALID_ARGUMENT
        name, call, code = rng.choice([
            ("StartRecording ../", lambda: client.start_recording("../escape.h5"), invalid),
            ("StartRecording /abs", lambda: client.start_recording("/tmp/soak-abs.h5"), invalid),
            ("StartRecording no dir", lambda: client.start_recording("nodir/x.h5"),
             grpc.StatusCode.NOT_FOUND),
            ("SetConfig threshold=1.5", lambda: client.set_config(threshold=1.5), invalid),
            ("SetConfig bias_epsilon=-1", lambda: client.set_config(bias_epsilon=-1.0), invalid),
            ("SetConfig takes=0", lambda: client.set_config(takes=1000000), invalid),
            ("GetPixel outside", lambda: client.get_pixel(WIDTH, 0), invalid),
            ("GetPixel bins", lambda: client.get_pixel(0, 0, bins=1 << 20), invalid),
            ("StreamFrames roi", lambda: next(iter(client.frames(
                products=["range"], roi=(WIDTH - 4, 0, 8, 8)))), invalid),
            ("StreamFrames slices", lambda: next(iter(client.frames(
                products=["slices"], slices=1 << 20))), invalid),
            ("StreamFrames queue", lambda: next(iter(client.frames(
                products=["range"], queue_frames=1 << 20))), invalid),
            ("Calibrate source", lambda: client.calibrate("file:/etc/passwd"), invalid),
        ])
        self.expect(name, call, refused=code)

    def garbage(self, rng):
        """Bytes that are not HTTP/2 on a raw connection: the daemon drops the connection."""
        try:
            with socket.create_connection(("127.0.0.1", self.port), timeout=5.0) as s:
                s.sendall(bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 4096))))
                s.settimeout(5.0)
                try:
                    while s.recv(4096):
                        pass
                except (socket.timeout, ConnectionResetError):
                    pass
            self.count("raw garbage", "ok")
        except OSError as error:
            self.fail(f"raw garbage: {error}")

    def check_recording(self, data, name, recording):
        """The file holds at least the frames the daemon reported flushed, then it is deleted."""
        path = os.path.join(data, name)
        why = recording.error[:60] if recording.error else "StopRecording"
        self.recordings["ended by"][why] = self.recordings["ended by"].get(why, 0) + 1
        try:
            with h5py.File(path, "r") as f:
                held = f["frames/pixels"].shape[0]
        except (OSError, KeyError) as error:
            self.fail(f"recording {name} ({recording.flushed_frames} flushed) does not open: "
                      f"{error}")
            return
        if held < recording.flushed_frames:
            self.fail(f"recording {name}: {held} frames in the file, "
                      f"{recording.flushed_frames} reported flushed")
        self.recordings["files checked"] += 1
        self.recordings["frames checked"] += recording.flushed_frames
        os.remove(path)

    # --- the sampler ---------------------------------------------------------------------
    def sample(self, client):
        pid = self.daemon.process.pid
        with open(f"/proc/{pid}/status") as f:
            status = dict(line.split(":", 1) for line in f if ":" in line)
        stats = client.stats()
        row = {
            "t_s": round(self.elapsed(), 2),
            "rss_mib": round(int(status["VmRSS"].split()[0]) / 1024.0, 2),
            "fds": len(os.listdir(f"/proc/{pid}/fd")),
            "threads": int(status["Threads"]),
            "subscribers": len(stats.subscribers),
            "frames_published": stats.frames_published,
            "cycles_dropped": stats.cycles_dropped,
            "source_reopens": stats.source_reopens,
            "state": pb2.SourceState.Name(stats.state).lower(),
        }
        self.samples.append(row)
        return row

    def sampler(self, interval):
        with transient.Client(self.address, connect_timeout_s=10.0) as client:
            next_print = 0.0
            while not self.stop.wait(interval):
                if self.daemon.process.poll() is not None:
                    self.fail(f"transientd exited with {self.daemon.process.returncode}")
                    self.stop.set()
                    return
                try:
                    row = self.sample(client)
                except RpcError as error:
                    self.fail(f"GetStats: {error}")
                    continue
                if row["t_s"] >= next_print:
                    print(f"{row['t_s']:7.0f} s  rss {row['rss_mib']:7.1f} MiB  fds {row['fds']:4d}"
                          f"  threads {row['threads']:3d}  subscribers {row['subscribers']:3d}"
                          f"  published {row['frames_published']:7d}"
                          f"  reopens {row['source_reopens']:3d}  {row['state']}", flush=True)
                    next_print = row["t_s"] + self.args.print_every

    # --- the run -------------------------------------------------------------------------
    def run(self):
        args = self.args
        seconds = args.minutes * 60.0
        source = (f"sim:mirrors?width={WIDTH}&height={HEIGHT}&unplug_every={args.unplug_every:g}"
                  f"&unplug_for={args.unplug_for:g}")
        self.daemon = Daemon(args.transientd, args.out, source=source,
                             extra_args=["--data-quota", "256MiB", "--stats-interval", "60"])
        self.address = self.daemon.wait_until_serving()
        self.port = int(self.address.rsplit(":", 1)[1])
        print(f"soak: {args.minutes:g} min, transientd pid {self.daemon.process.pid} on "
              f"{self.address}, {source}", flush=True)
        threads = []
        for name, kwargs in KEPT_UP:
            record = self.new_record(name, "kept up")
            threads.append(threading.Thread(target=self.subscriber, args=(record, kwargs, 0.0)))
        for i in range(STALLING):
            record = self.new_record(f"stalling-{i}", "stalls")
            threads.append(threading.Thread(target=self.subscriber,
                                            args=(record, dict(products=["range", "slices"]),
                                                  6.0 + 2.0 * i)))
        for i in range(RECONNECTING):
            record = self.new_record(f"reconnecting-{i}", "reconnects")
            threads.append(threading.Thread(target=self.reconnecting_subscriber,
                                            args=(record, dict(products=["depth"]))))
        threads.append(threading.Thread(target=self.operator))
        sampler = threading.Thread(target=self.sampler, args=(args.sample_interval,))
        for t in threads + [sampler]:
            t.daemon = True
            t.start()
        self.stop.wait(seconds)
        self.stop.set()
        for t in threads + [sampler]:
            t.join(timeout=30.0)
            if t.is_alive():
                self.fail("a client thread did not end within 30 s of the stop")
        try:
            self.daemon.stop()
        except DaemonError as error:
            self.fail(str(error).splitlines()[0])
        finally:
            self.daemon.kill()
        return self.report(seconds)

    def new_record(self, name, kind):
        record = {"name": name, "kind": kind, "frames": 0, "missed": 0, "gaps": 0,
                  "gap_frames": 0, "sequence_backwards": 0, "outages": 0, "stalls": 0,
                  "connections": 0, "states": [], "last_sequence": None, "pending_missed": 0}
        self.subscribers.append(record)
        return record

    def growth(self, key, seconds):
        """(baseline, final): the highest value of `key` in the run's second quarter and in
        its last quarter."""
        second = [s[key] for s in self.samples if seconds / 4 <= s["t_s"] < seconds / 2]
        last = [s[key] for s in self.samples if s["t_s"] >= 3 * seconds / 4]
        if not second or not last:
            self.fail(f"too few samples to judge {key}")
            return None, None
        return max(second), max(last)

    def slope_per_hour(self, key):
        """Least-squares slope of `key` over the run's second half, per hour (a leak shows as a
        steady slope; allocator settling does not)."""
        half = [(s["t_s"], s[key]) for s in self.samples if s["t_s"] >= self.samples[-1]["t_s"] / 2]
        if len(half) < 3:
            return None
        mt = sum(t for t, _ in half) / len(half)
        mv = sum(v for _, v in half) / len(half)
        den = sum((t - mt) ** 2 for t, _ in half)
        return 3600.0 * sum((t - mt) * (v - mv) for t, v in half) / den if den else None

    def report(self, seconds):
        outages = self.samples[-1]["source_reopens"] if self.samples else 0
        print(f"\n{'subscriber':22s} {'kind':10s} {'frames':>7s} {'missed':>7s} {'gaps':>5s} "
              f"{'uncounted':>9s} {'outages':>7s} {'stalls':>6s} {'conns':>5s}")
        for r in self.subscribers:
            print(f"{r['name']:22s} {r['kind']:10s} {r['frames']:7d} {r['missed']:7d} "
                  f"{r['gaps']:5d} {r['gap_frames']:9d} {r['outages']:7d} {r['stalls']:6d} "
                  f"{r['connections']:5d}")
            if r["frames"] == 0:
                self.fail(f"{r['name']} received no frame")
            if r["gap_frames"]:
                self.fail(f"{r['name']}: {r['gap_frames']} frames missing from the sequence "
                          f"were not counted in Frame.missed")
            if r["kind"] == "kept up":
                if r["missed"] or r["gaps"] or r["sequence_backwards"]:
                    self.fail(f"{r['name']} kept up and lost frames: missed {r['missed']}, "
                              f"{r['gaps']} gaps, {r['sequence_backwards']} backwards")
                if self.args.unplug_every and r["outages"] == 0 and \
                        seconds > 2 * self.args.unplug_every:
                    self.fail(f"{r['name']} was told of no outage")
            if r["kind"] == "stalls" and r["stalls"] and not r["missed"]:
                self.fail(f"{r['name']} stalled {r['stalls']} times and missed nothing: the "
                          f"daemon queued its frames")
        rss = self.growth("rss_mib", seconds)
        fds = self.growth("fds", seconds)
        threads = self.growth("threads", seconds)
        if rss[0] is not None and rss[1] > rss[0] * (1 + RSS_SLACK_FRACTION) + RSS_SLACK_MIB:
            self.fail(f"resident memory grew from {rss[0]:.1f} MiB (second quarter) to "
                      f"{rss[1]:.1f} MiB (last quarter)")
        if fds[0] is not None and fds[1] > fds[0] + FD_SLACK:
            self.fail(f"open descriptors grew from {fds[0]} to {fds[1]}")
        print("\noperations:")
        for name, outcomes in sorted(self.operations.items()):
            print(f"  {name:28s} " + ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items())))
        print(f"recordings: {self.recordings}")
        # (Over a few minutes the slope is the allocator settling, not a rate.)
        rss_slope = self.slope_per_hour("rss_mib") if self.args.minutes >= 10 else None
        print(f"resident memory (MiB, highest of 2nd / last quarter): {rss[0]} / {rss[1]}"
              f" (slope over the second half {rss_slope:+.2f} MiB/h); " if rss_slope is not None
              else f"resident memory (MiB, highest of 2nd / last quarter): {rss[0]} / {rss[1]}; ",
              end="")
        print(f"descriptors: {fds[0]} / {fds[1]}; threads: {threads[0]} / {threads[1]}; "
              f"source reopens {outages}")
        summary = {
            "minutes": self.args.minutes, "unplug_every_s": self.args.unplug_every,
            "unplug_for_s": self.args.unplug_for,
            "subscribers": [{k: v for k, v in r.items()
                             if k not in ("states", "last_sequence", "pending_missed")}
                            for r in self.subscribers],
            "operations": self.operations, "recordings": self.recordings,
            "rss_mib": {"second_quarter_max": rss[0], "last_quarter_max": rss[1],
                        "max": max((s["rss_mib"] for s in self.samples), default=None),
                        "second_half_slope_per_hour": rss_slope},
            "fds": {"second_quarter_max": fds[0], "last_quarter_max": fds[1]},
            "threads": {"second_quarter_max": threads[0], "last_quarter_max": threads[1]},
            "last_sample": self.samples[-1] if self.samples else None,
            "failures": self.failures,
        }
        with open(os.path.join(self.args.out, "soak.json"), "w") as f:
            json.dump(summary, f, indent=1)
        if self.samples:
            with open(os.path.join(self.args.out, "samples.csv"), "w", newline="") as f:
                writer = csv.DictWriter(f, fieldnames=list(self.samples[0]))
                writer.writeheader()
                writer.writerows(self.samples)
            write_svg(os.path.join(self.args.out, "soak.svg"), self.samples, self.args.minutes)
        if self.failures:
            print(f"\nsoak FAILED ({len(self.failures)}):")
            for line in self.failures[:50]:
                print(f"  {line}")
            return 1
        print(f"\nsoak passed: {self.args.minutes:g} min, {len(self.subscribers)} subscribers, "
              f"no frame lost by a subscriber that kept up, no growth")
        return 0


def write_svg(path, samples, minutes):
    """Resident memory and open descriptors over the run, as two line charts."""
    width, height, pad = 760, 200, 48
    t_end = max(s["t_s"] for s in samples) or 1.0
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{2 * height}" '
             f'font-family="sans-serif" font-size="12">',
             f'<rect width="{width}" height="{2 * height}" fill="white"/>']
    for row, (key, label, colour) in enumerate([("rss_mib", "resident memory, MiB", "#1f77b4"),
                                                ("fds", "open descriptors", "#d62728")]):
        top = row * height
        values = [s[key] for s in samples]
        lo, hi = 0.0, max(values) * 1.15 or 1.0
        def x(t):
            return pad + (width - 2 * pad) * t / t_end
        def y(v):
            return top + height - pad / 2 - (height - pad) * (v - lo) / (hi - lo)
        points = " ".join(f"{x(s['t_s']):.1f},{y(s[key]):.1f}" for s in samples)
        parts += [f'<text x="{pad}" y="{top + 16}">{label} (transientd, {minutes:g}-minute soak)'
                  f'</text>',
                  f'<line x1="{pad}" y1="{y(lo):.1f}" x2="{width - pad}" y2="{y(lo):.1f}" '
                  f'stroke="#888"/>',
                  f'<line x1="{pad}" y1="{y(lo):.1f}" x2="{pad}" y2="{y(hi):.1f}" stroke="#888"/>',
                  f'<text x="{pad - 4}" y="{y(hi) + 4:.1f}" text-anchor="end">{hi:.0f}</text>',
                  f'<text x="{pad - 4}" y="{y(lo) + 4:.1f}" text-anchor="end">0</text>',
                  f'<text x="{width - pad}" y="{y(lo) + 16:.1f}" text-anchor="end">'
                  f'{t_end / 60:.1f} min</text>',
                  f'<polyline fill="none" stroke="{colour}" stroke-width="1.5" '
                  f'points="{points}"/>']
    parts.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(parts) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, required=True)
    parser.add_argument("--transientd", required=True)
    parser.add_argument("--out", required=True, help="work directory; the report goes here")
    parser.add_argument("--unplug-every", type=float, default=60.0,
                        help="seconds between the camera's outages (default 60)")
    parser.add_argument("--unplug-for", type=float, default=5.0,
                        help="seconds each outage lasts (default 5)")
    parser.add_argument("--sample-interval", type=float, default=1.0)
    parser.add_argument("--print-every", type=float, default=60.0)
    args = parser.parse_args()
    if args.minutes <= 0:
        parser.error("--minutes must be > 0")
    os.makedirs(args.out, exist_ok=True)
    sys.exit(Soak(args).run())


if __name__ == "__main__":
    main()
