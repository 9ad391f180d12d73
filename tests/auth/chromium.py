"""Headless Chromium driven over its DevTools protocol (aiohttp's websocket client):
what the web console's tests need, and nothing more."""

from __future__ import annotations

import base64
import json
import os
import re
import shutil
import subprocess
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any

import aiohttp
import pytest

from mrss.ports import free_port
from mrss.testing import wait_until

CHROMIUM = "/usr/bin/chromium"
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--window-size=1600,1000")
ANSI = re.compile(r"\x1b(\[[0-9;?<>=]*[ -/]*[@-~]|\][^\x07\x1b]*(\x07|\x1b\\)|[()][0-9A-B]|.)")


def chromium() -> str:
    """The browser, or a skip (a failure under MRSS_REQUIRE_CHROMIUM=1, as in CI)."""
    found = shutil.which("chromium") or (CHROMIUM if os.path.exists(CHROMIUM) else None)
    if found is None:
        if os.environ.get("MRSS_REQUIRE_CHROMIUM") == "1":
            pytest.fail("chromium is required (MRSS_REQUIRE_CHROMIUM=1) but not installed")
        pytest.skip("chromium is not installed")
    return found


class Browser:
    """One headless Chromium with a fresh profile; `close` ends it."""

    def __init__(self, profile: Path) -> None:
        self.port = free_port()
        self.proc = subprocess.Popen(
            [chromium(), *FLAGS, f"--user-data-dir={profile}",
             f"--remote-debugging-port={self.port}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def page_socket(self, timeout: float = 60.0) -> str:
        """The DevTools websocket of the browser's page."""
        def page() -> str | None:
            assert self.proc.poll() is None, "chromium ended"
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{self.port}/json/list",
                                            timeout=5) as reply:
                    pages = [t for t in json.load(reply) if t.get("type") == "page"]
            except OSError:
                return None
            return str(pages[0]["webSocketDebuggerUrl"]) if pages else None
        found: str = wait_until(page, timeout, interval=0.2,
                                message="chromium's DevTools answering")
        return found

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=10)


class Page:
    """A page over DevTools; `screen` is all the terminal text its web socket received
    (escape sequences taken out), which is what the browser draws."""

    def __init__(self, ws: aiohttp.ClientWebSocketResponse) -> None:
        self.ws = ws
        self.serial = 0
        self.screen = ""

    async def call(self, method: str, **params: Any) -> dict[str, Any]:
        self.serial += 1
        serial = self.serial
        await self.ws.send_json({"id": serial, "method": method, "params": params})
        while True:
            message = await self.ws.receive_json(timeout=60)
            if message.get("id") == serial:
                if "error" in message:
                    raise AssertionError(f"{method}: {message['error']}")
                return dict(message.get("result", {}))
            self._event(message)

    def _event(self, message: dict[str, Any]) -> None:
        if message.get("method") != "Network.webSocketFrameReceived":
            return
        frame = message["params"]["response"]
        data = frame["payloadData"]
        text = (base64.b64decode(data).decode("utf-8", "replace") if frame["opcode"] == 2
                else data)
        self.screen += ANSI.sub("", text)

    async def until(self, condition: Callable[[str], bool], what: str,
                    timeout: float = 60.0) -> None:
        """Wait until the terminal text received satisfies `condition`."""
        deadline = time.monotonic() + timeout
        while not condition(self.screen):
            left = deadline - time.monotonic()
            if left <= 0:
                if os.environ.get("MRSS_SCREENSHOT_DIR"):
                    Path(os.environ["MRSS_SCREENSHOT_DIR"], "screen.txt").write_text(self.screen)
                raise AssertionError(f"{what}: not on the page; its end: {self.screen[-600:]!r}")
            try:
                self._event(await self.ws.receive_json(timeout=min(left, 1.0)))
            except TimeoutError:
                continue

    async def type(self, text: str) -> None:
        await self.call("Input.insertText", text=text)

    async def enter(self) -> None:
        for kind in ("keyDown", "keyUp"):
            await self.call("Input.dispatchKeyEvent", type=kind, key="Enter", code="Enter",
                            windowsVirtualKeyCode=13, text="\r" if kind == "keyDown" else "")
