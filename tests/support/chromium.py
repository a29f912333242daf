"""A headless Chromium client over the DevTools protocol, for tests of HTML reports.

:func:`load_in_chromium` starts ``chromium --headless --remote-debugging-pipe`` (commands on
the child's fd 3, replies on fd 4, NUL-separated JSON), loads a page and returns what the
page reports about its images together with every console error, exception and failed load.
"""

from __future__ import annotations

import json
import os
import select
import shlex
import shutil
import subprocess
import tempfile
import time

__all__ = ["load_in_chromium", "CHROMIUM_FLAGS"]

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run")


def load_in_chromium(url: str, *, timeout_s: float = 60.0) -> tuple[dict, list[dict]]:
    """Load a page in headless Chromium over the DevTools protocol (--remote-debugging-pipe:
    commands on the child's fd 3, replies on fd 4, NUL-separated JSON); return what the page
    reports about its images and every console error, exception and failed load.

    Returns
    -------
    tuple
        ``({"title", "tables", "images": [[complete, width, height], ...]}, [error events])``.
    """
    import fcntl

    binary = shutil.which("chromium")
    assert binary, "headless Chromium is needed: apt-get install -y chromium"
    to_child_r, to_child = os.pipe()
    from_child, from_child_w = os.pipe()
    # keep the child's ends clear of 3 and 4, which bash points the pipes at
    child_r = fcntl.fcntl(to_child_r, fcntl.F_DUPFD, 10)
    child_w = fcntl.fcntl(from_child_w, fcntl.F_DUPFD, 10)
    os.close(to_child_r)
    os.close(from_child_w)
    profile = tempfile.mkdtemp(prefix="chromium-profile-")
    argv = [binary, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "--remote-debugging-pipe", "about:blank"]
    shell = "exec " + " ".join(shlex.quote(a) for a in argv) + f" 3<&{child_r} 4>&{child_w} {child_r}<&- {child_w}>&-"
    proc = subprocess.Popen(["bash", "-c", shell], pass_fds=(child_r, child_w), stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    os.close(child_r)
    os.close(child_w)
    buffer, events, counter = b"", [], [0]

    def read_until(predicate, deadline):
        nonlocal buffer
        while True:
            while b"\0" in buffer:
                message, buffer = buffer.split(b"\0", 1)
                message = json.loads(message)
                if predicate(message):
                    return message
                events.append(message)
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("Chromium did not answer in time")
            ready, _, _ = select.select([from_child], [], [], left)
            if ready:
                chunk = os.read(from_child, 1 << 16)
                if not chunk:
                    raise RuntimeError("Chromium closed the DevTools pipe: " + proc.stderr.read().decode()[-2000:])
                buffer += chunk

    def call(method, params=None, session=None):
        counter[0] += 1
        message = {"id": counter[0], "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(to_child, json.dumps(message).encode() + b"\0")
        reply = read_until(lambda m, i=counter[0]: m.get("id") == i, time.monotonic() + timeout_s)
        assert "error" not in reply, f"{method}: {reply['error']}"
        return reply["result"]

    try:
        target = call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for method in ("Runtime.enable", "Log.enable", "Page.enable"):
            call(method, session=session)
        call("Page.navigate", {"url": url}, session=session)
        read_until(lambda m: m.get("method") == "Page.loadEventFired", time.monotonic() + timeout_s)
        probe = ("JSON.stringify({title: document.title, tables: document.querySelectorAll('table').length,"
                 " images: Array.from(document.images).map(i => [i.complete, i.naturalWidth, i.naturalHeight])})")
        page = json.loads(call("Runtime.evaluate", {"expression": probe, "returnByValue": True},
                               session=session)["result"]["value"])
        try:  # let late events arrive
            read_until(lambda m: False, time.monotonic() + 0.5)
        except TimeoutError:
            pass
        call("Browser.close")
    finally:
        os.close(to_child)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        os.close(from_child)
        shutil.rmtree(profile, ignore_errors=True)
    errors = [e for e in events
              if e.get("method") == "Runtime.exceptionThrown"
              or (e.get("method") == "Runtime.consoleAPICalled" and e["params"]["type"] in ("error", "assert"))
              or (e.get("method") == "Log.entryAdded" and e["params"]["entry"]["level"] == "error")]
    return page, errors
