"""Serve the web player (`web/`) and a folder of `.glb` files over HTTP, so that its ES modules load.

    .venv/bin/python -m scripts.web.serve MODELS_DIR [--port 8000]

Then open http://localhost:8000/?src=models/FILE.glb (`web/node_modules` must exist: `npm ci` in `web/`).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import sys
import threading
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
WEB = ROOT / "web"
MODELS = "/models/"


class _Handler(SimpleHTTPRequestHandler):
    """`web/` at the root, MODELS_DIR under /models/; quiet."""

    def __init__(self, *args, models: Path, **kwargs):
        self.models = models
        super().__init__(*args, directory=str(WEB), **kwargs)

    def translate_path(self, path: str) -> str:
        if path.startswith(MODELS):  # a handler serves one request, so it may switch its folder
            self.directory = str(self.models)
            path = path[len(MODELS) - 1 :]
        return super().translate_path(path)

    def log_message(self, format, *args):
        pass


@contextlib.contextmanager
def serving(models: Path, port: int = 0):
    """Serve in a thread while the block runs; yields the base URL (port 0: a free one)."""
    server = ThreadingHTTPServer(("127.0.0.1", port), functools.partial(_Handler, models=Path(models).resolve()))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("models", type=Path, help="the folder of .glb files, served under /models/")
    parser.add_argument("--port", type=int, default=8000)
    args = parser.parse_args(argv)
    with serving(args.models, args.port) as url:
        print(f"serving {WEB} and {args.models} at {url}?src=models/FILE.glb (Ctrl+C ends)")
        with contextlib.suppress(KeyboardInterrupt):
            threading.Event().wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
