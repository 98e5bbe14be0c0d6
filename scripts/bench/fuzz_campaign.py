"""A campaign of malformed inputs through the newer doors, made differently from the tests' corpora.

    .venv/bin/python -m scripts.bench.fuzz_campaign [--seed 2026] [--scale 1.0] [--keep FOLDER]

The tests mutate bytes with a fixed token list (hypothesis) and hand-pick cases; here every input comes
from a grammar with its own generator: documents that are valid JSON or XML in shape with field values
drawn from "nasty numbers" (subnormals, 1.7e308, 400-digit integers, '-0', '1E+999', leading zeros, hex),
wrong types, unknown keys and ids, nesting by objects rather than arrays, the real XFace files with
attributes replaced, encoding declarations from Python's codec names and byte order marks; cue lines with
random field counts, line ends and labels; texts with control and private-use characters; FP empties
moved by random factors; paths that are FIFOs, folders, devices, 300-byte names and NUL characters.

Doors: the FDP and XFace readers, Import FDP, the cue readers, Import Lip-Sync Cues, Speak Text, Fit to
Feature Points, Fit to Calibration Mesh (random scans with their own FPs), convert.py and say.py. For each
input it checks the promise: the core raises nothing but an Mpeg4Error; an operator is refused with a
report (never "Internal error") and leaves the scene as it was (objects, transforms, evaluated face,
actions, shape keys, settings, files) or finishes; nothing runs past 30 s (SIGALRM). Prints the counts per
door and every break, and keeps the breaking inputs in --keep.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import face_data, fitting_store, reporting
from addon.errors import Mpeg4Error
from addon.fitting.fdp_file import parse_fdp
from addon.fitting.xface_fdp import parse_xface_fdp
from addon.mpeg4.feature_points import FP_IDS
from addon.speech import cue_files
from scripts import convert

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
XFACE_FILES = sorted(Path("/work/shared/interop/fap").rglob("*.fdp"))
LIMIT_SECONDS = 30
NASTY = [
    "0", "-0", "0.0", "-0.0", "5e-324", "2.2250738585072014e-308", "1e-300", "1e300", "1.7976931348623157e308",
    "1E+999", "-1e999", "1" * 400, "-" + "9" * 330, "007", "0x10", "1.", ".5", "1e", "+1", "1_000", "١٢",
    "3.4028235e38", "3.4028236e38", "65535", "65536", "-1", "0.05", "1000", "1e6", "true", "null", '"0.1"',
]  # fmt: skip
LABELS = ["p", "AA", "PP", "_", "X", "A", "14", "15", "-1", "aI@", "ʃ", "\u200b", "\ue000", "NONE", "E", "zz", "#"]
ENCODINGS = ["utf-8", "UTF-16", "utf-32", "cp1252", "latin-1", "shift_jis", "UTF-7", "ebcdic", "", "utf-8 ", "x" * 80]
IMAGES = ["a" * 300 + ".png", "/dev/zero", ".", "x\u0000.png"]
BOMS = [b"", b"\xef\xbb\xbf", b"\xff\xfe", b"\xfe\xff", b"\x00\x00\xfe\xff"]


class Campaign:
    """Counts and breaks per door; the scene it runs on."""

    def __init__(self, seed: int, folder: Path, keep: Path | None):
        self.rng = random.Random(seed)
        self.folder = folder
        self.keep = keep
        self.counts: dict[str, dict[str, int]] = {}
        self.breaks: list[str] = []
        self.saved = folder / "face.blend"

    def count(self, door: str, outcome: str) -> None:
        self.counts.setdefault(door, {}).setdefault(outcome, 0)
        self.counts[door][outcome] += 1

    def broke(self, door: str, what: str, data: bytes | None) -> None:
        self.count(door, "BROKE")
        kept = ""
        if self.keep is not None and data is not None:
            self.keep.mkdir(parents=True, exist_ok=True)
            path = self.keep / f"{door.replace(' ', '_')}_{len(self.breaks)}"
            path.write_bytes(data)
            kept = f" (input kept as {path})"
        self.breaks.append(f"{door}: {what}{kept}")

    # ------------------------------------------------------------------ generators

    def nasty(self) -> str:
        return self.rng.choice(NASTY) if self.rng.random() < 0.6 else repr(self.rng.uniform(-0.2, 0.2))

    def value(self, depth: int = 0) -> str:
        """A JSON value that is often not what the field wants."""
        r = self.rng.random()
        if r < 0.5 or depth > 2:
            return self.nasty()
        if r < 0.7:
            return "[" + ", ".join(self.value(depth + 1) for _ in range(self.rng.randrange(5))) + "]"
        if r < 0.85:
            return json.dumps(self.rng.choice(LABELS + ["", "a" * 300]))
        return "{" + ", ".join(f'"{self.rng.choice(FP_IDS)}": {self.value(depth + 1)}' for _ in range(2)) + "}"

    def fdp_text(self) -> bytes:
        ids = self.rng.sample(FP_IDS, self.rng.randrange(1, 12)) + (
            ["99.9", "2.1 ", ""] if self.rng.random() < 0.1 else []
        )
        points = ", ".join(
            f'"{fp_id}": [{", ".join(self.nasty() for _ in range(self.rng.choice([3, 3, 3, 2, 4])))}]' for fp_id in ids
        )
        parts = ['"format": "mpeg4-face-fdp"', f'"version": {self.rng.choice(["1", "1", "2", "1.0", "true"])}']
        parts.append(f'"feature_points": {{{points}}}')
        if self.rng.random() < 0.4:
            uv = ", ".join(f'"{fp_id}": [{self.nasty()}, {self.nasty()}]' for fp_id in ids[:3])
            parts.append(f'"texture_coordinates": {{{uv}}}')
        if self.rng.random() < 0.3:
            names = ("IRISD0", "ES0", "ENS0", "MNS0", "MW0")
            parts.append('"fapu": {' + ", ".join(f'"{n}": {self.nasty()}' for n in names) + "}")
        if self.rng.random() < 0.3:
            image = self.rng.choice(IMAGES)
            parts.append(f'"image": {json.dumps(image)}')
        if self.rng.random() < 0.15:
            parts.append(f'"{self.rng.choice(["extra", "format", "about"])}": {self.value()}')
        if self.rng.random() < 0.1:
            depth = self.rng.choice([70, 1000, 200_000])
            parts.append('"deep": ' + '{"a": ' * depth + "0" + "}" * depth)
        self.rng.shuffle(parts)
        text = "{" + ", ".join(parts) + "}"
        if self.rng.random() < 0.15:
            text = text[: self.rng.randrange(len(text))]
        return text.encode("utf-8", "surrogatepass")

    def xface_text(self) -> bytes:
        data = self.rng.choice(XFACE_FILES).read_bytes()
        text = data.decode("latin-1")
        for _ in range(self.rng.randrange(1, 4)):
            r = self.rng.random()
            if r < 0.5:  # an attribute's value replaced
                at = text.find('="', self.rng.randrange(len(text)))
                if at > 0:
                    end = text.find('"', at + 2)
                    text = text[: at + 2] + self.rng.choice(NASTY).replace('"', "") + text[end:]
            elif r < 0.7:  # an element removed or doubled
                at = text.find("<", self.rng.randrange(len(text)))
                end = text.find(">", at)
                if at > 0 and end > at:
                    piece = text[at : end + 1]
                    text = text[:at] + (piece * 2 if self.rng.random() < 0.5 else "") + text[end + 1 :]
            elif r < 0.85:  # another declared encoding
                text = text.replace("<?xml", f'<?xml encoding="{self.rng.choice(ENCODINGS)}"', 1)
            else:
                text = text[: self.rng.randrange(len(text))]
        return self.rng.choice(BOMS) + text.encode("latin-1", "replace")

    def cue_text(self) -> tuple[str, bytes]:
        kind = self.rng.choice(["tsv", "rhubarb.tsv", "json", "rhubarb.json"])
        n = self.rng.choice([1, 2, 3, 5, 20, 200])
        if kind.endswith("json"):
            key, label = ("mouthCues", "value") if kind.startswith("rhubarb") else ("segments", "label")
            items = []
            for _ in range(n):
                fields = [f'"start": {self.nasty()}', f'"end": {self.nasty()}', f'"{label}": {self.value()}']
                if self.rng.random() < 0.1:
                    fields.append(f'"{self.rng.choice(["start", "x"])}": 0')
                items.append("{" + ", ".join(fields) + "}")
            text = f'{{"{key}": [{", ".join(items)}]}}'
            if self.rng.random() < 0.1:
                text = '{"segments": ' + '{"a": ' * 5000 + "1" + "}" * 5000 + "}"
            return f"cues.{kind}".replace("rhubarb.", "r_"), text.encode("utf-8", "surrogatepass")
        line_end = self.rng.choice(["\n", "\r\n", "\r", "\n\n"])
        lines = []
        t = 0.0
        for _ in range(n):
            t += self.rng.choice([0.0, 0.04, 0.1, -0.1, 1e6, 3600.0])
            fields = [self.nasty() if self.rng.random() < 0.3 else f"{t:g}"]
            if kind == "tsv":
                fields.append(self.nasty() if self.rng.random() < 0.3 else f"{t + 0.1:g}")
            fields.append(self.rng.choice(LABELS))
            if self.rng.random() < 0.1:
                fields = fields[: self.rng.randrange(len(fields))] or ["#"]
            lines.append(self.rng.choice(["\t", " ", "  \t"]).join(fields))
        name = "cues.tsv" if kind == "tsv" else "r_cues.tsv"
        return name, line_end.join(lines).encode("utf-8", "surrogatepass")

    def special_path(self) -> Path:
        """A path that is not a regular file one can read or write."""
        choice = self.rng.randrange(5)
        if choice == 0:
            fifo = self.folder / f"fifo{self.rng.randrange(10**9)}"
            os.mkfifo(fifo)
            return fifo
        if choice == 1:
            return self.folder
        if choice == 2:
            return Path("/dev/zero") if self.rng.random() < 0.5 else Path("/dev/null")
        if choice == 3:
            return self.folder / ("é" * 150 + ".json")
        return self.folder / "missing" / "none.json"

    # ------------------------------------------------------------------ running

    def core(self, door: str, read, data: bytes) -> None:
        try:
            with deadline():
                read(data)
            self.count(door, "accepted")
        except Mpeg4Error:
            self.count(door, "refused")
        except TimeoutError:
            self.broke(door, "hang", data)
        except Exception as exc:
            self.broke(door, f"{type(exc).__name__}: {exc}"[:300], data)

    def operator(self, door: str, call, data: bytes | None, face_name: str = "Head") -> None:
        head = bpy.data.objects[face_name]
        before = scene_state(head, self.folder)
        try:
            with deadline():
                call()
        except TimeoutError:
            self.broke(door, "hang", data)
            self.reopen()
            return
        except RuntimeError as exc:
            text = str(exc)
            if "Internal error" in text or "Traceback" in text:
                self.broke(door, text.splitlines()[0][:300], data)
                self.reopen()
                return
            if scene_state(bpy.data.objects[face_name], self.folder) != before:
                self.broke(door, f"changed the scene after refusing: {text.strip()[:200]}", data)
                self.reopen()
                return
            self.count(door, "refused")
            return
        except Exception as exc:  # RAISE_UNEXPECTED: a bug escaped the operator
            self.broke(door, f"{type(exc).__name__}: {exc}"[:300], data)
            self.reopen()
            return
        self.count(door, "accepted")
        self.reopen()

    def reopen(self) -> None:
        bpy.ops.wm.open_mainfile(filepath=str(self.saved))
        convert.select_only(bpy.data.objects["Head"])
        for path in self.folder.iterdir():
            if path.name not in ("face.blend", "sample.json") and not path.is_dir():
                path.unlink()


def deadline():
    class Alarm:
        def __enter__(self):
            def stop(_signum, _frame):
                raise TimeoutError

            self.previous = signal.signal(signal.SIGALRM, stop)
            signal.alarm(LIMIT_SECONDS)

        def __exit__(self, *_exc):
            signal.alarm(0)
            signal.signal(signal.SIGALRM, self.previous)
            return False

    return Alarm()


def scene_state(head, folder: Path):
    """What a refusal must leave as it was."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = head.evaluated_get(depsgraph).to_mesh()
    co = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", co)
    head.evaluated_get(depsgraph).to_mesh_clear()
    objects = tuple(
        (
            ob.name,
            tuple(tuple(row) for row in ob.matrix_world),
            ob.animation_data.action.name if ob.animation_data and ob.animation_data.action else None,
        )
        for ob in bpy.data.objects
    )
    keys = head.data.shape_keys
    scene = bpy.context.scene
    return (
        co.tobytes(),
        objects,
        tuple(sorted(a.name for a in bpy.data.actions)),
        tuple(k.name for k in keys.key_blocks) if keys else None,
        tuple(head.mpeg4_face.fapu),
        head.mpeg4_face.status,
        fitting_store.holder(head) is not None,
        tuple(sorted(s.name for s in bpy.data.sounds)),
        scene.sequence_editor is not None,
        (scene.frame_start, scene.frame_end),
        tuple(sorted(os.listdir(folder))),
    )


