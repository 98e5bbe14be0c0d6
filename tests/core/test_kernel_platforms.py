"""The kernel as each platform's wheel carries it (scripts/build_kernel.py, cross-compiled with Zig): a library of
that platform's format and CPU exporting exactly the kernel's functions; and the Windows x64 one run for real under
Wine by a Windows test program built the same way (kernel_probe.c), equal to this machine's kernel and to the numpy
reference. Wine is Debian's `wine64` (scripts/run_tests.sh installs it); without it that test is skipped."""

import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from addon.deform import fused, planar_bones
from addon.deform.planar_bones import bind
from scripts import build_kernel

from .binaries import describe
from .test_fused import reference
from .test_planar_bones import icosahedron, sphere_points

WINE = Path("/usr/lib/wine/wine64")  # Debian's wine64 package
PROBE = Path(__file__).with_name("kernel_probe.c")
FORMATS = {".dll": "PE", ".dylib": "Mach-O", ".so": "ELF"}
TOLERANCE = 1e-8  # m: 1e-5 mm


def exported_functions() -> set[str]:
    """The functions the C sources mark PBK_EXPORT."""
    source = "".join(path.read_text("utf-8") for path in build_kernel.SOURCES)
    return set(re.findall(r"PBK_EXPORT \w+\s*\*?\s*(pbk_\w+)\(", source))


def library(platform: str, folder: Path) -> Path:
    """The platform's library, unpacked from its wheel (built unless it is up to date) into `folder`."""
    name = f"{build_kernel.PACKAGE}/{build_kernel.library_name(platform)}"
    with zipfile.ZipFile(build_kernel.build_wheel(platform)) as wheel:
        return Path(wheel.extract(name, folder))


@pytest.mark.parametrize("platform", build_kernel.PLATFORMS)
def test_each_platform_gets_a_library_of_its_format_exporting_the_kernel(platform, tmp_path):
    target = build_kernel.PLATFORMS[platform]
    kind, cpu, names = describe(library(platform, tmp_path).read_bytes())
    assert kind == FORMATS[target.suffix] and cpu == target.zig.split("-")[0].replace("aarch64", "arm64")
    # Mach-O also lists the linker's own _-prefixed symbols
    assert {name for name in names if not name.startswith("_")} == exported_functions() and len(names) > 10


def test_the_host_wheel_is_the_one_installed():
    assert build_kernel.host_platform() == "linux-x64" or os.uname().machine != "x86_64"
    assert fused.available() and fused.library_path().suffix == ".so"


def _layout_file(path: Path, layout: fused.Layout, control: np.ndarray) -> None:
    """kernel_probe.c's input: the counts, then each array pbk_evaluate_f64 takes as a byte count and its bytes."""
    arrays = (control, layout.control_rest, layout.rest_bases, layout.triangles, layout.base, layout.plain_start)
    arrays += (layout.plain_key, layout.plain_coef, layout.apex_start, layout.apex_key, layout.apex_coef)
    arrays += (layout.apex_scale, layout.apex_rest, layout.rest_out, layout.vertex_mask)
    with path.open("wb") as out:
        out.write(np.array([layout.n_vertices, len(layout.triangles)], np.int64).tobytes())
        for array in arrays:
            data = np.ascontiguousarray(array).tobytes()
            out.write(np.int64(len(data)).tobytes() + data)


@pytest.mark.skipif(not WINE.is_file(), reason=f"needs Wine ({WINE}: apt-get install wine64; run_tests.sh does)")
@pytest.mark.skipif(not fused.available(), reason="no compiled kernel on this machine to compare with")
def test_the_windows_kernel_under_wine_equals_this_machines_kernel_and_numpy(tmp_path):
    control_rest, _ = icosahedron(0.012)
    binding = bind(sphere_points(3000, radius=0.03, seed=4), control_rest[:6], np.array([[0, 1, 2], [0, 2, 3]]))
    control = binding.control_rest + np.random.default_rng(3).normal(0.0, 0.003, binding.control_rest.shape)
    layout = planar_bones._fused_layout(binding, "planar_bones", np.float64)
    assert layout.apex_key is not None and len(layout.apex_key) > 1000  # the apex path (eq. 13-14) is in play
    _layout_file(tmp_path / "in.bin", layout, control)
    probe = tmp_path / "kernel_probe.exe"
    zig = [*build_kernel.zig(), "cc", "-target", build_kernel.PLATFORMS["windows-x64"].zig, "-O2", "-Wall", "-Werror"]
    subprocess.run([*zig, str(PROBE), "-o", str(probe)], check=True, capture_output=True, timeout=600)
    dll = library("windows-x64", tmp_path)
    environment = {
        **os.environ,
        "WINEPREFIX": str(tmp_path / "wine"),
        "WINEDEBUG": "-all",
        "WINEDLLOVERRIDES": "mscoree,mshtml=",
    }
    result = subprocess.run(
        [str(WINE), str(probe), str(dll), str(tmp_path / "in.bin"), str(tmp_path / "out.bin")],
        capture_output=True,
        text=True,
        env=environment,
        timeout=600,
    )
    shutil.rmtree(tmp_path / "wine", ignore_errors=True)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    windows = np.fromfile(tmp_path / "out.bin", dtype=np.float64).reshape(-1, 3)
    here = np.empty_like(windows)
    assert fused.evaluate_into(layout, control, here)
    exact = reference(binding, control, "planar_bones")
    assert np.abs(windows - here).max() <= TOLERANCE and np.abs(windows - exact).max() <= TOLERANCE
    assert np.abs(exact - binding.rest_vertices).max() > 1e-3  # the control points moved the points by millimetres
