"""Builds the module's C++ part (shearzone._native) with the project's own CMake build
for `pip install --no-build-isolation .`: Release, no tests, the interpreter pip runs,
nothing fetched. The metadata is in pyproject.toml; the version is the CMake project's."""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
VERSION = re.search(r"project\(shearzone VERSION ([0-9.]+)", (ROOT / "CMakeLists.txt").read_text()).group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = Path(self.build_temp).resolve() / "cmake"
        configure = ["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                     "-DSHEARZONE_BUILD_TESTS=OFF", "-DSHEARZONE_PYTHON=ON", f"-DPython3_EXECUTABLE={sys.executable}"]
        if shutil.which("ninja"):
            configure += ["-G", "Ninja"]
        subprocess.run(configure, check=True)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 1))
        subprocess.run(["cmake", "--build", str(build), "--target", "shearzone_python", "--parallel", jobs],
                       check=True)
        built = sorted((build / "python" / "shearzone").glob("_native*.so"))
        if len(built) != 1:
            raise RuntimeError(f"{build}: expected one _native*.so, found {len(built)}")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[0], target)


setup(version=VERSION, ext_modules=[Extension("shearzone._native", sources=[])], cmdclass={"build_ext": CMakeBuild})