def run(campaign: Campaign, scale: float) -> None:
    rng = campaign.rng
    folder = campaign.folder
    n = {door: max(1, round(count * scale)) for door, count in DOORS.items()}

    for _ in range(n["FDP reader"]):
        campaign.core("FDP reader", parse_fdp, campaign.fdp_text())
    for _ in range(n["XFace reader"]):
        campaign.core("XFace reader", parse_xface_fdp, campaign.xface_text())

    def read_cues(name, data):
        path = folder / name
        path.write_bytes(data)
        try:
            return cue_files.read_cue_file(path)
        finally:
            path.unlink()

    for _ in range(n["cue readers"]):
        name, data = campaign.cue_text()
        campaign.core("cue readers", lambda d, name=name: read_cues(name, d), data)

    for k in range(n["Import FDP"]):
        r = rng.random()
        if r < 0.15:
            path, data = campaign.special_path(), None
        else:
            data = campaign.xface_text() if r < 0.4 else campaign.fdp_text()
            path = folder / f"in{k}.{'fdp' if r < 0.4 else 'json'}"
            path.write_bytes(data)
        unit = rng.choice([0.001, 1.0, 1e-9, 1e6])
        campaign.operator(
            "Import FDP", lambda p=path, u=unit: bpy.ops.mpeg4.import_fdp(filepath=str(p), xface_unit=u), data
        )
        if data is not None:
            path.unlink(missing_ok=True)

    for k in range(n["Import Lip-Sync Cues"]):
        options = {"start_frame": rng.choice([1, 0, -5, 1_000_000]), "set_frame_range": rng.random() < 0.7}
        if rng.random() < 0.2:
            options["audio_filepath"] = str(campaign.special_path())
        if rng.random() < 0.1:
            path, data = campaign.special_path(), None
        else:
            name, data = campaign.cue_text()
            path = folder / f"{k}_{name}"
            path.write_bytes(data)
        campaign.operator(
            "Import Lip-Sync Cues", lambda p=path, o=options: bpy.ops.mpeg4.import_cues(filepath=str(p), **o), data
        )

    for _ in range(n["Speak Text"]):
        text = "".join(
            rng.choice(["hello ", "1 ", "\u0007", "\ue000", "<speak>", "\u202e", "ʃ", "  ", "\x00", ".", "Zürich "])
            for _ in range(rng.choice([0, 1, 3, 10]))
        )
        if rng.random() < 0.05:
            text = "a " * 10_001
        options = {
            "text": text,
            "voice": rng.choice(["en", "", "xx", "en\x00", "../../etc", "en-us", "a" * 70]),
            "rate": rng.choice([80, 175, 450]),
            "start_frame": rng.choice([1, 1_048_000]),
            "set_frame_range": rng.random() < 0.5,
        }
        if rng.random() < 0.4:
            options["audio_filepath"] = str(campaign.special_path())
        campaign.operator(
            "Speak Text", lambda o=options: bpy.ops.mpeg4.speak_text(**o), text.encode("utf-8", "surrogatepass")
        )

    for _ in range(n["Fit to Feature Points"]):
        empties = face_data.fp_empties(bpy.data.objects["Head"])
        factor = rng.choice([1e6, 1e3, 200.0, 1e-3, 1e-6, 0.0])
        centre = np.array(rng.choice(list(empties.values())).location)
        moved = rng.sample(list(empties.values()), rng.choice([1, 5, len(empties)]))
        for ob in moved:
            offset = np.array(ob.location) - centre
            ob.location = centre + factor * offset + (rng.choice([0.0, 1e38, -3e38]) if len(moved) == 1 else 0.0)
        bpy.context.view_layer.update()
        campaign.operator("Fit to Feature Points", lambda: bpy.ops.mpeg4.fit_to_feature_points(), None)
        campaign.reopen()

    for _ in range(n["Fit to Calibration Mesh"]):
        calibration_target(campaign)
        campaign.operator("Fit to Calibration Mesh", lambda: bpy.ops.mpeg4.fit_to_calibration_mesh(), None)
        campaign.reopen()

    scripts_door(campaign, n["convert.py / say.py"])


