"""The web player's frame time in headless Chromium (software WebGL) and the `.glb`'s size per second of animation.

    .venv/bin/python -m scripts.bench.bench_web_player [--glb FILE.glb] [--frames 120] [--rounds 3] [--size 480x480]

Without --glb it measures the sample exported by `convert.py --glb` (`scripts/web/sample_glb.py`). Each round
loads the page afresh and draws `frames` frames, one animation step each; `render` waits for the GPU after each
draw (SwiftShader: the CPU), `interval` is the time between the browser's animation frames. Needs what the web
test needs (scripts/setup_web.sh).
"""

from __future__ import annotations

import argparse
import json
import statistics
import struct
import sys
import tempfile
from pathlib import Path

from scripts.web import sample_glb
from scripts.web.browser import shoot

COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}  # glTF componentType
ELEMENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def animation_bytes(glb: Path) -> int:
    """Bytes of the key times and values the file's animations use (the rest is mesh, skin and materials)."""
    data = glb.read_bytes()
    length, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON", f"{glb}: the first chunk of a .glb is its JSON"
    gltf = json.loads(data[20 : 20 + length])
    used = {i for a in gltf.get("animations", []) for s in a["samplers"] for i in (s["input"], s["output"])}
    accessors = [gltf["accessors"][i] for i in used]
    return sum(a["count"] * COMPONENT_BYTES[a["componentType"]] * ELEMENTS[a["type"]] for a in accessors)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--glb", type=Path, help="the file to play (default: the sample, exported afresh)")
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--size", default="480x480", help="viewport WIDTHxHEIGHT, CSS pixels (device pixel ratio 1)")
    args = parser.parse_args(argv)
    size = tuple(int(n) for n in args.size.split("x"))
    with tempfile.TemporaryDirectory() as folder:
        glb = args.glb
        if glb is None:
            glb = sample_glb.export(Path(folder))
        rounds = [shoot(glb, size=size, measure=args.frames) for _ in range(args.rounds)]
        size_bytes, keys = glb.stat().st_size, animation_bytes(glb)
    duration = rounds[0]["duration"]
    print(f"{glb.name}: {size_bytes / 1024:.1f} KiB, of which animation keys {keys / 1024:.1f} KiB; {duration:g} s")
    if duration > 0:
        print(
            f"per second of animation: {size_bytes / 1024 / duration:.1f} KiB (whole file), "
            f"{keys / 1024 / duration:.2f} KiB (keys)"
        )
    print(f"renderer: {rounds[0]['renderer']}; viewport {args.size}")
    for name in ("renderMs", "intervalMs"):
        values = [r["frameTime"][name] for r in rounds]
        print(
            f"{name[:-2]:>8}: median {statistics.median(values):6.1f} ms/frame  (rounds: "
            + ", ".join(f"{v:.1f}" for v in values)
            + f"; {args.frames} frames each)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
