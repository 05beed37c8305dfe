"""The HTML report as a reader sees it: every table page opened in headless Chromium, its values found.

    snakemake --cores 2 && python benchmarks/report_in_browser.py

Builds ``results/report.html`` with ``snakemake --report``, opens it in the system's Chromium
(headless, driven over the DevTools protocol on a pipe), and for each page of rule ``report_pages``
clicks its category and its eye button as a user would, reads the text the browser rendered in the
report's frame, and looks there for the values of the first rows of the CSV the page names (as the
page formats them). Prints one line per page and exits 1 when a value is missing.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from hybridtwin.io.files import read_checked
from hybridtwin.report import pages

ROWS_CHECKED = 3


class Chromium:
    """A headless Chromium and the least of the DevTools protocol: commands over fds 3 and 4."""

    def __init__(self, executable: str):
        command_read, self._command_write = os.pipe()
        self._reply_read, reply_write = os.pipe()

        def on_fds_3_and_4():
            os.dup2(command_read, 3)
            os.dup2(reply_write, 4)

        self.process = subprocess.Popen(
            [executable, "--headless", "--no-sandbox", "--disable-gpu", "--remote-debugging-pipe", "about:blank"],
            preexec_fn=on_fds_3_and_4,
            pass_fds=(3, 4, command_read, reply_write),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        os.close(command_read)
        os.close(reply_write)
        self._buffer, self._id = b"", 0

    def send(self, method: str, session: str | None = None, **params) -> dict:
        self._id += 1
        message = {"id": self._id, "method": method, "params": params, **({"sessionId": session} if session else {})}
        os.write(self._command_write, json.dumps(message).encode() + b"\0")
        while True:
            while b"\0" not in self._buffer:
                chunk = os.read(self._reply_read, 1 << 16)
                if not chunk:
                    raise RuntimeError("Chromium closed the pipe")
                self._buffer += chunk
            raw, self._buffer = self._buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]

    def close(self) -> None:
        self.process.kill()
        self.process.wait()


class ReportTab:
    def __init__(self, browser: Chromium, report: Path):
        self.browser, self.url = browser, report.resolve().as_uri()
        target = browser.send("Target.createTarget", url="about:blank")["targetId"]
        self.session = browser.send("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]

    def evaluate(self, expression: str, context: int | None = None):
        extra = {"contextId": context} if context is not None else {}
        result = self.browser.send("Runtime.evaluate", self.session, expression=expression, returnByValue=True, **extra)
        return result["result"].get("value")

    def wait_for(self, expression: str, seconds: float = 20.0):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            value = self.evaluate(expression)
            if value:
                return value
            time.sleep(0.2)
        raise TimeoutError(expression)

    def first_page(self) -> str:
        """The text the report shows when it opens, before any click."""
        self.browser.send("Page.navigate", self.session, url=self.url)
        self.wait_for("document.readyState === 'complete' && typeof results === 'object'")
        return self.wait_for("document.body && document.body.innerText.includes('Gain') && document.body.innerText")

    def open_page(self, category: str, path: str) -> str:
        """Load the report, click the category and the result's eye button; the text of the frame shown."""
        self.browser.send("Page.navigate", self.session, url=self.url)
        self.wait_for("document.readyState === 'complete' && typeof results === 'object'")
        self.wait_for(
            f"(() => {{ const el = [...document.querySelectorAll('*')].reverse()"
            f".find(e => e.innerText && e.innerText.trim() === {json.dumps(category)}); "
            f"if (el) el.click(); return !!el }})()"
        )
        self.wait_for(
            f"(() => {{ const td = [...document.querySelectorAll('td')].find(e => e.innerText.trim() === "
            f"{json.dumps(path)}); if (td) td.closest('tr').querySelector('a[iconname=eye]').click(); return !!td }})()"
        )
        self.wait_for("document.querySelectorAll('iframe').length === 1")
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            frames = self.browser.send("Page.getFrameTree", self.session)["frameTree"].get("childFrames", [])
            if frames:
                context = self.browser.send("Page.createIsolatedWorld", self.session, frameId=frames[0]["frame"]["id"])
                text = self.evaluate("document.body ? document.body.innerText : ''", context["executionContextId"])
                if text:
                    return text
            time.sleep(0.2)
        raise TimeoutError(f"{path}: no frame text")


def report_pages(rules: Path) -> dict[str, str]:
    """page file name -> category, from workflow/rules/report.smk."""
    text = rules.read_text()
    return dict(re.findall(r'"(\w+)": \(\s*f"[^"]+",\s*"[^"]+",\s*"\w+",\s*"([^"]+)",?\s*\)', text))


def expected_values(source: str) -> list[str]:
    """What the page must show of its source: the first rows' cells as the page formats them."""
    if source.endswith(".md"):
        first = next(line for line in Path(source).read_text().splitlines() if line.startswith("On average"))
        return [re.sub(r"[*`]", "", first).split(" (")[0]]
    table = read_checked(source).head(ROWS_CHECKED)
    return [pages.cell(value) for row in table.itertuples(index=False) for value in row]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--chromium", default=shutil.which("chromium") or shutil.which("chromium-browser"))
    parser.add_argument("--report", default="results/report.html")
    args = parser.parse_args()
    if not args.chromium:
        sys.exit("no Chromium found: install the system's package (apt install chromium) or pass --chromium PATH")
    subprocess.run(["snakemake", "--report", args.report], check=True, capture_output=True)
    browser = Chromium(args.chromium)
    missing_any = False
    try:
        tab = ReportTab(browser, Path(args.report))
        results_dir = Path(args.report).parent
        opening = " ".join(tab.first_page().split())
        answer = [
            "Offset",
            "Cause",
            "Gain out of the support",
            "Validated domain",
            "Recommended model",
            "Next simulations",
        ]
        absent = [words for words in answer if words not in opening]
        missing_any |= bool(absent)
        print(f"first page, no click: {len(answer) - len(absent)}/{len(answer)} parts of the answer shown"
              + (f"; missing: {absent}" if absent else ""), flush=True)  # fmt: skip
        for page, category in report_pages(Path("workflow/rules/report.smk")).items():
            path = f"{results_dir}/report/{page}.html"
            start = time.perf_counter()
            rendered = tab.open_page(category, path)
            source = re.findall(r"Data: (\S+)", rendered)[-1]  # the note under the page names its file
            wanted = expected_values(source)
            flat = " ".join(rendered.split())
            missing = [value for value in wanted if " ".join(value.split()) not in flat]
            missing_any |= bool(missing)
            print(
                f"{page:22s} {category:24s} {len(wanted) - len(missing):3d}/{len(wanted)} values of {source} "
                f"found in the rendered report ({time.perf_counter() - start:.1f} s)"
                + (f"; missing: {missing[:3]}" if missing else ""),
                flush=True,
            )
        made = sorted(path.stem for path in (results_dir / "report").glob("*.html"))
        checked = sorted(report_pages(Path("workflow/rules/report.smk")))
        if made != checked:  # a page the list above missed is a page nobody checked
            print(f"pages written {made}, pages checked {checked}")
            missing_any = True
    finally:
        browser.close()
    return 1 if missing_any else 0


if __name__ == "__main__":
    sys.exit(main())
