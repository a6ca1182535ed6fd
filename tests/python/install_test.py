#!/usr/bin/python3
"""`cmake --install` puts the transient package and its generated stubs where Debian's python3
imports them: installed into a temporary prefix, the package imports and works with only that
prefix's directory on PYTHONPATH, nothing of the source or build tree.

    install_test.py --cmake CMAKE --build BUILD_DIR --python-dir lib/python3.11/dist-packages \\
        --workdir DIR
"""

import argparse
import os
import shutil
import subprocess
import sys
import time
import unittest

from transientd_fixture import closed_address

ARGS = None

# Run by the installed package's python, from an empty directory: where each module comes
# from, and the package at work (an image decoded, an unreachable daemon reported).
USE_INSTALLED = """
import sys
import numpy as np
import transient
from transient.v1 import transient_pb2 as pb2, transient_pb2_grpc
print(transient.__file__)
print(pb2.__file__)
print(transient_pb2_grpc.__file__)
depth = np.array([[1.5, 0.0]], dtype="<f4")
image = transient.decode_image(pb2.Image(name="depth", product=pb2.DEPTH, width=2, height=1,
                                         encoding="32FC1", step=8, data=depth.tobytes()))
assert image.array.tolist() == [[1.5, 0.0]] and image.product == "depth", image
try:
    transient.Client(sys.argv[1], connect_timeout_s=0.2)
    raise AssertionError(f"connected to {sys.argv[1]}")
except transient.UnreachableError as error:
    print(error)
"""


class InstalledPackage(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        shutil.rmtree(ARGS.workdir, ignore_errors=True)
        cls.prefix = os.path.join(ARGS.workdir, "prefix")
        cls.empty = os.path.join(ARGS.workdir, "empty")
        os.makedirs(cls.empty)
        start = time.monotonic()
        result = subprocess.run([ARGS.cmake, "--install", ARGS.build, "--prefix", cls.prefix],
                                capture_output=True, text=True, timeout=300, check=False)
        print(f"cmake --install took {time.monotonic() - start:.1f} s", file=sys.stderr)
        if result.returncode != 0:
            raise AssertionError(f"cmake --install exited with {result.returncode}:\n"
                                 f"{result.stdout}{result.stderr}")
        cls.site = os.path.join(cls.prefix, ARGS.python_dir)

    def run_python(self, code, *args):
        """Runs code in Debian's python3 with only the installed site on PYTHONPATH."""
        env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "TRANSIENT"))}
        env["PYTHONPATH"] = self.site
        env["PYTHONDONTWRITEBYTECODE"] = "1"  # leaves the installed tree as installed
        result = subprocess.run([sys.executable, "-c", code, *args], cwd=self.empty, env=env,
                                capture_output=True, text=True, timeout=60, check=False)
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
        return result.stdout.splitlines()

    def test_package_and_stubs_are_installed_together(self):
        package = os.path.join(self.site, "transient")
        for name in ("__init__.py", "client.py", "errors.py", "images.py",
                     "v1/transient_pb2.py", "v1/transient_pb2_grpc.py"):
            self.assertTrue(os.path.isfile(os.path.join(package, name)), name)
        self.assertFalse(os.path.exists(os.path.join(package, "__pycache__")))

    def test_imports_and_works_from_the_prefix_alone(self):
        package, stubs, grpc_stubs, unreachable = self.run_python(USE_INSTALLED, closed_address())
        self.assertEqual(package, os.path.join(self.site, "transient", "__init__.py"))
        self.assertEqual(stubs, os.path.join(self.site, "transient", "v1", "transient_pb2.py"))
        self.assertEqual(os.path.dirname(grpc_stubs), os.path.dirname(stubs))
        self.assertIn("not reachable within 0.2 s", unreachable)

    def test_debian_python_searches_the_directory_under_usr_local(self):
        env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
        result = subprocess.run([sys.executable, "-c", "import sys; print('\\n'.join(sys.path))"],
                                env=env, capture_output=True, text=True, check=True)
        self.assertIn(os.path.join("/usr/local", ARGS.python_dir), result.stdout.splitlines())


def main():
    global ARGS  # pylint: disable=global-statement
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cmake", required=True)
    parser.add_argument("--build", required=True, help="the build directory to install")
    parser.add_argument("--python-dir", required=True,
                        help="TRANSIENT_PYTHON_INSTALL_DIR, relative to the prefix")
    parser.add_argument("--workdir", required=True)
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0], *rest], verbosity=2)


if __name__ == "__main__":
    main()