def calibration_target(campaign: Campaign) -> None:
    """A selected scan: a random closed-ish surface (a sphere of random size, some vertices thrown far, some
    triangles collapsed) with its own FP empties, of random ids and places."""
    rng = campaign.rng
    head = bpy.data.objects["Head"]
    size = rng.choice([1e-6, 1e-3, 0.1, 0.2, 10.0, 1e4])
    turns = np.linspace(0.0, np.pi, 12)[:, None], np.linspace(0.0, 2 * np.pi, 16, endpoint=False)[None, :]
    sphere = np.stack(
        [np.sin(turns[0]) * np.cos(turns[1]), np.sin(turns[0]) * np.sin(turns[1]), np.cos(turns[0]) + 0 * turns[1]], -1
    )
    vertices = (size * sphere.reshape(-1, 3)).tolist()
    for k in rng.sample(range(len(vertices)), rng.choice([0, 0, 1, 20])):
        vertices[k] = [rng.choice([1e30, -3e38, 0.0, size]) for _ in range(3)]
    faces = [(a * 16 + b, a * 16 + (b + 1) % 16, (a + 1) * 16 + b) for a in range(11) for b in range(16)]
    faces += [(0, 0, 1)] * rng.choice([0, 3])
    mesh = bpy.data.meshes.new("Scan")
    mesh.from_pydata(vertices, [], faces if rng.random() > 0.05 else [])
    target = bpy.data.objects.new("Scan", mesh)
    bpy.context.scene.collection.objects.link(target)
    collection = bpy.data.collections.new("Scan FPs")
    bpy.context.scene.collection.children.link(collection)
    for fp_id in rng.sample(FP_IDS, rng.choice([1, 3, 10, 40])):
        empty = bpy.data.objects.new(f"Scan FP {fp_id}", None)
        empty["mpeg4_fp"] = fp_id
        empty.location = [size * rng.uniform(-1, 1) * rng.choice([1.0, 1.0, 1e3, 0.0]) for _ in range(3)]
        collection.objects.link(empty)
    bpy.context.view_layer.update()
    convert.select_only(head)
    target.select_set(True)


