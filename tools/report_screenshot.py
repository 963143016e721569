#!/usr/bin/env python3
"""Make docs/report_screenshot.png: `pyvehtrack report` on the shipped KITTI clip (its camera
and range truth found by name, plus the lead-car boxes; KITTI's --rear-offset 1.8, as the
README's main job), rendered by headless chromium with
the network cut, trimmed, scaled to 60% and reduced to 256 colours (< 300 KB).

    PYTHONPATH=. python3 tools/report_screenshot.py [--out docs/report_screenshot.png]"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "report_screenshot.png"))
    ap.add_argument("--scale", type=float, default=0.6)
    a = ap.parse_args()
    import numpy as np
    from PIL import Image

    from pyvehtrack.cli import main as cli
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        raise SystemExit("chromium is not installed")
    clip = ROOT / "tests" / "data" / "kitti_clip"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        os.chdir(ROOT)                  # relative paths on the page
        rel = clip.relative_to(ROOT)
        if cli(["report", str(rel), "--out", str(tmp / "r"), "--truth", str(rel / "lead_boxes.csv"),
                "--truth", str(rel / "truth_lidar_range.csv"), "--rear-offset", "1.8", "--no-progress"]) != 0:
            raise SystemExit("report failed")
        env = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "ASAN_OPTIONS")}
        shot = tmp / "full.png"
        subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                        "--disable-component-update", "--disable-sync", "--no-first-run",
                        f"--user-data-dir={tmp / 'profile'}", "--proxy-server=127.0.0.1:9", "--hide-scrollbars",
                        f"--screenshot={shot}", "--window-size=1200,4000", (tmp / "r" / "index.html").as_uri()],
                       env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=180, check=True)
        im = Image.open(shot).convert("RGB")
        rows = np.where((np.asarray(im) < 250).any(axis=(1, 2)))[0]
        im = im.crop((0, 0, im.width, int(rows.max()) + 16))
        im = im.resize((round(im.width * a.scale), round(im.height * a.scale)), Image.LANCZOS)
        im = im.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        Path(a.out).parent.mkdir(parents=True, exist_ok=True)
        im.save(a.out, optimize=True)
    print(f"{a.out}: {im.width}x{im.height}, {Path(a.out).stat().st_size // 1024} KB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
