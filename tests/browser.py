"""Headless Chromium for the tests: found or installed from Debian, driven over the DevTools
protocol with aiohttp's websocket client (no webdriver, nothing downloaded but the Debian
package).
"""

import asyncio
import base64
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest


def chromium() -> str:
    """Chromium from Debian: found, or installed with apt-get when root; else skip."""
    for name in ("chromium", "chromium-browser"):
        if shutil.which(name):
            return shutil.which(name)
    if os.environ.get("WRINKLE_VIS_NO_APT"):
        pytest.skip("no Chromium, and WRINKLE_VIS_NO_APT forbids installing it")
    if not shutil.which("apt-get") or os.geteuid() != 0:
        pytest.skip("no Chromium, and it cannot be installed here (needs root and apt-get): "
                    "apt-get install chromium")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    install = ["apt-get", "install", "-y", "-qq", "chromium"]
    log = ""
    for command in (install, ["apt-get", "update", "-qq"], install):
        try:
            done = subprocess.run(command, env=env, capture_output=True, text=True,
                                  timeout=600)
        except subprocess.TimeoutExpired:
            pytest.skip(f"installing Chromium timed out: {' '.join(command)}")
        log = done.stderr[-500:]
        if command is install and done.returncode == 0 and shutil.which("chromium"):
            return shutil.which("chromium")
    pytest.skip(f"Chromium could not be installed with apt-get: {log}")


class Browser:
    """Headless Chromium driven over the DevTools protocol (aiohttp's websocket client)."""

    def __init__(self, executable: str, size=(1000, 760)):
        self.executable, self.size = executable, size

    async def __aenter__(self):
        import aiohttp

        self._dir = tempfile.mkdtemp(prefix="wv-chromium-")
        self._log = open(Path(self._dir) / "chromium.log", "w")  # noqa: SIM115
        self._proc = subprocess.Popen(
            [self.executable, "--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
             "--no-first-run", "--disable-extensions", "--use-angle=swiftshader",
             "--enable-unsafe-swiftshader", f"--user-data-dir={self._dir}",
             "--remote-debugging-address=127.0.0.1", "--remote-debugging-port=0",
             f"--window-size={self.size[0]},{self.size[1]}", "--hide-scrollbars",
             "about:blank"], stdout=subprocess.DEVNULL, stderr=self._log)
        port_file = Path(self._dir) / "DevToolsActivePort"
        deadline = time.monotonic() + 60
        while not (port_file.exists() and port_file.read_text().strip()):
            if self._proc.poll() is not None or time.monotonic() > deadline:
                await self._stop()
                pytest.skip("headless Chromium does not start here: "
                            + (Path(self._dir) / "chromium.log").read_text()[-400:])
            await asyncio.sleep(0.1)
        port = int(port_file.read_text().split()[0])
        self._session = aiohttp.ClientSession()
        async with self._session.get(f"http://127.0.0.1:{port}/json/list") as reply:
            page = next(t for t in await reply.json() if t["type"] == "page")
        self._ws = await self._session.ws_connect(page["webSocketDebuggerUrl"], max_msg_size=0)
        self._id = 0
        await self.call("Page.enable")
        return self

    async def __aexit__(self, *exc):
        await self._ws.close()
        await self._session.close()
        await self._stop()

    async def _stop(self):
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(20)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait(20)
        self._log.close()
        shutil.rmtree(self._dir, ignore_errors=True)

    async def call(self, method: str, **params):
        self._id += 1
        mine = self._id
        await self._ws.send_json({"id": mine, "method": method, "params": params})
        while True:
            message = await asyncio.wait_for(self._ws.receive_json(), 60)
            if message.get("id") == mine:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message["result"]

    async def evaluate(self, expression: str):
        reply = await self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return reply["result"].get("value")

    async def goto(self, url: str):
        await self.call("Page.navigate", url=url)

    async def view_box(self, timeout: float = 60.0):
        """The largest canvas or image in the window once there is one: (x, y, w, h)."""
        script = """(() => { let best = null;
          for (const e of document.querySelectorAll('canvas, img')) {
            const r = e.getBoundingClientRect();
            const x = Math.max(r.left, 0), y = Math.max(r.top, 0);
            const w = Math.min(r.right, innerWidth) - x, h = Math.min(r.bottom, innerHeight) - y;
            if (w > 100 && h > 100 && (!best || w * h > best[2] * best[3]))
              best = [x, y, w, h]; }
          return best; })()"""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            box = await self.evaluate(script)
            if box:
                return [int(round(v)) for v in box]
            await asyncio.sleep(0.25)
        raise AssertionError("no canvas or image on the page")

    async def screenshot(self) -> np.ndarray:
        import imageio.v3 as iio

        shot = await self.call("Page.captureScreenshot", format="png")
        return iio.imread(base64.b64decode(shot["data"]))[..., :3]
