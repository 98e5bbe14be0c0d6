"""Scripts around the add-on, grouped by job; run each as a module from the repository root:

    .venv/bin/python -m scripts.convert --face FACE.blend IN.fap... -o OUTDIR    convert streams (user command)
    .venv/bin/python -m scripts.build_extension                                  build the extension zips
    .venv/bin/python -m scripts.bench.<name>                                     benchmarks (the figures of docs/)
    .venv/bin/python -m scripts.sample.<name>                                    build the sample heads and stream
    .venv/bin/python -m scripts.docs.<name>                                      render the pictures of docs/

`convert.py` also runs as a file inside Blender (`blender --background --python scripts/convert.py -- ...`),
so it imports nothing from this package. The shell entry points (`run_demo.sh`, `run_tests.sh`,
`run_benchmarks.sh`, `setup_env.sh`) sit here too.
"""
