#!/usr/bin/python3
"""Writes the example moment file tests/data/example_moments.h5 with numpy and h5py.

It is both the example of `make demo` and the proof that a file written by h5py in the
documented layout (`transient-moments 1`, README.md) reconstructs correctly.

The scene: 16x12 px, 2 frames, m = 3, base frequency 23 MHz. Every pixel holds a known
measure of light over the phase phi = 4*pi*f*range/c:
  - a direct return (a Dirac) at a range that varies smoothly across the image and moves
    0.25 m away between the frames, with brightness falling as 1/range^2;
  - in the top-right quarter, a weaker second Dirac 1.5 m behind it (a wall seen through
    glass): these pixels and the direct-only ones are "sparse";
  - in the bottom third, a continuous return instead: an exponentially modified Gaussian
    (subsurface scattering) starting 0.3 m behind the direct return;
  - two pixels marked invalid in /moments/valid (saturated), their moments zero.
The moments are exact: c_j = sum_l w_l exp(i j phi_l) for Diracs (thesis eq. 8.1), and
c_j = w exp(i j mu - (j sigma)^2 / 2) lambda / (lambda - i j) for the exponentially
modified Gaussian in phase (its characteristic function at integer j, which wrapping onto
the circle leaves unchanged).

Ground truth is stored beside the moments, and readers ignore it: /truth/range_m (the range
of the first return, NaN for invalid pixels) and /truth/sparse (1 where the measure is a
sum of Diracs). Usage: make_example_moments.py OUT.h5
"""

import argparse

import h5py
import numpy as np

SPEED_OF_LIGHT = 299_792_458.0  # m/s
BASE_FREQUENCY_HZ = 23e6
ORDER = 3
FRAMES = 2
HEIGHT, WIDTH = 12, 16

SECOND_RETURN_DELAY_M = 1.5
SECOND_RETURN_SHARE = 0.3
CONTINUOUS_ONSET_M = 0.3  # behind the direct return
CONTINUOUS_SPREAD_M = 0.1  # Gaussian sigma
CONTINUOUS_DECAY_M = 0.8  # mean length of the exponential tail
CONTINUOUS_SHARE = 0.4
INVALID_PIXELS = [(0, 0, 0), (1, HEIGHT - 1, WIDTH - 1)]  # (frame, row, column)


def range_to_phase(range_m):
    """phi = 2*pi*f*tau with the round trip tau = 2*range/c (DESIGN.md)."""
    return 4.0 * np.pi * BASE_FREQUENCY_HZ * np.asarray(range_m) / SPEED_OF_LIGHT


def dirac_moments(phase, weight, order):
    """c_j = w exp(i j phi), j = 0..order, along a new last axis."""
    j = np.arange(order + 1)
    return weight[..., None] * np.exp(1j * j * phase[..., None])


def emg_moments(onset, sigma, rate, weight, order):
    """Moments of an exponentially modified Gaussian in phase (onset, sigma, rate 1/rad)."""
    j = np.arange(order + 1)
    gaussian = np.exp(1j * j * onset[..., None] - 0.5 * (j * sigma) ** 2)
    exponential = rate / (rate - 1j * j)
    return weight[..., None] * gaussian * exponential


def make_scene():
    frame, row, column = np.meshgrid(np.arange(FRAMES), np.arange(HEIGHT), np.arange(WIDTH),
                                     indexing="ij")
    direct_range = (1.2 + 2.4 * column / (WIDTH - 1) + 0.6 * row / (HEIGHT - 1)
                    + 0.25 * frame)
    direct_weight = 3.0 / direct_range**2
    moments = dirac_moments(range_to_phase(direct_range), direct_weight, ORDER)

    second = (row < HEIGHT // 2) & (column >= WIDTH // 2)
    continuous = row >= 2 * HEIGHT // 3
    moments += np.where(
        second[..., None],
        dirac_moments(range_to_phase(direct_range + SECOND_RETURN_DELAY_M),
                      SECOND_RETURN_SHARE * direct_weight, ORDER), 0)
    rate = 1.0 / float(range_to_phase(CONTINUOUS_DECAY_M))
    moments += np.where(
        continuous[..., None],
        emg_moments(range_to_phase(direct_range + CONTINUOUS_ONSET_M),
                    float(range_to_phase(CONTINUOUS_SPREAD_M)), rate,
                    CONTINUOUS_SHARE * direct_weight, ORDER), 0)

    valid = np.ones((FRAMES, HEIGHT, WIDTH), dtype=np.uint8)
    truth_range = direct_range.astype(np.float32)
    for f, y, x in INVALID_PIXELS:
        valid[f, y, x] = 0
        moments[f, y, x, :] = 0
        truth_range[f, y, x] = np.nan
    sparse = (~continuous & (valid == 1)).astype(np.uint8)
    # [frames, height, width, m+1] -> [frames, m+1, height, width]
    moments = np.moveaxis(moments, -1, 1)
    return moments, valid, truth_range, sparse


def write(path):
    moments, valid, truth_range, sparse = make_scene()
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "transient-moments 1"
        f.attrs["generator"] = "tools/scripts/make_example_moments.py"
        group = f.create_group("moments")
        group.attrs["base_frequency_hz"] = np.float64(BASE_FREQUENCY_HZ)
        group.create_dataset("real", data=moments.real.astype(np.float32), track_times=False)
        group.create_dataset("imag", data=moments.imag.astype(np.float32), track_times=False)
        group.create_dataset("valid", data=valid, track_times=False)
        truth = f.create_group("truth")
        truth.create_dataset("range_m", data=truth_range, track_times=False)
        truth.create_dataset("sparse", data=sparse, track_times=False)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", help="the moment file to write, e.g. tests/data/example_moments.h5")
    write(parser.parse_args().output)


if __name__ == "__main__":
    main()
