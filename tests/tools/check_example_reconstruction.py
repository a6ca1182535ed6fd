#!/usr/bin/python3
"""A moment file written by h5py in the documented layout reconstructs to its known ranges.

  generated: runs tools/scripts/make_example_moments.py into WORKDIR, then the `transient`
             binary on the result, and compares /range_m with the file's /truth/range_m.
  committed: checks that tests/data/example_moments.h5 holds exactly what the generator
             writes (datasets and attributes, value for value), then reconstructs it and
             compares as above.
Exits non-zero with a message on the first failed check.
"""

import argparse
import pathlib
import shutil
import subprocess
import sys

import h5py
import numpy as np

# MESE range of a pixel with one or two Dirac returns, m = 3, eps = 4e-3: the observed error
# is below 1 mm (float32 moments, the peak pulled by the second return and by the uniform
# component of biasing); 5 mm leaves a margin while still catching a wrong phase convention,
# a wrong frequency or a frame/pixel mix-up (errors of centimetres to metres).
SPARSE_TOLERANCE_M = 5e-3
# Pisarenko recovers Dirac phases exactly up to float32 storage: ~3e-6 m observed.
PISARENKO_SPARSE_TOLERANCE_M = 1e-4
# With a continuous return 0.3 m behind the direct one the first MESE peak moves ~3 cm away
# (m = 3 cannot separate them); bound it so that gross errors still show.
CONTINUOUS_TOLERANCE_M = 5e-2
FLAG_INVALID_INPUT = 1 << 1


def fail(message):
    print(f"FAILED: {message}", file=sys.stderr)
    sys.exit(1)


def generate(generator, path):
    subprocess.run([sys.executable, str(generator), str(path)], check=True)


def reconstruct(transient, moments, output):
    result = subprocess.run([str(transient), "reconstruct", str(moments), str(output)],
                            capture_output=True, text=True)
    if result.returncode != 0:
        fail(f"transient exited with {result.returncode}: {result.stderr.strip()}")
    print(result.stdout.strip())


def check_reconstruction(moments, output):
    with h5py.File(moments, "r") as m, h5py.File(output, "r") as r:
        truth = m["truth/range_m"][...]
        sparse = m["truth/sparse"][...].astype(bool)
        invalid = np.isnan(truth)
        continuous = ~sparse & ~invalid
        if r.attrs["format"] != "transient-reconstruction 1":
            fail(f"format attribute is {r.attrs['format']!r}")
        if r["range_m"].shape != truth.shape:
            fail(f"/range_m has shape {r['range_m'].shape}, expected {truth.shape}")
        flags = r["flags"][...]
        for name, tolerance in (("range_m", SPARSE_TOLERANCE_M),
                                ("pisarenko/range_m", PISARENKO_SPARSE_TOLERANCE_M)):
            error = np.abs(r[name][...] - truth)
            worst = np.max(error[sparse])
            print(f"/{name}: largest error on {sparse.sum()} sparse pixels {worst:.2e} m "
                  f"(tolerance {tolerance:.0e} m)")
            if not worst <= tolerance:
                fail(f"/{name} misses /truth/range_m by {worst} m on a sparse pixel")
        error = np.abs(r["range_m"][...] - truth)
        worst = np.max(error[continuous])
        print(f"/range_m: largest error on {continuous.sum()} pixels with a continuous return "
              f"{worst:.2e} m (tolerance {CONTINUOUS_TOLERANCE_M:.0e} m)")
        if not worst <= CONTINUOUS_TOLERANCE_M:
            fail(f"/range_m misses /truth/range_m by {worst} m on a continuous pixel")
        if not np.all(flags[invalid] & FLAG_INVALID_INPUT):
            fail("pixels marked invalid in /moments/valid lack the invalid-input flag")
        if not np.all(np.isnan(r["range_m"][...][invalid])):
            fail("pixels marked invalid have a range")
        if np.any(flags[~invalid] & FLAG_INVALID_INPUT):
            fail("valid pixels carry the invalid-input flag")


