"""PEP 517 build backend for posekit's Python module: drives the project's own CMake build.

`pip install --no-build-isolation .` and `python -m build --no-isolation` call these hooks. Nothing
is fetched: the build needs the Debian packages scripts/install-deps.sh installs (pybind11, Eigen,
PCL, VTK, OpenCV). The wheel holds the extension module and its type stubs (the posekit libraries are linked in
statically; PCL, VTK and OpenCV stay the system's), so it is for this platform and Python version.

The module is built in build/release when that build was configured for this interpreter (as
scripts/build.sh configures it for /usr/bin/python3), else in build/python-<tag>. Set
POSEKIT_BUILD_DIR to choose another folder.
"""
import base64
import hashlib
import io
import os
import re
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
NAME = "posekit"


def _version():
    text = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"project\(posekit VERSION ([0-9.]+)", text)
    if not match:
        raise RuntimeError(f"{ROOT / 'CMakeLists.txt'}: no 'project(posekit VERSION x.y.z)'")
    return match.group(1)


def _interpreter():
    """The real interpreter (a venv's python is a link to it): the one the module is built for."""
    base = getattr(sys, "_base_executable", None) or sys.executable
    return Path(base).resolve()


def _tag():
    return f"cp{sys.version_info.major}{sys.version_info.minor}"


def _platform():
    return sysconfig.get_platform().replace("-", "_").replace(".", "_")


def _cached_interpreter(build_dir):
    cache = build_dir / "CMakeCache.txt"
    if not cache.is_file():
        return None
    for line in cache.read_text(errors="replace").splitlines():
        if line.startswith("_Python3_EXECUTABLE:") or line.startswith("Python3_EXECUTABLE:"):
            return Path(line.split("=", 1)[1]).resolve()
    return None


def _build_dir():
    if os.environ.get("POSEKIT_BUILD_DIR"):
        return Path(os.environ["POSEKIT_BUILD_DIR"]).resolve()
    release = ROOT / "build" / "release"
    if _cached_interpreter(release) == _interpreter():
        return release
    return ROOT / "build" / f"python-{_tag()}"


def _build_module():
    build_dir = _build_dir()
    env = dict(os.environ)
    env.setdefault("CCACHE_BASEDIR", str(ROOT))  # share scripts/build.sh's compiler cache
    env.setdefault("CCACHE_NOHASHDIR", "1")
    if not (build_dir / "CMakeCache.txt").is_file():
        generator = ["-G", "Ninja"] if subprocess.run(["which", "ninja"], capture_output=True).returncode == 0 else []
        print(f"posekit: configuring {build_dir} for {_interpreter()}", file=sys.stderr)
        subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build_dir), *generator, "-DCMAKE_BUILD_TYPE=Release",
                        f"-DPython3_EXECUTABLE={_interpreter()}"], check=True, env=env, stdout=subprocess.DEVNULL)
    jobs = str(os.cpu_count() or 2)
    print(f"posekit: building the Python module in {build_dir}", file=sys.stderr)
    subprocess.run(["cmake", "--build", str(build_dir), "--parallel", jobs, "--target", "posekit_python", "posekit_plugins"],
                   check=True, env=env)
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    module = build_dir / "python" / f"{NAME}{suffix}"
    if not module.is_file():
        built = sorted(p.name for p in (build_dir / "python").glob(f"{NAME}*.so"))
        raise RuntimeError(f"{build_dir / 'python'}: no {module.name} for this interpreter ({sys.executable}, "
                           f"Python {sys.version.split()[0]}); built: {', '.join(built) or 'nothing'}. "
                           "Remove that build folder or set POSEKIT_BUILD_DIR to build for this interpreter")
    return module


def _metadata():
    readme = "A C++17 toolkit for human body models (Zhu & Mok): customize, pose and validate bodies against scans."
    return "\n".join([
        "Metadata-Version: 2.1",
        f"Name: {NAME}",
        f"Version: {_version()}",
        "Summary: " + readme,
        "Requires-Python: >=3.9",
        "Platform: linux",
        "",
    ])


def _dist_info():
    return f"{NAME}-{_version()}.dist-info"


def _write_metadata(directory):
    info = Path(directory) / _dist_info()
    info.mkdir(parents=True, exist_ok=True)
    (info / "METADATA").write_text(_metadata())
    return info.name


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def _wheel(wheel_directory, files):
    tag = f"{_tag()}-{_tag()}-{_platform()}"
    path = Path(wheel_directory) / f"{NAME}-{_version()}-{tag}.whl"
    info = _dist_info()
    files = dict(files)
    files[f"{info}/METADATA"] = _metadata().encode()
    files[f"{info}/WHEEL"] = ("Wheel-Version: 1.0\nGenerator: posekit_build\nRoot-Is-Purelib: false\n"
                              f"Tag: {tag}\n").encode()
    files[f"{info}/top_level.txt"] = f"{NAME}\n".encode()
    record = [_record_line(name, data) for name, data in files.items()] + [f"{info}/RECORD,,"]
    files[f"{info}/RECORD"] = ("\n".join(record) + "\n").encode()
    partial = path.with_suffix(".whl.part")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files.items():
            z.writestr(name, data)
    partial.replace(path)  # a failed build leaves no half-written wheel
    return path.name


# PEP 517 hooks.

def get_requires_for_build_wheel(config_settings=None):
    return []


def get_requires_for_build_sdist(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    return _write_metadata(metadata_directory)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    module = _build_module()
    stubs = ROOT / "python" / "posekit.pyi"  # type stubs beside the module, for editors and checkers
    files = {module.name: module.read_bytes(), stubs.name: stubs.read_bytes()}
    # The plugins (the code that uses VTK, PCL and OpenCV), where the module looks first: posekit_plugins/.
    plugins = sorted((module.parent.parent / "lib" / "posekit").glob("libposekit_*_plugin.so"))
    if not plugins:
        raise RuntimeError(f"{module.parent.parent / 'lib' / 'posekit'}: no plugins built")
    for plugin in plugins:
        files[f"posekit_plugins/{plugin.name}"] = plugin.read_bytes()
    return _wheel(wheel_directory, files)


def build_sdist(sdist_directory, config_settings=None):
    """The source tree as git tracks it (build folders, data and outputs left out)."""
    base = f"{NAME}-{_version()}"
    try:
        listed = subprocess.run(["git", "-C", str(ROOT), "ls-files"], check=True, capture_output=True, text=True).stdout
        names = [n for n in listed.splitlines() if n]
    except (OSError, subprocess.CalledProcessError):
        skip = {"build", "out", ".git", "report", "__pycache__"}
        names = [str(p.relative_to(ROOT)) for p in ROOT.rglob("*")
                 if p.is_file() and not (set(p.relative_to(ROOT).parts) & skip)]
    path = Path(sdist_directory) / f"{base}.tar.gz"
    partial = path.with_suffix(".part")
    with tarfile.open(partial, "w:gz") as tar:
        for name in sorted(names):
            tar.add(ROOT / name, arcname=f"{base}/{name}", recursive=False)
        pkg_info = _metadata().encode()
        entry = tarfile.TarInfo(f"{base}/PKG-INFO")
        entry.size = len(pkg_info)
        tar.addfile(entry, io.BytesIO(pkg_info))
    partial.replace(path)
    return path.name
