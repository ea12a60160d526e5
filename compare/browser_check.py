"""Open a report page in headless Chromium (Debian's `chromium`) and check
that it rendered: the summary table has rows and every image loaded.

    /usr/bin/python3 -m compare.browser_check DIR/report.html [--screenshot PNG]

The page's own script counts the images that loaded (data-images-loaded on
<body>); Chromium's --dump-dom prints the DOM after the load event, so the
count read back is what a person opening the page would see.
"""
from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
from pathlib import Path


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(name)
        if p:
            return p
    return None


def _run(args, timeout=120):
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout)


def check(page, screenshot=None):
    """Returns a dict: rows, images_loaded, images_total, screenshot; raises
    RuntimeError if the page did not render its table and every image."""
    exe = chromium()
    if exe is None:
        raise RuntimeError("chromium is not installed (apt-get install chromium)")
    url = Path(page).resolve().as_uri()
    common = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--allow-file-access-from-files",
              "--virtual-time-budget=10000", "--hide-scrollbars"]
    r = _run([*common, "--dump-dom", url])
    dom = r.stdout
    if r.returncode != 0 or "<body" not in dom:
        raise RuntimeError(f"chromium could not load {page}: {r.stderr.strip()[-500:]}")
    table = re.search(r"<table id=\"summary\">(.*?)</table>", dom, re.S)
    rows = len(re.findall(r"<tr class=", table.group(1))) if table else 0
    loaded = re.search(r'data-images-loaded="(\d+)"', dom)
    total = re.search(r'data-images-total="(\d+)"', dom)
    res = {"rows": rows, "images_loaded": int(loaded.group(1)) if loaded else None,
           "images_total": int(total.group(1)) if total else None, "screenshot": None}
    if screenshot:
        Path(screenshot).parent.mkdir(parents=True, exist_ok=True)
        s = _run([*common, f"--screenshot={Path(screenshot).resolve()}", "--window-size=1280,2400", url])
        if s.returncode == 0 and Path(screenshot).exists():
            res["screenshot"] = str(screenshot)
    problems = []
    if not table:
        problems.append("no summary table in the rendered page")
    elif rows == 0:
        problems.append("the summary table has no rows")
    if res["images_total"] is None:
        problems.append("the page's load script did not run")
    elif res["images_total"] == 0:
        problems.append("the page has no images")
    elif res["images_loaded"] != res["images_total"]:
        problems.append(f"{res['images_total'] - res['images_loaded']} of {res['images_total']} images did not load")
    if screenshot and res["screenshot"] is None:
        problems.append("no screenshot written")
    if problems:
        raise RuntimeError(f"{page}: " + "; ".join(problems))
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(prog="compare.browser_check", description=__doc__.splitlines()[0])
    ap.add_argument("page")
    ap.add_argument("--screenshot", default=None)
    a = ap.parse_args(argv)
    try:
        res = check(a.page, a.screenshot)
    except (RuntimeError, OSError, subprocess.TimeoutExpired) as e:
        print(f"browser_check: error: {e}", file=sys.stderr)
        return 1
    print(f"{a.page}: rendered, {res['rows']} summary rows, {res['images_loaded']}/{res['images_total']} images"
          + (f", screenshot {res['screenshot']}" if res["screenshot"] else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
