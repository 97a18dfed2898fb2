"""Look at the built site in a real browser: headless Chromium on the Chrome DevTools Protocol.

    make docs && .venv/bin/python docs/check_site.py [--out DIR]

Serves ``build/site`` on 127.0.0.1, opens the home page, an API page and a tutorial and saves a screenshot of
each, then types queries into the search box and waits for MkDocs Material's search (a web worker, which a
plain ``chromium --screenshot`` does not wait for) to list results; it prints the number of results and the first
titles of each query, saves the screenshot of the first, and exits 1 when a query finds nothing or a page does
not load. It needs a ``chromium`` on the PATH (Debian: ``apt-get install chromium``) and tornado's websocket
client (installed with the ``dask`` extra); it is a developer's check, not part of ``make test``.
"""

from __future__ import annotations

import argparse
import base64
import functools
import http.server
import json
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

from tornado.ioloop import IOLoop
from tornado.websocket import websocket_connect

ROOT = Path(__file__).resolve().parent.parent
PAGES = {"home": "", "api": "reference/api/simulate/", "tutorial": "tutorials/your-plant/"}
QUERIES = ("consistency", "design_observer_gain", "cart-pole", "Theorem 3.1")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _Tab:
    """One page of the browser, driven over its DevTools websocket."""

    def __init__(self, ws: object) -> None:
        self.ws = ws
        self.n = 0

    async def call(self, method: str, **params: object) -> dict:
        self.n += 1
        await self.ws.write_message(json.dumps({"id": self.n, "method": method, "params": params}))
        while True:
            msg = json.loads(await self.ws.read_message())
            if msg.get("id") == self.n:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})

    async def js(self, expression: str) -> object:
        res = await self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        return res.get("result", {}).get("value")

    async def goto(self, url: str) -> None:
        await self.call("Page.navigate", url=url)
        for _ in range(100):
            if await self.js("document.readyState") == "complete":
                return
            time.sleep(0.1)
        raise RuntimeError(f"{url} did not load")

    async def shot(self, path: Path) -> None:
        data = await self.call("Page.captureScreenshot", format="png")
        path.write_bytes(base64.b64decode(data["data"]))


async def _check(base: str, port: int, out: Path) -> list[str]:
    tabs = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/json").read())
    ws = await websocket_connect(next(t for t in tabs if t.get("type") == "page")["webSocketDebuggerUrl"],
                                 max_message_size=64 * 2**20)
    tab = _Tab(ws)
    await tab.call("Page.enable")
    await tab.call("Emulation.setDeviceMetricsOverride", width=1280, height=1000, deviceScaleFactor=1, mobile=False)
    problems = []
    for name, path in PAGES.items():
        await tab.goto(base + path)
        title = await tab.js("document.title")
        h1 = await tab.js("document.querySelector('article h1') && document.querySelector('article h1').innerText")
        print(f"{name:9s} {base + path}: title {title!r}, heading {h1!r}")
        if not h1:
            problems.append(f"{path or '/'}: no heading")
        await tab.shot(out / f"{name}.png")
    for i, query in enumerate(QUERIES):
        await tab.goto(base)
        await tab.js("document.querySelector('label.md-search__icon, label[for=__search]').click()")
        await tab.js(f"(() => {{ const i = document.querySelector('input.md-search__input'); i.focus(); "
                     f"i.value = {json.dumps(query)}; i.dispatchEvent(new Event('input', {{bubbles: true}})); "
                     f"i.dispatchEvent(new KeyboardEvent('keyup', {{bubbles: true}})); }})()")
        found: list[str] = []
        meta = ""
        for _ in range(200):  # the worker builds the index first: up to 20 s
            time.sleep(0.1)
            meta = str(await tab.js("(document.querySelector('.md-search-result__meta') || {}).innerText || ''"))
            found = await tab.js("Array.from(document.querySelectorAll('.md-search-result__item h1, "
                                 ".md-search-result__item h2')).map(e => e.innerText).slice(0, 4)") or []
            if found:
                break
        print(f"search {query!r}: {meta.strip()!r}; first: {found}")
        if not found:
            problems.append(f"search {query!r} found nothing ({meta.strip()!r})")
        if i == 0:
            await tab.shot(out / "search.png")
    ws.close()
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--site", type=Path, default=ROOT / "build" / "site")
    parser.add_argument("--out", type=Path, default=ROOT / "build" / "screenshots")
    args = parser.parse_args()
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser is None:
        print("check_site: no chromium on the PATH (Debian: apt-get install chromium)", file=sys.stderr)
        return 2
    if not (args.site / "index.html").is_file():
        print(f"check_site: no site in {args.site} (make docs)", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, format: str, *a: object) -> None:  # noqa: A002 - the base class's name
            pass

    handler = functools.partial(Quiet, directory=str(args.site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    base = f"http://127.0.0.1:{server.server_address[1]}/"
    port = _free_port()
    with tempfile.TemporaryDirectory() as profile:
        proc = subprocess.Popen([browser, "--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                                 f"--remote-debugging-port={port}", f"--user-data-dir={profile}", "about:blank"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for _ in range(100):
                try:
                    urllib.request.urlopen(f"http://127.0.0.1:{port}/json/version", timeout=1)
                    break
                except OSError:
                    time.sleep(0.1)
            problems = IOLoop.current().run_sync(lambda: _check(base, port, args.out), timeout=180)
        finally:
            proc.terminate()
            proc.wait(timeout=10)
            server.shutdown()
    print(f"screenshots in {args.out}")
    for p in problems:
        print(f"check_site: {p}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    raise SystemExit(main())
