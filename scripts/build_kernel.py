"""Build the compiled Planar Bones kernel into a wheel per platform, and optionally install this machine's.

    .venv/bin/python -m scripts.build_kernel [--platforms linux-x64 ...] [--install] [--out wheels]

Compiles `native/planar_bones_kernel.c` into a shared library for each platform the extension ships
(PLATFORMS: Windows, macOS and Linux, each on x64 and arm64) with Zig's C compiler, which the pinned PyPI package
`ziglang` brings with the C libraries and headers of every target, so one Linux machine builds them all. It is
plain C with no Python C-API, so a wheel is ``py3-none-<platform>`` and serves every Python version. A wheel holds
the package ``mpeg4_face_kernel`` (the library, its path and ABI version) and is written to
``wheels/mpeg4_face_kernel-<abi>.0.0-py3-none-<platform tag>.whl``; `scripts.build_extension` bundles each in its
platform's zip and Blender installs it. ``--install`` also installs this machine's wheel into the Python running
this script (set-up does this for ``.venv``), offline and only when the installed kernel differs. Nothing is
rebuilt when the wheel was built from the same source, flags and compiler. Without Zig it exits with status 2 and
says so: the add-on then runs its numpy path.
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import importlib.util
import os
import re
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = tuple(
    ROOT / "native" / name
    for name in (
        "planar_bones_kernel.c",
        "planar_bones_range.h",
        "lip_guard.h",
        "nearest_sources.h",
        "bind_regions.h",
        "lid_weights.h",
        "unfold.h",
    )
)
WHEELS = ROOT / "wheels"
PACKAGE = "mpeg4_face_kernel"
STEM = "planar_bones_kernel"
# IEEE arithmetic throughout (no -ffast-math): -fno-math-errno and -fno-trapping-math only let the loop
# of square roots and divisions vectorise; FMA contraction changes results by rounding only. -Wno-psabi: the
# 4-double vectors pass only between always-inlined functions, so no call has the ABI the warning is about.
FLAGS = (
    "-O3",
    "-std=gnu11",
    "-fPIC",
    "-shared",
    "-pthread",
    "-fvisibility=hidden",
    "-fno-math-errno",
    "-fno-trapping-math",
    "-ffp-contract=fast",
    "-s",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-Wno-psabi",
)
ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed, so that the same library gives the same wheel


@dataclass(frozen=True)
class Target:
    zig: str  # Zig's target triple
    tag: str  # the wheel's platform tag, which Blender maps to its platform name
    suffix: str  # the shared library's file name suffix


# Blender's platform names -> how to build for each. Linux: glibc 2.28, what Blender 4.2 needs; macOS: 11.0,
# Blender 4.2's oldest; Windows: MinGW-w64 on the Universal C Runtime, with its pthreads linked in.
PLATFORMS = {
    "windows-x64": Target("x86_64-windows-gnu", "win_amd64", ".dll"),
    "windows-arm64": Target("aarch64-windows-gnu", "win_arm64", ".dll"),
    "macos-x64": Target("x86_64-macos.11.0", "macosx_11_0_x86_64", ".dylib"),
    "macos-arm64": Target("aarch64-macos.11.0", "macosx_11_0_arm64", ".dylib"),
    "linux-x64": Target("x86_64-linux-gnu.2.28", "manylinux_2_28_x86_64", ".so"),
    "linux-arm64": Target("aarch64-linux-gnu.2.28", "manylinux_2_28_aarch64", ".so"),
}
# sysconfig's platform of this Python -> Blender's name for it
HOSTS = {
    "linux-x86_64": "linux-x64",
    "linux-aarch64": "linux-arm64",
    "win-amd64": "windows-x64",
    "win-arm64": "windows-arm64",
}


class KernelBuildError(RuntimeError):
    pass


def abi_version() -> int:
    match = re.search(r"#define PBK_ABI_VERSION (\d+)", SOURCES[0].read_text(encoding="utf-8"))
    if match is None:
        raise KernelBuildError(f"{SOURCES[0]} defines no PBK_ABI_VERSION")
    return int(match.group(1))


def host_platform() -> str:
    """Blender's name for the platform of the Python running this, or KernelBuildError."""
    system = sysconfig.get_platform()
    if system.startswith("macosx-"):
        return "macos-arm64" if system.endswith("-arm64") else "macos-x64"
    if system not in HOSTS:
        raise KernelBuildError(f"no kernel is built for this platform ({system}); the add-on uses its numpy path")
    return HOSTS[system]


def library_name(platform: str) -> str:
    return STEM + PLATFORMS[platform].suffix


def wheel_path(platform: str, out_dir: Path = WHEELS) -> Path:
    return out_dir / f"{PACKAGE}-{abi_version()}.0.0-py3-none-{PLATFORMS[platform].tag}.whl"


def zig() -> list[str]:
    """The command that runs Zig (`python -m ziglang`), or KernelBuildError when the package is missing."""
    if importlib.util.find_spec("ziglang") is None:
        raise KernelBuildError(
            "Zig's C compiler is missing (pip install the `ziglang` that requirements.txt pins; scripts/setup_env.sh "
            "does): the compiled kernel cannot be built, and the add-on will use its slower numpy path"
        )
    return [sys.executable, "-m", "ziglang"]


