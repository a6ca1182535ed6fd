#!/usr/bin/python3
"""The tail of MESE's first-return range error on the simulated corner (tools/scripts/corner_tail.sh).

Usage: corner_tail.py TRANSIENT OUT_DIR MAIN_RUN [RUN...]

For the run MAIN_RUN (files OUT_DIR/NAME-capture.h5, -moments.h5, -reconstruction.h5 as
corner_tail.sh writes them): reconstructs the scene's noise-free moments with TRANSIENT, then
compares the pixels beyond the 95th percentile of |range error| (all frames) with the rest.
For every run: the moments' error against the scene's, split into its part common to the
frames (systematic) and the part that changes from frame to frame (random), relative to c_0.
"""
import shutil
import subprocess
import sys

import h5py
import numpy as np

SPEED_OF_LIGHT = 299_792_458.0


def files(out, name):
    return (f"{out}/{name}-capture.h5", f"{out}/{name}-moments.h5",
            f"{out}/{name}-reconstruction.h5")


def truth_moments(capture):
    g = capture["ground_truth/moments"]
    return g["real"][()] + 1j * g["imag"][()]


def measured_moments(moments):
    return moments["moments/real"][()] + 1j * moments["moments/imag"][()]


def main(argv):
    if len(argv) < 4:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    transient, out, main_run, runs = argv[1], argv[2], argv[3], argv[3:]
    capture_path, moments_path, reconstruction_path = files(out, main_run)
    capture = h5py.File(capture_path, "r")
    truth = truth_moments(capture)

    # The same frames with the scene's own moments: what m = 3 gives without noise.
    clean_moments = f"{out}/noise-free-moments.h5"
    clean_reconstruction = f"{out}/noise-free-reconstruction.h5"
    shutil.copyfile(moments_path, clean_moments)
    with h5py.File(clean_moments, "r+") as m:
        for k in range(m["moments/real"].shape[0]):
            m["moments/real"][k] = truth.real
            m["moments/imag"][k] = truth.imag
    subprocess.run([transient, "reconstruct", clean_moments, clean_reconstruction, "--bins", "64"],
                   check=True, stdout=subprocess.DEVNULL)

    reconstruction = h5py.File(reconstruction_path, "r")
    clean = h5py.File(clean_reconstruction, "r")
    g = capture["ground_truth"]
    first = g["first_range_m"][()]
    ranges, amplitudes = g["return_range_m"][()], g["return_amplitude"][()]
    f = float(reconstruction.attrs["base_frequency_hz"])
    unambiguous = SPEED_OF_LIGHT / (2 * f)

    def wrapped(e):
        return (e + unambiguous / 2) % unambiguous - unambiguous / 2

    error = wrapped(reconstruction["range_m"][()] - first[None])
    clean_error = wrapped(clean["range_m"][()] - first[None])
    absolute = np.abs(error)
    frames = error.shape[0]
    print(f"noise-free moments, m = 3: |range error| median "
          f"{1e3 * np.median(np.abs(clean_error)):.1f} mm, 95th percentile "
          f"{1e3 * np.percentile(np.abs(clean_error), 95):.1f} mm (all {frames} frames)")
    p95 = np.percentile(absolute, 95)
    tail = absolute > p95
    print(f"\n{main_run}, all {frames} frames: |range error| median "
          f"{1e3 * np.median(absolute):.1f} mm, 95th percentile {1e3 * p95:.1f} mm; "
          f"the {int(tail.sum())} pixel-frames beyond it (the tail) against the rest:")

    def shape(x):
        return np.broadcast_to(x, absolute.shape)

    c0 = shape(truth[0].real)
    measured = measured_moments(h5py.File(moments_path, "r"))
    noise = np.abs(measured[:, 1:] - truth[None, 1:]).mean(axis=1) / c0
    r1, r2 = shape(ranges[0]), shape(ranges[1])
    a1, a2 = shape(amplitudes[0]), shape(amplitudes[1])
    separation = np.maximum(r2 - r1, 1e-6)
    rows = [
        ("true c_0", c0, "{:.1f}"),
        ("|moment error| of c_1..c_3 / c_0", noise, "{:.4f}"),
        ("second return's amplitude / first's", a2 / a1, "{:.2f}"),
        ("second return behind the first (m)", r2 - r1, "{:.2f}"),
        ("noise-free |range error| (mm)", 1e3 * np.abs(clean_error), "{:.1f}"),
        ("found range, share of the way to return 2", error / separation, "{:.2f}"),
        ("the same without noise", clean_error / separation, "{:.3f}"),
    ]
    print(f"  {'median of':44s} {'tail':>8s} {'rest':>8s}")
    for label, x, form in rows:
        print(f"  {label:44s} {form.format(np.median(x[tail])):>8s} "
              f"{form.format(np.median(x[~tail])):>8s}")
    print(f"  tail errors too far: {100 * np.mean(error[tail] > 0):.0f} %; "
          f"nearer return 2 than return 1: {100 * np.mean(error[tail] / separation[tail] > 0.5):.0f} %")
    frames_in_tail = tail.sum(axis=0)
    print("  pixels in the tail in 1, 2, 3, 4 frames: " +
          ", ".join(str(int((frames_in_tail == n).sum())) for n in range(1, frames + 1)))
    rows_, cols_ = np.nonzero(frames_in_tail >= 2)
    if len(cols_):
        print(f"  columns of pixels in the tail in >= 2 frames: 5th-95th percentile "
              f"{np.percentile(cols_, 5):.0f}-{np.percentile(cols_, 95):.0f} of {error.shape[2]}")

    print("\nmoment error relative to c_0, medians over pixels (systematic: |mean over frames|; "
          "random: mean |deviation from it|):")
    for name in runs:
        capture_path, moments_path, _ = files(out, name)
        truth = truth_moments(h5py.File(capture_path, "r"))
        difference = measured_moments(h5py.File(moments_path, "r")) - truth[None]
        c0 = truth[0].real
        systematic = np.abs(difference.mean(axis=0)) / c0
        random = np.abs(difference - difference.mean(axis=0)).mean(axis=0) / c0
        parts = ", ".join(f"c_{j} {np.median(systematic[j]):.4f}/{np.median(random[j]):.4f}"
                          for j in range(1, truth.shape[0]))
        print(f"  {name:40s} {parts}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