def scripts_door(campaign: Campaign, count: int) -> None:
    rng, folder = campaign.rng, campaign.folder
    for k in range(count):
        out = folder / f"out{k}"
        r = rng.random()
        if r < 0.5:
            stream = folder / f"s{k}.fap"
            frames = rng.choice([0, 1, 2])
            header = f"{rng.choice(['2.1', '2.0', '3'])} x {rng.choice(NASTY[:12])} {frames}\n"
            body = "".join(
                ("1 " * 68).strip() + "\n" + "0 " + " ".join(rng.choice(NASTY[:14]) for _ in range(68)) + "\n"
                for _ in range(frames)
            )
            stream.write_bytes((header + body).encode())
            command = [
                "scripts.convert",
                str(stream),
                "-o",
                str(out),
                "--face",
                str(SAMPLE),
                "--no-video",
                "--sheet",
                "0",
            ]
            if rng.random() < 0.3:
                command += ["--object", rng.choice(["Eye L", "Tongue", "Head FPs", "\x7f"])]
        else:
            face = rng.choice([folder / "notes.txt", folder / "cut.blend", SAMPLE, folder])
            command = [
                "scripts.say",
                rng.choice(["Hello", "", "\u0007"]),
                "--face",
                str(face),
                "-o",
                str(out),
                "--no-video",
            ]
            if rng.random() < 0.5:
                command += ["--object", rng.choice(["Eye L", "Nothing"])]
        try:
            result = subprocess.run(
                [sys.executable, "-m", *command], capture_output=True, text=True, timeout=300, cwd=ROOT
            )
        except subprocess.TimeoutExpired:
            campaign.broke("convert.py / say.py", f"hang: {command}", None)
            continue
        said = result.stdout + result.stderr
        wrote = out.exists() and any(out.iterdir())
        if "Traceback" in said or any(
            f"FAILED: {name}" in said for name in ("ValueError", "IndexError", "TypeError", "KeyError", "Overflow")
        ):
            campaign.broke("convert.py / say.py", f"{command[0]}: {said.strip().splitlines()[-1][:200]}", None)
        elif command[0] == "scripts.say" and result.returncode == 2 and wrote:
            campaign.broke("convert.py / say.py", "say.py wrote files before refusing", None)
        else:
            campaign.count("convert.py / say.py", "refused" if result.returncode else "accepted")
        shutil.rmtree(out, ignore_errors=True)