def source_digest(platform: str) -> str:
    """What a platform's library is built from: the sources, the target, the flags and Zig's version."""
    version = subprocess.run([*zig(), "version"], capture_output=True, text=True).stdout
    digest = hashlib.sha256()
    parts = (*(p.read_bytes() for p in SOURCES), PLATFORMS[platform].zig.encode(), " ".join(FLAGS).encode())
    for part in (*parts, version.encode()):
        digest.update(hashlib.sha256(part).digest())
    return digest.hexdigest()


def _package_init(platform: str, digest: str) -> str:
    return (
        '"""The compiled Planar Bones kernel of the MPEG-4 Face Animation extension: plain C, loaded with ctypes\n'
        'by its addon/deform/fused.py. Built by scripts/build_kernel.py from native/planar_bones_kernel.c."""\n\n'
        "from pathlib import Path\n\n"
        f'LIBRARY = Path(__file__).with_name("{library_name(platform)}")\n'
        f"ABI_VERSION = {abi_version()}\n"
        f'SOURCE_DIGEST = "{digest}"\n'
    )


def record_hash(data: bytes) -> str:
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


def _digest_in(init_text: str) -> str | None:
    match = re.search(r'SOURCE_DIGEST = "([0-9a-f]+)"', init_text)
    return match.group(1) if match else None


def _wheel_digest(path: Path) -> str | None:
    try:
        with zipfile.ZipFile(path) as wheel:
            return _digest_in(wheel.read(f"{PACKAGE}/__init__.py").decode())
    except (OSError, KeyError, zipfile.BadZipFile):
        return None


def compile_library(platform: str, target: Path) -> None:
    command = [*zig(), "cc", "-target", PLATFORMS[platform].zig, *FLAGS, "-I", str(SOURCES[0].parent)]
    command += [str(SOURCES[0]), "-o", str(target), "-lm"]
    with tempfile.TemporaryDirectory() as cache:  # Zig's caches, so that builds running at once do not collide
        environment = {**os.environ, "ZIG_LOCAL_CACHE_DIR": cache}
        result = subprocess.run(command, capture_output=True, text=True, env=environment)
    if result.returncode != 0:
        raise KernelBuildError(f"{' '.join(command)} failed:\n{result.stdout}{result.stderr}")


def build_wheel(platform: str, out_dir: Path = WHEELS) -> Path:
    """The platform's kernel wheel, compiled and packed unless one from the same source is already there."""
    digest = source_digest(platform)
    target = wheel_path(platform, out_dir)
    if _wheel_digest(target) == digest:
        return target
    library = library_name(platform)
    with tempfile.TemporaryDirectory() as scratch:
        compile_library(platform, Path(scratch) / library)
        binary = (Path(scratch) / library).read_bytes()
    version = f"{abi_version()}.0.0"
    info = f"{PACKAGE}-{version}.dist-info"
    files = {
        f"{PACKAGE}/__init__.py": _package_init(platform, digest).encode(),
        f"{PACKAGE}/{library}": binary,
        f"{info}/METADATA": (
            f"Metadata-Version: 2.1\nName: {PACKAGE}\nVersion: {version}\n"
            "Summary: Compiled Planar Bones kernel of the MPEG-4 Face Animation Blender extension\n"
            "License: GPL-3.0-or-later\n"
        ).encode(),
        f"{info}/WHEEL": (
            "Wheel-Version: 1.0\nGenerator: scripts/build_kernel.py\nRoot-Is-Purelib: false\n"
            f"Tag: py3-none-{PLATFORMS[platform].tag}\n"
        ).encode(),
    }
    record = "".join(f"{name},{record_hash(data)},{len(data)}\n" for name, data in files.items())
    files[f"{info}/RECORD"] = (record + f"{info}/RECORD,,\n").encode()
    out_dir.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f"{target.name}.{os.getpid()}.part")  # builds running at once do not collide
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as wheel:
        for name, data in files.items():
            entry = zipfile.ZipInfo(name, ZIP_TIME)
            entry.external_attr = (0o755 if name.endswith(library) else 0o644) << 16
            entry.compress_type = zipfile.ZIP_DEFLATED
            wheel.writestr(entry, data)
    partial.replace(target)
    return target


def installed_digest() -> str | None:
    """The source digest of the kernel installed in this Python, or None."""
    spec = importlib.util.find_spec(PACKAGE)
    if spec is None or spec.origin is None:
        return None
    return _digest_in(Path(spec.origin).read_text(encoding="utf-8"))


def install(wheel: Path) -> bool:
    """Install the wheel into this Python unless the same kernel is there; True if it installed."""
    if installed_digest() == _wheel_digest(wheel):
        return False
    command = [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check"]
    command += ["--no-index", "--no-deps", "--force-reinstall", str(wheel)]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise KernelBuildError(f"installing {wheel.name} failed:\n{result.stdout}{result.stderr}")
    return True


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--platforms", nargs="+", choices=PLATFORMS, metavar="PLATFORM", help="default: all; with --install, this one"
    )
    parser.add_argument("--out", type=Path, default=WHEELS, help="folder for the wheels (default: wheels/)")
    parser.add_argument("--install", action="store_true", help="also install this machine's wheel into this Python")
    args = parser.parse_args(argv)
    try:
        chosen = args.platforms or ([] if args.install else list(PLATFORMS))
        platforms = dict.fromkeys([*chosen, *([host_platform()] if args.install else [])])
        wheels = {platform: build_wheel(platform, args.out) for platform in platforms}
        print("\n".join(map(str, wheels.values())))
        if args.install and install(wheels[host_platform()]):
            print(f"installed {wheels[host_platform()].name} into {sys.prefix}")
    except KernelBuildError as exc:
        print(f"build_kernel: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
