"""Check a report in a headless Chromium (Debian's ``/usr/bin/chromium``), offline.

Used by the tests: :func:`check_html` copies the report, appends a small probe script that records
console errors, uncaught errors and every ``<img>``'s ``naturalWidth`` into the DOM once the page
has loaded, runs ``chromium --headless --dump-dom`` on it with networking disabled, and parses
the probe result. :func:`screenshot` saves a PNG of the (unmodified) report. Nothing is downloaded.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

#: Flags for a quiet, offline, sandbox-free headless run (CI containers run as root).
CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-default-apps",
    "--disable-extensions",
    "--mute-audio",
    "--hide-scrollbars",
)

_PROBE = """
<script id="usvid-probe">
(function () {
  var errors = [];
  var origError = console.error;
  console.error = function () {
    errors.push(Array.prototype.join.call(arguments, " "));
    origError.apply(console, arguments);
  };
  window.addEventListener("error", function (e) {
    errors.push("uncaught: " + (e.message || (e.target && e.target.tagName) || "error"));
  }, true);
  window.addEventListener("load", function () {
    var imgs = Array.prototype.map.call(document.images, function (im) {
      return {alt: im.alt, complete: im.complete, w: im.naturalWidth, h: im.naturalHeight};
    });
    var pre = document.createElement("pre");
    pre.id = "usvid-probe-result";
    pre.textContent = "USVID_" + "PROBE" + JSON.stringify({errors: errors, images: imgs}) +
      "END_" + "PROBE";
    document.body.appendChild(pre);
  });
})();
</script>
"""


@dataclass
class BrowserCheck:
    """What Chromium saw: console/uncaught ``errors``, one dict per ``<img>`` (``alt``, ``w``,
    ``h`` natural size [px]), and Chromium's own stderr console lines."""

    errors: list[str] = field(default_factory=list)
    images: list[dict] = field(default_factory=list)
    console: list[str] = field(default_factory=list)

    @property
    def broken_images(self) -> list[dict]:
        return [im for im in self.images if not im.get("w") or not im.get("h")]


def find_chromium() -> str | None:
    """Path of a Chromium binary (``$USVID_CHROMIUM``, ``/usr/bin/chromium``, PATH), or None."""
    for cand in (os.environ.get("USVID_CHROMIUM"), "/usr/bin/chromium"):
        if cand and Path(cand).is_file() and os.access(cand, os.X_OK):
            return cand
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


def _run(args: list[str], timeout: float) -> subprocess.CompletedProcess:
    chrome = find_chromium()
    if chrome is None:
        raise FileNotFoundError("no chromium binary found (install Debian's `chromium`)")
    with tempfile.TemporaryDirectory(prefix="usvid-chromium-") as profile:
        cmd = [chrome, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args]
        env = {**os.environ, "HOME": profile}
        return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env,
                              check=False)


def check_html(path: str | Path, timeout: float = 60.0) -> BrowserCheck:
    """Load ``path`` in headless Chromium and report console errors and image sizes.

    The report itself is not modified: a probed copy is written to a temporary folder.
    Raises ``FileNotFoundError`` without Chromium and ``RuntimeError`` if no probe result came
    back (the page did not load).
    """
    text = Path(path).read_text(encoding="utf-8")
    probed = text.replace("<head>", "<head>" + _PROBE, 1)
    with tempfile.TemporaryDirectory(prefix="usvid-probe-") as tmp:
        page = Path(tmp) / "probe.html"
        page.write_text(probed, encoding="utf-8")
        proc = _run(["--enable-logging=stderr", "--v=0", "--virtual-time-budget=10000",
                     "--dump-dom", page.as_uri()], timeout)
    m = re.search(r"USVID_PROBE(.*?)END_PROBE", proc.stdout, re.S)
    if not m:
        raise RuntimeError(f"chromium returned no probe result (rc={proc.returncode}): "
                           f"{proc.stderr[-800:]}")
    import html as _html

    data = json.loads(_html.unescape(m.group(1)))
    console = [ln for ln in proc.stderr.splitlines() if "CONSOLE" in ln or ":ERROR:CONSOLE" in ln]
    return BrowserCheck(errors=list(data.get("errors", [])), images=list(data.get("images", [])),
                        console=console)


def screenshot(path: str | Path, out_png: str | Path, width: int = 1200, height: int = 3000,
               timeout: float = 60.0) -> Path:
    """Save a PNG screenshot of the report ``path`` to ``out_png``; returns ``out_png``."""
    out_png = Path(out_png).resolve()
    out_png.parent.mkdir(parents=True, exist_ok=True)
    proc = _run([f"--window-size={width},{height}", f"--screenshot={out_png}",
                 Path(path).resolve().as_uri()], timeout)
    if not out_png.is_file():
        raise RuntimeError(f"chromium wrote no screenshot (rc={proc.returncode}): "
                           f"{proc.stderr[-800:]}")
    return out_png


def print_pdf(path: str | Path, out_pdf: str | Path, timeout: float = 60.0) -> Path:
    """Print the report ``path`` to ``out_pdf`` with Chromium's print engine (the print CSS);
    returns ``out_pdf``."""
    out_pdf = Path(out_pdf).resolve()
    out_pdf.parent.mkdir(parents=True, exist_ok=True)
    proc = _run(["--no-pdf-header-footer", f"--print-to-pdf={out_pdf}",
                 Path(path).resolve().as_uri()], timeout)
    if not out_pdf.is_file():
        raise RuntimeError(f"chromium wrote no PDF (rc={proc.returncode}): {proc.stderr[-800:]}")
    return out_pdf