def compare_files(committed, generated):
    """Every dataset and attribute of one file equals the other's, and no object is extra."""
    def collect(path):
        objects = {}
        with h5py.File(path, "r") as f:
            objects["/"] = ("group", dict(f.attrs))
            def visit(name, obj):
                if isinstance(obj, h5py.Dataset):
                    objects[name] = ("dataset", dict(obj.attrs), obj.dtype, obj[...])
                else:
                    objects[name] = ("group", dict(obj.attrs))
            f.visititems(visit)
        return objects

    a, b = collect(committed), collect(generated)
    if sorted(a) != sorted(b):
        fail(f"{committed} holds {sorted(a)}, the generator writes {sorted(b)}")
    for name in a:
        if a[name][0] != b[name][0] or a[name][1].keys() != b[name][1].keys():
            fail(f"{name}: kind or attribute names differ")
        for key in a[name][1]:
            if not np.array_equal(a[name][1][key], b[name][1][key]):
                fail(f"{name}: attribute {key} differs")
        if a[name][0] == "dataset":
            if a[name][2] != b[name][2]:
                fail(f"{name}: type {a[name][2]} differs from {b[name][2]}")
            if not np.array_equal(a[name][3], b[name][3], equal_nan=True):
                fail(f"{name}: values differ (regenerate with "
                     f"tools/scripts/make_example_moments.py {committed})")
    print(f"{committed} equals the generator's output ({len(a)} objects)")


def check_unsupported_filter(transient, workdir):
    """A file compressed with h5py's lzf, which Debian's HDF5 cannot decode, is refused up
    front with exit code 2, a message naming the filter, and no output file."""
    moments = workdir / "lzf_moments.h5"
    with h5py.File(moments, "w") as f:
        f.attrs["format"] = "transient-moments 1"
        g = f.create_group("moments")
        g.attrs["base_frequency_hz"] = 23e6
        data = np.zeros((1, 4, 8, 8), np.float32)
        data[0, 0] = 1.0
        g.create_dataset("real", data=data, compression="lzf")
        g.create_dataset("imag", data=np.zeros_like(data))
    output = workdir / "lzf_reconstruction.h5"
    result = subprocess.run([str(transient), "reconstruct", str(moments), str(output)],
                            capture_output=True, text=True)
    if result.returncode != 2:
        fail(f"lzf file: exit code {result.returncode}, expected 2 ({result.stderr.strip()})")
    if "/moments/real: stored with HDF5 filter 32000 (lzf)" not in result.stderr:
        fail(f"lzf file: unexpected message {result.stderr.strip()!r}")
    leftovers = sorted(p.name for p in workdir.iterdir() if p.name.startswith("lzf_recon"))
    if leftovers:
        fail(f"lzf file: left {leftovers} behind")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("check", choices=["generated", "committed"])
    parser.add_argument("--transient", required=True, type=pathlib.Path)
    parser.add_argument("--generator", required=True, type=pathlib.Path)
    parser.add_argument("--committed", required=True, type=pathlib.Path)
    parser.add_argument("--workdir", required=True, type=pathlib.Path)
    args = parser.parse_args()

    shutil.rmtree(args.workdir, ignore_errors=True)
    args.workdir.mkdir(parents=True)
    generated = args.workdir / "example_moments.h5"
    generate(args.generator, generated)
    if args.check == "generated":
        moments = generated
    else:
        compare_files(args.committed, generated)
        moments = args.committed
    output = args.workdir / "example_reconstruction.h5"
    reconstruct(args.transient, moments, output)
    check_reconstruction(moments, output)
    if args.check == "generated":
        check_unsupported_filter(args.transient, args.workdir)
    shutil.rmtree(args.workdir)
    print("OK")


if __name__ == "__main__":
    main()
