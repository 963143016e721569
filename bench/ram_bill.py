#!/usr/bin/env python3
"""`make ram-bill` (also run by `make bench`): the library's RAM bill per build.

Runs bench/ram_bill.c compiled once per build configuration (bench/bench.mk:
RAM_NAMES, RAM_DEFS_<name>), each on the largest bench frame its VT_MAX_* admits
(one fresh vt_pipeline_step, to show the capacities suffice), and writes the table
to stdout, bench/ram_bill.md and bench/ram_bill.json.

    python bench/ram_bill.py --workdir build/bench default vga ...
"""
from __future__ import annotations

import argparse
import json
import subprocess
from pathlib import Path

import cv2

HERE = Path(__file__).resolve().parent
FRAMES = ((1280, 720), (640, 480))

NOTES = {
    "default": "the defaults of include/vehtrack/config.h (frames up to 1920x1080)",
    "720p": "-DVT_MAX_WIDTH=1280 -DVT_MAX_HEIGHT=720",
    "vga": "-DVT_MAX_WIDTH=640 -DVT_MAX_HEIGHT=480",
    "vga-lean": "VGA, lane capacities cut to the 320x240 working frame the default lane config "
                "uses (VT_LANE_MAX_WORK_W/H=320/240, VT_LANE_ACC_CELLS=16384) and the Kalman "
                "filter to the tracker's 6-state, 3-measurement model (VT_KF_MAX_X/Z=6/3)",
    "vga-lean-8": "vga-lean with 8 track slots (VT_MAX_TRACKS=8)",
}


def write_pgm(path: Path, w: int, h: int) -> Path:
    img = cv2.imread(str(HERE / "data" / f"road_{w}x{h}.png"), cv2.IMREAD_GRAYSCALE)
    path.write_bytes(b"P5\n%d %d\n255\n" % (w, h) + img.tobytes())
    return path


def run(workdir: Path, name: str, frames: dict) -> dict:
    exe = workdir / f"ram_bill_{name}"
    first = subprocess.run([str(exe), name], capture_output=True, text=True, check=True).stdout
    kv = dict(t.split("=", 1) for t in first.split())
    mw, mh = int(kv["max_width"]), int(kv["max_height"])
    fit = next(((w, h) for w, h in FRAMES if w <= mw and h <= mh), None)
    if fit is not None:
        out = subprocess.run([str(exe), name, str(frames[fit])], capture_output=True, text=True,
                             check=True).stdout
        kv = dict(t.split("=", 1) for t in out.split())
    return {k: (int(v) if v.lstrip("-").isdigit() else v) for k, v in kv.items()}


def render(rows: list[dict]) -> str:
    kib = 1024
    lines = ["# RAM bill (`make ram-bill`)", "",
             "sizeof of the caller-owned structs on this host (x86-64; the Cortex-M figures of "
             "`make firmware-run` agree to within padding), in bytes. `vt_pipeline` is the whole "
             "state of the library; `vt_frame_out` is one frame's output. The last columns come "
             "from one fresh `vt_pipeline_step` on the largest bench frame the build admits "
             "(status 0 = VT_OK; lane status -3 would mean the lane capacities are too small "
             "for that frame).", "",
             "| build | max frame | tracks | vt_pipeline | KiB | lane state | tracker | detect "
             "scratch + result | camera (range) | vt_frame_out | edge ws (edges only) | classifier ws | "
             "flow state | ttc state | frame run | status / lane / boxes / tracks |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|"]
    for r in rows:
        frame = r.get("frame", "—")
        st = (f"{r['status']} / {r['lane_status']} / {r['boxes']} / {r['tracks']}"
              if "status" in r else "—")
        lines.append(
            f"| {r['build']} | {r['max_width']}x{r['max_height']} | {r['max_tracks']} | "
            f"{r['vt_pipeline']:,} | {r['vt_pipeline'] / kib:.1f} | {r['vt_lane_state']:,} | "
            f"{r['vt_tracker']:,} | {r['vt_detect_state'] + r['vt_detect_result']:,} | "
            f"{r['vt_range_state']:,} | {r['vt_frame_out']:,} | {r['vt_edge_ws']:,} | "
            f"{r['vt_pipe_cls_ws']:,} | {r['vt_flow_state']:,} | "
            f"{r['vt_ttc_state']:,} | {frame} | {st} |")
    lines += ["", "Builds:"] + [f"- {r['build']}: {NOTES.get(r['build'], '')}" for r in rows]
    lines += ["", "The tracker's edge-curve measurement (GIST paper, `measurement` = "
              "VT_MEAS_EDGE_CURVES) needs one `vt_edge_ws` more (the column \"edge ws\": 5 bytes per "
              "pixel of VT_EDGE_MAX_PIXELS), caller-owned and attached with "
              "`vt_pipeline_set_edge_ws` / `vt_tracker_set_edge_ws` only when that measurement is "
              "used; it is not in vt_pipeline. Each track keeps its edge template "
              f"(`vt_edge_template`, {rows[0]['vt_edge_template']:,} bytes) inside vt_track, so it "
              "is in the tracker column whichever measurement runs."]
    lines += ["", "With a classifier (VT_SRC_CLASSIFIER, or a model given to vt_pipeline_init) the "
              "whole-road detector needs one `vt_pipe_cls_ws` (column \"classifier ws\": its pyramid "
              "of the largest frame, window and candidate lists, the HOG band), attached with "
              "`vt_pipeline_set_cls_ws`; with VT_SRC_FLOW the overtaking stage needs one "
              "`vt_flow_state` (column \"flow state\": two level images and the cell tables), "
              "attached with `vt_pipeline_set_flow_ws`. Both are caller-owned and outside "
              "vt_pipeline; a firmware build sizes them with VT_MAX_WIDTH/HEIGHT (and "
              "VT_FULLDET_MAX_*, VT_FLOW_MAX_*, VT_CLS_MAX_*). The block-scale TTC after the "
              "tracker needs one `vt_ttc_state` (column \"ttc state\": VT_TTC_TRACKS slots of "
              "VT_TTC_HIST frames of VT_TTC_GRID^2 blocks of VT_TTC_BLOCK^2 bytes, and the pair "
              "scratch; independent of the frame size), attached with `vt_pipeline_set_ttc_ws`; "
              "a firmware build lowers VT_TTC_TRACKS (about 28 KB a slot at the defaults)."]
    lines += ["", "The camera stage's state (per-track range filters) is in vt_pipeline whether or "
              "not a camera is given.", "", "Stack: the high-water mark of one `vt_pipeline_step` is measured by stack "
              "painting in the firmware image (`make firmware-run`, line `stack step`)."]
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workdir", type=Path, required=True)
    ap.add_argument("--out", type=Path, default=HERE / "ram_bill")
    ap.add_argument("names", nargs="+")
    args = ap.parse_args()
    frames = {(w, h): write_pgm(args.workdir / f"ram_{w}x{h}.pgm", w, h) for w, h in FRAMES}
    rows = [run(args.workdir, n, frames) for n in args.names]
    text = render(rows)
    print(text, end="")
    args.out.with_suffix(".md").write_text(text)
    args.out.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