DOORS = {
    "FDP reader": 180,
    "XFace reader": 120,
    "cue readers": 200,
    "Import FDP": 200,
    "Import Lip-Sync Cues": 200,
    "Speak Text": 100,
    "Fit to Feature Points": 40,
    "Fit to Calibration Mesh": 40,
    "convert.py / say.py": 20,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--scale", type=float, default=1.0, help="multiply every door's count")
    parser.add_argument("--keep", type=Path, help="folder for the inputs that broke something")
    args = parser.parse_args(argv)
    addon.register()
    reporting.RAISE_UNEXPECTED = True
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        campaign = Campaign(args.seed, folder, args.keep)
        (folder / "notes.txt").write_text("not a face\n")
        (folder / "cut.blend").write_bytes(SAMPLE.read_bytes()[:5000])
        bpy.ops.wm.open_mainfile(filepath=str(SAMPLE))
        convert.select_only(bpy.data.objects["Head"])
        assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
        bpy.ops.wm.save_as_mainfile(filepath=str(campaign.saved))
        start = time.perf_counter()
        run(campaign, args.scale)
        seconds = time.perf_counter() - start
    total = sum(sum(c.values()) for c in campaign.counts.values())
    print(f"{total} inputs in {seconds:.0f} s (seed {args.seed})")
    for door, counts in campaign.counts.items():
        shown = ", ".join(f"{outcome} {n}" for outcome, n in sorted(counts.items()))
        print(f"  {door:24s} {sum(counts.values()):5d}: {shown}")
    print(f"breaks (traceback, internal error, hang, change after a refusal): {len(campaign.breaks)}")
    for line in campaign.breaks:
        print(f"  {line}")
    return 1 if campaign.breaks else 0


if __name__ == "__main__":
    sys.exit(main())
