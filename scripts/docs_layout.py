"""Measure the built documentation site in headless Chromium: code blocks that run past their column, page heights.

Usage::

    python -m mjflex docs --out out/docs && python scripts/docs_layout.py out/docs/html [--width 1400] [--json FILE]

Needs Chromium (Debian: ``apt-get install chromium``). Each page with code is loaded at a window of ``--width``
pixels (900 high) into a copy of the site, with a script that counts its code blocks (``div.highlight pre``), those
whose content is wider than the block (``scrollWidth > clientWidth``: a horizontal scroll bar), the copy buttons, and
the page's height. Prints a line per page with an overflowing block or taller than 20,000 px, then the totals;
exit status 1 if any block overflows.
"""

import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

PROBE = """<script>window.addEventListener('load', () => {
  const pres = [...document.querySelectorAll('div.highlight pre')];
  const over = pres.map((p, i) => [i, p.scrollWidth, p.clientWidth]).filter(([, s, c]) => s > c + 1);
  const report = {blocks: pres.length, over: over, copy: document.querySelectorAll('button.copybtn').length,
                  height: document.documentElement.scrollHeight};
  const d = document.createElement('div'); d.id = 'layout-report'; d.textContent = JSON.stringify(report);
  document.body.appendChild(d);
});</script></body>"""
REPORT = re.compile(r'<div id="layout-report">(.*?)</div>')


def measure(page, width, browser):
    """The probe's report of one page (dict), or None when the browser gave none."""
    out = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", f"--window-size={width},900",
                          "--virtual-time-budget=3000", "--dump-dom", "file://" + page],
                         capture_output=True, text=True, timeout=120).stdout  # fmt: skip
    m = REPORT.search(out)
    return json.loads(m.group(1).replace("&quot;", '"')) if m else None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("site", help="the built site (out/docs/html)")
    ap.add_argument("--width", type=int, default=1400)
    ap.add_argument("--json", help="write every page's report here")
    args = ap.parse_args(argv)
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if not browser:
        sys.exit("no Chromium on PATH (Debian: apt-get install chromium)")
    reports, blocks, over = {}, 0, 0
    with tempfile.TemporaryDirectory() as tmp:
        copy = os.path.join(tmp, "site")
        shutil.copytree(args.site, copy)
        for page in sorted(glob.glob(os.path.join(copy, "**", "*.html"), recursive=True)):
            rel = os.path.relpath(page, copy)
            with open(page, encoding="utf-8") as f:
                html = f.read()
            if rel.startswith(("_modules", "_sources")) or 'class="highlight' not in html:
                continue
            with open(page, "w", encoding="utf-8") as f:
                f.write(html.replace("</body>", PROBE, 1))
            r = reports[rel] = measure(page, args.width, browser)
            if r is None:
                print(f"{rel}: no report")
                continue
            blocks, over = blocks + r["blocks"], over + len(r["over"])
            if r["over"] or r["height"] > 20000:
                print(f"{rel}: {len(r['over'])} of {r['blocks']} code blocks overflow, {r['height']} px tall")
    print(f"{over} of {blocks} code blocks overflow at {args.width} px, on {len(reports)} pages with code")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"width": args.width, "blocks": blocks, "overflowing": over, "pages": reports}, f, indent=1)
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
