# SPDX-License-Identifier: MIT
"""Builds the hybrid_broadphase extension with the project's CMake build, for
the interpreter that runs this script (pip's), and installs it with its type
stubs (hybrid_broadphase.pyi).

    pip install --no-build-isolation ./python

Offline: the build needs setuptools, CMake, a C++20 compiler, pybind11's CMake
package (Debian: pybind11-dev), the interpreter's headers (python3-dev), TBB
and libpng. The CMake build configures the core library, the hardware models
and the module only (no tools, tests, baselines, RTL, MPI or CUDA).

Environment:
  HBP_CMAKE_BUILD_DIR  an existing build tree of this project: its module
                       target is built there and taken instead of configuring
                       a fresh one (the ctest python_pip_install uses it).
  HBP_CMAKE_ARGS       extra arguments for the fresh configure
                       (e.g. "-DHBP_CUDA=AUTO").
  CMAKE_BUILD_PARALLEL_LEVEL  build jobs (CMake's own variable).
"""
import os
import pathlib
import re
import shlex
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent  # the project's CMakeLists.txt


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"project\(hybrid_broadphase\s+VERSION\s+([0-9.]+)", text)
    if not match:
        raise RuntimeError(f"no project(hybrid_broadphase VERSION ...) in {ROOT / 'CMakeLists.txt'}")
    return match.group(1)


class CMakeBuild(build_ext):
    def run(self):
        for ext in self.extensions:
            self.build_with_cmake(ext)

    def build_with_cmake(self, ext):
        existing = os.environ.get("HBP_CMAKE_BUILD_DIR")
        if existing:
            build_dir = pathlib.Path(existing).resolve()
            if not (build_dir / "CMakeCache.txt").exists():
                raise RuntimeError(f"HBP_CMAKE_BUILD_DIR={existing}: no CMakeCache.txt there (not a build tree)")
        else:
            build_dir = pathlib.Path(self.build_temp).resolve() / "cmake"
            build_dir.mkdir(parents=True, exist_ok=True)
            configure = [
                "cmake", "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                f"-DPython3_EXECUTABLE={sys.executable}",
                "-DHBP_BUILD_PYTHON=ON", "-DHBP_BUILD_TESTS=OFF", "-DHBP_BUILD_BENCH=OFF",
                "-DHBP_BUILD_TOOLS=OFF", "-DHBP_BUILD_BASELINES=OFF", "-DHBP_BUILD_BULLET=OFF",
                "-DHBP_BUILD_RTL=OFF", "-DHBP_BUILD_MPI=OFF", "-DHBP_BUILD_SHARED=OFF", "-DHBP_CUDA=OFF",
            ]
            if shutil.which("ninja"):
                configure += ["-G", "Ninja"]
            configure += shlex.split(os.environ.get("HBP_CMAKE_ARGS", ""))
            subprocess.run(configure, check=True)
        subprocess.run(["cmake", "--build", str(build_dir), "--target", "hybrid_broadphase_python"], check=True)

        built = sorted((build_dir / "python" / "module").glob("hybrid_broadphase*.so"))
        if len(built) != 1:
            raise RuntimeError(f"expected one hybrid_broadphase*.so under {build_dir / 'python' / 'module'}, "
                               f"found {[str(p) for p in built]}")
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        if not target.name.endswith(built[0].name[len("hybrid_broadphase"):]):
            raise RuntimeError(f"{built[0]} was built for another interpreter than {sys.executable} "
                               f"(which loads {target.name})")
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[0], target)
        shutil.copyfile(HERE / "hybrid_broadphase.pyi", target.parent / "hybrid_broadphase.pyi")


setup(
    version=project_version(),
    packages=[],  # the extension only: no automatic discovery of python/src (C++ sources)
    py_modules=[],
    ext_modules=[Extension("hybrid_broadphase", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
)
