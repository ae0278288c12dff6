"""The offline web viewer of a tileset: assemble its folder, serve it on 127.0.0.1 (make view).

    python scripts/viewer.py build TILESET_DIR VIEWER_DIR   # page + CesiumJS + the tileset, self-contained
                                                             # (TILESET_DIR: a chain's 3dtiles/ or a tiled run's output)
    python scripts/viewer.py serve VIEWER_DIR [--port N]     # prints the URL, serves until Ctrl-C

The page is viewer/page/; CesiumJS is the npm package pinned in viewer/package.json, installed by
scripts/setup-viewer.sh into viewer/node_modules (never in git nor in the plugin zip). Files are hard
links where the file system allows (no extra space), copies otherwise. Nothing is fetched at view time.
"""
from __future__ import annotations

import argparse
import functools
import http.server
import os
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "viewer" / "page"
CESIUM_BUILD = ROOT / "viewer" / "node_modules" / "cesium" / "Build" / "Cesium"
DEFAULT_PORT = 8716
TYPES = {".glb": "model/gltf-binary", ".wasm": "application/wasm", ".js": "text/javascript",
         ".mjs": "text/javascript", ".json": "application/json", ".ktx2": "image/ktx2"}


#: what a tiled run's output folder holds beside its tilesets (the viewer needs none of it)
NOT_3DTILES = shutil.ignore_patterns("*.gml", "*.gpkg", "*.html", "*.csv", "*_textures", "work", "steps.json")


def _link_tree(source: Path, target: Path, ignore=None) -> None:
    def link(src: str, dst: str) -> None:
        try:
            os.link(src, dst)
        except OSError:
            shutil.copy2(src, dst)

    shutil.copytree(source, target, copy_function=link, ignore=ignore)


def build(tileset: Path, output: Path) -> Path:
    """Write the viewer folder ``output`` (replaced whole): index.html, app.js, cesium/, 3dtiles/."""
    if not (tileset / "tileset.json").is_file():
        sys.exit(f"{tileset} holds no tileset.json: export the tileset first (wit:export3dtiles).")
    if not (CESIUM_BUILD / "Cesium.js").is_file():
        sys.exit(f"CesiumJS is not installed ({CESIUM_BUILD}): run `make setup` once with access to the npm "
                 "registry (scripts/setup-viewer.sh).")
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".viewer-", dir=output.parent))
    try:
        for page in PAGE.iterdir():
            shutil.copy2(page, tmp / page.name)
        _link_tree(CESIUM_BUILD, tmp / "cesium")
        _link_tree(tileset, tmp / "3dtiles", NOT_3DTILES)  # a tiled run's folder: its tilesets only
        if output.exists():
            shutil.rmtree(output)
        os.replace(tmp, output)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return output / "index.html"


class _Handler(http.server.SimpleHTTPRequestHandler):
    extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map, **TYPES}

    def log_message(self, format: str, *args) -> None:  # noqa: A002 - the base class's name
        if os.environ.get("WIT_VIEWER_LOG"):
            super().log_message(format, *args)


def serve(folder: Path, port: int, host: str = "127.0.0.1") -> None:
    """Serve ``folder`` on host:port (0 = any free port); the first line printed is the URL."""
    if not (folder / "index.html").is_file():
        sys.exit(f"{folder} holds no index.html: run `make demo` first (it builds out/demo/viewer/).")
    server = http.server.ThreadingHTTPServer((host, port), functools.partial(_Handler, directory=str(folder)))
    print(f"http://{host}:{server.server_address[1]}/index.html", flush=True)
    print("(open it in a browser; Ctrl-C stops the server)", file=sys.stderr, flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    b = commands.add_parser("build", help="assemble the viewer folder")
    b.add_argument("tileset", type=Path)
    b.add_argument("output", type=Path)
    s = commands.add_parser("serve", help="serve a viewer folder on 127.0.0.1")
    s.add_argument("folder", type=Path)
    s.add_argument("--port", type=int, default=int(os.environ.get("WIT_VIEWER_PORT", DEFAULT_PORT)))
    args = parser.parse_args(argv)
    if args.command == "build":
        print(build(args.tileset, args.output))
    else:
        serve(args.folder, args.port)
    return 0


if __name__ == "__main__":
    sys.exit(main())
