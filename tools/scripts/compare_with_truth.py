#!/usr/bin/python3
"""Compares a reconstruction with the ground truth a simulated capture carries.

Usage: compare_with_truth.py CAPTURE.h5 RECONSTRUCTION.h5

Prints, per estimate, the error of the first-return range against the scene's true first
return (millimetres: median and 95th percentile of |error|, over pixels with a range) and, for
Pisarenko, how many of the true returns of each pixel were found within 1 cm. Exit code 2 with
a one-line error for a file that is not what it should be.
"""
import sys

import h5py
import numpy as np

SPEED_OF_LIGHT = 299_792_458.0


def open_capture(path):
    # A recording killed while being written opens only in SWMR read mode (docs/formats/capture.md).
    try:
        return h5py.File(path, "r")
    except OSError:
        return h5py.File(path, "r", swmr=True)


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    capture_path, reconstruction_path = argv[1], argv[2]
    try:
        capture = open_capture(capture_path)
        reconstruction = h5py.File(reconstruction_path, "r")
    except OSError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if "ground_truth" not in capture:
        print(f"error: {capture_path}: no /ground_truth (not a simulated capture)", file=sys.stderr)
        return 2
    truth = capture["ground_truth"]
    first = truth["first_range_m"][()]
    f = float(reconstruction.attrs["base_frequency_hz"])
    unambiguous = SPEED_OF_LIGHT / (2 * f)
    frame = 0  # static scenes: every frame has the same truth

    def wrapped(error):
        return (error + unambiguous / 2) % unambiguous - unambiguous / 2

    for name, label in (("range_m", "MESE first peak"), ("pisarenko/range_m", "Pisarenko first return")):
        if name not in reconstruction:
            continue
        found = reconstruction[name][frame]
        error = np.abs(wrapped(found - first))
        has = np.isfinite(error)
        share = 100.0 * has.mean()
        if has.any():
            print(f"{label}: |range error| median {1e3 * np.median(error[has]):.1f} mm, "
                  f"95th percentile {1e3 * np.percentile(error[has], 95):.1f} mm "
                  f"({share:.1f} % of pixels have a range)")
    if "pisarenko/phase" in reconstruction:
        phases = reconstruction["pisarenko/phase"][frame]
        found = phases * SPEED_OF_LIGHT / (4 * np.pi * f)
        true_ranges = truth["return_range_m"][()]
        amplitude = truth["return_amplitude"][()]
        total = hit = 0
        for r in range(true_ranges.shape[0]):
            present = np.isfinite(true_ranges[r]) & (amplitude[r] > 0)
            distance = np.nanmin(np.abs(wrapped(found - true_ranges[r][None])), axis=0)
            total += int(present.sum())
            hit += int((present & (distance < 0.01)).sum())
        if total:
            print(f"Pisarenko returns: {hit} of {total} true returns found within 1 cm "
                  f"({100.0 * hit / total:.1f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
