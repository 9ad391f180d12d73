"""`mrss tui PROJECT --web` for real: a supervised project with users, the web console
as a process, and headless Chromium (DevTools protocol) that logs in as the commander,
sees the robots, sends "all robots hold" and sees the events manager's answer."""

from __future__ import annotations

import asyncio
import base64
import os
import subprocess
import sys
import urllib.request
from pathlib import Path

import aiohttp
import pytest

from mrss.ports import free_port
from mrss.testing import wait_until
from tests.auth.chromium import Browser, Page, chromium
from tests.auth.operators import PASSWORDS, project_with_users
from tests.faults.supervised import Supervised

pytestmark = pytest.mark.slow
SCREENSHOT = "web-console.png"


def wait_http(url: str, proc: subprocess.Popen[bytes], timeout: float = 60.0) -> None:
    def answers() -> bool:
        assert proc.poll() is None, "the web console ended"
        try:
            with urllib.request.urlopen(url, timeout=5) as reply:
                return reply.status == 200
        except OSError:
            return False
    wait_until(answers, timeout, interval=0.2, message=f"{url} answering")


def test_a_browser_logs_in_sees_the_robots_and_sends_a_command(tmp_path: Path) -> None:
    chromium()  # skip (or fail in CI) before starting anything
    projects = tmp_path / "projects"
    project_with_users(projects)
    run_dir = tmp_path / "run"
    system = Supervised("tuimission", run_dir, projects=projects)
    port = free_port()
    env = {**os.environ, "MRSS_PROJECTS": str(projects)}
    env.pop("MRSS_OPERATOR_TOKEN", None)
    log = (tmp_path / "web.log").open("wb")
    web = subprocess.Popen([sys.executable, "-m", "mrss", "tui", "tuimission", "--web",
                            "--port", str(port), "--run-dir", str(run_dir)],
                           env=env, stdout=log, stderr=subprocess.STDOUT)
    browser = Browser(tmp_path / "profile")
    try:
        system.wait_all_running()
        url = f"http://127.0.0.1:{port}/"
        wait_http(url, web)

        async def drive() -> bytes:
            async with aiohttp.ClientSession() as session, \
                    session.ws_connect(browser.page_socket(), max_msg_size=0) as ws:
                page = Page(ws)
                await page.call("Network.enable")
                await page.call("Page.enable")
                await page.call("Page.navigate", url=f"{url}?fontsize=10")
                await page.until(lambda s: "log in" in s, "the login screen")
                assert "ugv1" not in page.screen  # nothing of the system before a login
                await page.call("Runtime.evaluate", expression=(
                    "document.querySelector('.xterm-helper-textarea').focus()"))
                await page.type("cora")
                await page.until(lambda s: "cora" in s, "the user name typed")
                await page.enter()  # typed on before the focus moved, keys would go astray
                await page.until(lambda s: "the password or token of cora" in s,
                                 "the password asked for")
                await page.type("not-her-password")
                await page.enter()
                await page.until(lambda s: "wrong password or token for 'cora'" in s,
                                 "a wrong password refused")
                await page.type(PASSWORDS["cora"])  # the secret field has the cursor again
                await page.enter()
                await page.until(lambda s: "MRSS · cora (commander)" in s, "logged in as cora")
                await page.until(lambda s: "uav1" in s and "ugv1" in s, "the robots")
                await page.type("H")  # all robots hold: asks first
                await page.until(lambda s: "All robots hold?" in s, "the question")
                await page.type("y")
                await page.until(lambda s: "ops/hold accepted" in s,
                                 "the events manager's answer")
                shot = await page.call("Page.captureScreenshot", format="png")
                return base64.b64decode(shot["data"])

        png = asyncio.run(drive())
        assert png.startswith(b"\x89PNG")
        (tmp_path / SCREENSHOT).write_bytes(png)
        if os.environ.get("MRSS_SCREENSHOT_DIR"):
            (Path(os.environ["MRSS_SCREENSHOT_DIR"]) / SCREENSHOT).write_bytes(png)
    finally:
        browser.close()
        web.terminate()
        try:
            web.wait(timeout=30)
        except subprocess.TimeoutExpired:
            web.kill()
            web.wait(timeout=10)
        log.close()
        system.close()
