"""The Flamenco job type `flamenco/mpeg4_face_convert.js`: valid JavaScript, its settings are convert.py's options
with convert.py's defaults, and the commands it authors, one task per stream, are commands convert.py runs.

It runs in Node with fakes of what Flamenco Manager gives a job type (`tests/scripts/flamenco_harness.js`):
the pinned Node that requirements.txt installs into .venv, else the machine's; without either they are skipped."""

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from scripts.web.browser import NODE

from .helpers import FACE, ROOT, cut_stream

pytestmark = pytest.mark.skipif(
    NODE is None, reason="needs Node.js to run the Flamenco job type: `bash scripts/setup_env.sh` installs it"
)

JOB_TYPE = ROOT / "flamenco" / "mpeg4_face_convert.js"
HARNESS = Path(__file__).with_name("flamenco_harness.js")
CONVERT = ROOT / "scripts" / "convert.py"
BLENDER_ARGS = "-b -y"  # the Manager's default for the variable {blenderArgs}

# What a Blender binary does with `blender [options] FACE.blend --python SCRIPT -- ARGS`, done with the bpy module:
# open FACE.blend, then run SCRIPT as __main__ with Blender's sys.argv (the whole command line). It stands for
# Blender's options only where the bpy module behaves the same already: -b/--background (always background),
# -y (scripts in the file may run), --python-exit-code 1 (an uncaught error already exits Python with 1).
BLENDER_AS_BPY_MODULE = textwrap.dedent("""
    import runpy, sys, bpy
    argv = sys.argv[1:]
    options, blend, script = argv[: argv.index("--")], None, None
    while options:
        option = options.pop(0)
        if option in ("-b", "--background", "-y"):
            continue
        if option == "--python-exit-code" and options.pop(0) == "1":
            continue
        if option == "--python" and script is None:
            script = options.pop(0)
        elif not option.startswith("-") and blend is None and script is None:
            blend = option
        else:
            sys.exit(f"the bpy module does not stand in for Blender's option {option!r}")
    bpy.ops.wm.open_mainfile(filepath=blend)
    sys.argv = ["blender", *argv]
    runpy.run_path(script, run_name="__main__")
""")


def compile_job(settings: dict | None = None) -> subprocess.CompletedProcess:
    command = [NODE, str(HARNESS), str(JOB_TYPE)] + ([] if settings is None else [json.dumps(settings)])
    return subprocess.run(command, capture_output=True, text=True, timeout=60)


def compiled(settings: dict) -> list[dict]:
    result = compile_job(settings)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)["tasks"]


def worker_argv(parameters: dict, blender: str) -> list[str]:
    """The command line a Flamenco Worker runs for a `blender-render` command (internal/worker/command_blender.go):
    exe, exeArgs split as a shell would, argsBefore, blendfile, args; with the Manager's variables filled in."""
    assert parameters["exe"] == "{blender}" and parameters["exeArgs"] == "{blenderArgs}"
    before = [*shlex.split(BLENDER_ARGS), *parameters["argsBefore"]]
    return [blender, *before, parameters["blendfile"], *parameters["args"]]


def settings_for(tmp_path, streams, **given) -> dict:
    return {
        "streams": "; ".join(str(s) for s in streams),
        "convert_script": str(CONVERT),
        "output_dir": str(tmp_path / "out"),
        "blendfile": str(FACE),
        **given,
    }


def test_the_job_type_is_valid_javascript():
    result = subprocess.run([NODE, "--check", str(JOB_TYPE)], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr


def test_the_settings_are_convert_options_with_its_defaults(tmp_path):
    from scripts import convert

    job_type = json.loads(compile_job().stdout)["jobType"]
    settings = {s["key"]: s for s in job_type["settings"]}
    assert settings["resolution"]["propargs"] == dict(zip(("min", "max"), convert.RESOLUTIONS, strict=True))
    assert settings["sheet"]["propargs"] == dict(zip(("min", "max"), convert.SHEET_FRAMES, strict=True))
    assert settings["engine"]["choices"] == list(convert.ENGINES)
    assert all(settings[key]["required"] for key in ("streams", "convert_script", "output_dir", "blendfile"))
    # only the required settings given: the task runs convert.py with convert.py's own defaults
    stream = tmp_path / "a.fap"
    (task,) = compiled(settings_for(tmp_path, [stream]))
    args = task["commands"][0]["parameters"]["args"]
    defaults = convert.parse_args([str(stream), "-o", str(tmp_path / "out")])
    assert args[args.index("-o") + 2 :] == convert.stream_options(defaults)


def test_the_commands_of_two_streams_are_convert_commands_that_run_here(tmp_path):
    from scripts import convert

    streams = [cut_stream(tmp_path / "a.fap", frames=6), cut_stream(tmp_path / "b.fap", frames=6)]
    options = {"resolution": 32, "video": False, "sheet": 0, "frames": "1:4", "engine": "WORKBENCH"}
    tasks = compiled(settings_for(tmp_path, streams, **options))
    assert [(t["name"], t["type"], len(t["commands"]), t["dependencies"]) for t in tasks] == [
        ("convert-a", "blender", 1, []),
        ("convert-b", "blender", 1, []),
    ]
    out = tmp_path / "out"
    expected_options = ["--resolution", "32", "--no-video", "--sheet", "0", "--frames", "1:4"]
    argvs = []
    for task, stream in zip(tasks, streams, strict=True):
        command = task["commands"][0]
        assert command["name"] == "blender-render"
        argv = worker_argv(command["parameters"], "blender")
        assert argv == [
            "blender", "-b", "-y", "--background", "--python-exit-code", "1", str(FACE),
            "--python", str(CONVERT), "--", str(stream), "-o", str(out),
            *convert.stream_options(convert.parse_args([str(stream), "-o", str(out), *expected_options])),
        ]  # fmt: skip
        argvs.append(argv)

    blender = os.environ.get("BLENDER") or shutil.which("blender")
    if blender:  # the command exactly as a Worker runs it
        run = [blender, *argvs[0][1:]]
    else:  # no Blender binary here: the bpy module stands in for it (BLENDER_AS_BPY_MODULE)
        run = [sys.executable, "-c", BLENDER_AS_BPY_MODULE, *argvs[0][1:]]
    result = subprocess.run(run, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert re.search(rf"^\[1/1\] {re.escape(str(streams[0]))}: ok in [\d.]+ s -> a.pc2, a.abc$", result.stdout, re.M)
    assert sorted(p.name for p in out.iterdir()) == ["a.abc", "a.log", "a.pc2"]
    from addon.formats.pc2 import read_pc2

    frames, start, _rate = read_pc2(str(out / "a.pc2"))
    assert frames.shape[0] == 4 and start == 1.0
    assert (out / "a.abc").stat().st_size > 0


@pytest.mark.parametrize(
    ("streams", "message"),
    [
        ("", "no FAP streams given: list them in the setting 'streams', separated by ';'"),
        (" ; ", "no FAP streams given: list them in the setting 'streams', separated by ';'"),
        ("/x/a.fap;/y/A.fap", "/x/a.fap and /y/A.fap would both write A.*: rename one"),
        ("a.fap", "a.fap: give streams as absolute paths (the Workers run in folders of their own)"),
    ],
)
def test_streams_no_task_could_convert_refuse_the_job(tmp_path, streams, message):
    result = compile_job({**settings_for(tmp_path, []), "streams": streams})
    assert result.returncode == 1 and result.stderr.strip() == f"compileJob: {message}"
