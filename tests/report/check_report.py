#!/usr/bin/python3
"""check_report.py REPORT.html [--screenshot PNG] [--warning TEXT ...]: the report as a
reader gets it (ctest "report: ...").

1. Valid HTML: html5lib's strict parser finds no error.
2. Self-contained: no src, href or url() that names anything but an in-page anchor or
   a data: URI; "http" appears only in SVG namespace declarations.
3. In headless Chromium (Debian's chromium and chromium-driver through
   python3-selenium): no console error, every image decoded with a non-zero size,
   every SVG drawn with a non-zero size, each frame slider changes the frame shown,
   each play button steps through the frames by itself, and the screenshot is not blank (its pixels vary).
4. Each --warning TEXT appears in the warnings list at the top.
Prints one line per failure and exits 1 if any."""
import argparse
import re
import sys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("report")
    ap.add_argument("--screenshot")
    ap.add_argument("--warning", action="append", default=[])
    a = ap.parse_args()
    fails = []
    text = open(a.report, encoding="utf-8").read()

    import html5lib
    parser = html5lib.HTMLParser(strict=False)
    parser.parse(text)
    for pos, code, data in parser.errors[:5]:
        fails.append(f"HTML: line {pos[0]} col {pos[1]}: {code} {data}")

    for m in re.finditer(r"""(?:src|href)\s*=\s*["']([^"']*)["']|url\(([^)]*)\)""", text):
        target = (m.group(1) or m.group(2) or "").strip("'\" ")
        if not (target.startswith("#") or target.startswith("data:")):
            fails.append(f"not self-contained: {m.group(0)[:80]}")
    for m in re.finditer(r"https?://", text):
        before = text[max(0, m.start() - 24):m.start()]
        if not re.search(r"xmlns(:\w+)?=[\"']$", before):
            fails.append(f"an http reference: ...{text[max(0, m.start() - 40):m.start() + 40]}...")
            break

    warnings = text.split("id='warnings'", 1)[1].split("<h2", 1)[0] if "id='warnings'" in text else ""
    for w in a.warning:
        if w not in warnings:
            fails.append(f"warning not at the top: {w}")

    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1200,1600"):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
    try:
        import os
        driver.get("file://" + os.path.abspath(a.report))
        driver.execute_script("return document.readyState")
        for entry in driver.get_log("browser"):
            if entry.get("level") == "SEVERE":
                fails.append(f"console: {entry.get('message', '')[:200]}")
        bad = driver.execute_script(
            "return Array.from(document.images).filter(i => !i.complete || i.naturalWidth === 0)"
            ".map(i => i.alt || i.src.slice(0, 40))")
        fails += [f"image not decoded: {b}" for b in bad]
        # Every image's and SVG's drawn size, the hidden frames under a slider shown first.
        driver.execute_script("document.querySelectorAll('.frames figure').forEach(f => f.style.display = 'block')")
        empty = driver.execute_script(
            "return Array.from(document.querySelectorAll('img, svg')).filter(e => {"
            " const r = e.getBoundingClientRect(); return r.width === 0 || r.height === 0; }).length")
        if empty:
            fails.append(f"{empty} images or SVGs drawn with zero size")
        driver.execute_script("document.querySelectorAll('.frames figure').forEach(f => f.style.display = '')")
        n_sliders = driver.execute_script("return document.querySelectorAll('input.slider').length")
        moved = driver.execute_script(
            "return Array.from(document.querySelectorAll('.frames')).map(box => {"
            " const s = box.querySelector('input.slider'); const figs = box.querySelectorAll('figure');"
            " if (figs.length < 2) return true;"
            " const shown = () => Array.from(figs).findIndex(f => getComputedStyle(f).display !== 'none');"
            " const before = shown(); s.value = String(figs.length - 1);"
            " s.dispatchEvent(new Event('input')); const after = shown();"
            " s.value = '0'; s.dispatchEvent(new Event('input'));"
            " return before === 0 && after === figs.length - 1; })")
        if not all(moved):
            fails.append(f"{moved.count(False)} of {len(moved)} frame sliders do not change the frame")
        # Each play button steps through the frames by itself (0.4 s per frame) and pauses.
        played = driver.execute_async_script(
            "const done = arguments[arguments.length - 1];"
            " const boxes = Array.from(document.querySelectorAll('.frames')).filter(b =>"
            "   b.querySelectorAll('figure').length > 1);"
            " boxes.forEach(b => b.querySelector('button.play').click());"
            " setTimeout(() => done(boxes.map(b => { const figs = Array.from(b.querySelectorAll('figure'));"
            "   b.querySelector('button.play').click();"
            "   return figs.findIndex(f => getComputedStyle(f).display !== 'none') > 0; })), 1000);")
        if not all(played):
            fails.append(f"{played.count(False)} of {len(played)} play buttons do not step the frames")
        png = driver.get_screenshot_as_png()
        import numpy as np
        import cv2
        img = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_GRAYSCALE)
        if img is None or float(img.std()) < 5:
            fails.append(f"blank screenshot (pixel std {0 if img is None else img.std():.1f})")
        if a.screenshot:
            with open(a.screenshot, "wb") as f:
                f.write(png)
    finally:
        driver.quit()
    for f in fails:
        print(f"check_report: {a.report}: {f}")
    if not fails:
        print(f"check_report: {a.report}: valid, self-contained, {n_sliders} frame sliders and play buttons work, "
              "no console error")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
