"""The report page: one self-contained HTML file (frames as inline base64 JPEG, plots as
inline base64 PNG made with matplotlib's Agg backend, CSS in the page, no script, no
external resource), from the per-frame records and FrameInfo of records.py.

Every plot section draws only what the records hold; a section without data says why on
the page instead of showing an empty axis."""
from __future__ import annotations

import base64
import datetime as _dt
import html
import io
import math
from pathlib import Path

import numpy as np

from .records import STAGES, Truth

STATE_COLOURS = {"tentative": "#b0b0b0", "confirmed": "#2a9d3a", "coasting": "#e08a00",
                 "handover": "#3a6fd8"}
# BGR for OpenCV drawing, hex for the legend: one colour per box source (the pipeline's
# names), and the raw detector boxes of detection frames.
SOURCE_COLOURS = {"shadow": ((60, 200, 40), "#28c83c"), "classifier": ((255, 160, 0), "#00a0ff"),
                  "flow": ((0, 140, 255), "#ff8c00"), "model": ((255, 255, 0), "#00ffff"),
                  "ego": ((0, 0, 230), "#e60000"), "other": ((200, 200, 200), "#c8c8c8")}
DETECTOR_BOX = ((200, 0, 220), "#dc00c8")
STAGE_COLOURS = {"lanes": "#4c72b0", "detect": "#dd8452", "track": "#55a868", "geometry": "#8172b3"}
MAX_THUMBS = 12
# "Every track, once": one cut-out per track id, the longest MAX_TRACK_TILES when there are more.
MAX_TRACK_TILES = 48
TRACK_TILE = (200, 150)   # w, h of a tile


# ====================================================================== helpers
def _png_data_uri(fig) -> str:
    import matplotlib.pyplot as plt
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _jpeg_bytes(img, quality: int = 82) -> bytes:
    import cv2
    ok, enc = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise RuntimeError("cannot encode a contact-sheet frame as JPEG")
    return enc.tobytes()


def _jpeg_bytes_uri(data: bytes) -> str:
    return "data:image/jpeg;base64," + base64.b64encode(data).decode("ascii")


def _jpeg_data_uri(img, quality: int = 82) -> str:
    return _jpeg_bytes_uri(_jpeg_bytes(img, quality))


def _fig(h_in: float = 3.2, w_in: float = 11.0, nrows: int = 1, sharex: bool = True):
    import matplotlib
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(nrows, 1, figsize=(w_in, h_in), sharex=sharex, squeeze=False,
                           constrained_layout=True)
    from matplotlib.ticker import MaxNLocator
    for a in ax[:, 0]:
        a.xaxis.set_major_locator(MaxNLocator(integer=True))
        a.grid(True, alpha=0.3)
        a.spines[["top", "right"]].set_visible(False)
    return fig, ax[:, 0]


def _note(text: str) -> str:
    return f'<p class="note">{html.escape(text)}</p>'


def _img(uri: str, alt: str) -> str:
    return f'<img class="plot" src="{uri}" alt="{html.escape(alt)}">'


def _table(head, rows) -> str:
    h = "".join(f"<th>{html.escape(str(c))}</th>" for c in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


def _ids(records) -> list:
    return sorted({t["id"] for r in records for t in r["tracks"]})


def _series(records, key):
    """{id: (frames, values)} of a numeric track field, frames where it is not null."""
    out: dict = {}
    for r in records:
        for t in r["tracks"]:
            v = t.get(key)
            if v is not None and isinstance(v, (int, float)) and math.isfinite(v):
                out.setdefault(t["id"], ([], []))
                out[t["id"]][0].append(r["frame"])
                out[t["id"]][1].append(float(v))
    return out


def _gapped(frames, values):
    """The series with NaN between non-consecutive frames, so a line is not drawn across
    frames where the value is unknown."""
    fx, vy = [], []
    for k, (f, v) in enumerate(zip(frames, values)):
        if k and f != frames[k - 1] + 1:
            fx.append(f - 0.5)
            vy.append(float("nan"))
        fx.append(f)
        vy.append(v)
    return fx, vy


def _id_hex(track_id: int) -> str:
    import colorsys
    r, g, b = colorsys.hsv_to_rgb((track_id * 0.6180339887) % 1.0, 0.8, 0.85)
    return "#%02x%02x%02x" % (int(r * 255), int(g * 255), int(b * 255))


# ====================================================================== frames
def annotate(frame, record: dict, info) -> np.ndarray:
    """A BGR copy of the frame with the road area (translucent yellow), lanes (ego lines
    thick; left blue, right red), detector boxes (thin magenta) and tracks (coloured by
    source, dashed when coasting, thin when tentative, '#id' labels, a '*' when a detector
    box confirmed the track on this frame)."""
    import cv2
    img = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if frame.ndim == 2 else frame[:, :, :3].copy()
    img = np.ascontiguousarray(img)
    th = max(1, round(max(img.shape[:2]) / 500))
    if info is not None and info.road is not None and len(info.road) >= 3:
        poly = np.asarray(info.road, np.int32)
        over = img.copy()
        cv2.fillPoly(over, [poly], (0, 200, 255))
        img = cv2.addWeighted(over, 0.22, img, 0.78, 0)
        cv2.polylines(img, [poly], True, (0, 200, 255), 1, cv2.LINE_AA)
    for side, pts in (info.lanes if info is not None else []):
        col = (255, 90, 0) if side.startswith("left") else (0, 0, 255)
        ego = side in ("left", "right")
        cv2.polylines(img, [np.asarray(pts, np.int32)], False, col, (2 if ego else 1) * th, cv2.LINE_AA)
    if info is not None and info.detections is not None:
        for l, t, r, b in info.detections:
            cv2.rectangle(img, (int(l), int(t)), (int(r), int(b)), DETECTOR_BOX[0], 1)
    for t in record["tracks"]:
        l, tp, r, b = (int(v) for v in t["box"])
        col = SOURCE_COLOURS.get(t.get("source") or "other", SOURCE_COLOURS["other"])[0]
        thick = 1 if t["state"] == "tentative" else 2 * th
        if t["state"] == "coasting":   # dashed: every other 6 px segment
            for x in range(l, r, 12):
                cv2.line(img, (x, tp), (min(x + 6, r), tp), col, thick)
                cv2.line(img, (x, b), (min(x + 6, r), b), col, thick)
            for y in range(tp, b, 12):
                cv2.line(img, (l, y), (l, min(y + 6, b)), col, thick)
                cv2.line(img, (r, y), (r, min(y + 6, b)), col, thick)
        else:
            cv2.rectangle(img, (l, tp), (r, b), col, thick, cv2.LINE_AA)
        label = f"#{t['id']}" + ("*" if info is not None and t["id"] in info.matched else "")
        if t.get("distance_m") is not None:
            label += f" {t['distance_m']:.1f}m"
        if t.get("warning"):
            label += " !"
        scale = 0.5 * th
        (tw, tht), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
        ty = tp - 4 if tp - tht - 6 >= 0 else tp + tht + 4
        cv2.rectangle(img, (l, ty - tht - 3), (l + tw + 4, ty + 3), (0, 0, 0), -1)
        cv2.putText(img, label, (l + 2, ty), cv2.FONT_HERSHEY_SIMPLEX, scale, col, 1, cv2.LINE_AA)
    return img


def pick_thumbs(n: int, k: int = MAX_THUMBS) -> list:
    """Up to k frame indices spread evenly over 0..n-1, first and last included."""
    if n <= 0:
        return []
    if n <= k:
        return list(range(n))
    return sorted({int(round(i * (n - 1) / (k - 1))) for i in range(k)})


def thumbnail(img, width: int = 400):
    import cv2
    h, w = img.shape[:2]
    if w <= width:
        return img
    return cv2.resize(img, (width, max(1, round(h * width / w))), interpolation=cv2.INTER_AREA)


class TrackTiles:
    """One cut-out per track id for the page's "Every track, once" section, kept while the
    frames stream by (the recording is not held): a track's tile is cut on its 1st, 2nd, 4th,
    8th, ... frame, and the page shows the one nearest the middle of its life, where the track
    had settled rather than on its first, least certain frame. The middle only moves on, so a
    cut with a later one at or before the middle can never be picked again and is dropped:
    at most two cuts per id are held, each as JPEG bytes (a few KB), so an hour's recording
    with thousands of ids stays within tens of MB."""

    def __init__(self):
        self.count: dict[int, int] = {}
        self.cuts: dict[int, list] = {}

    def add(self, frame, record: dict) -> None:
        for t in record["tracks"]:
            tid = int(t["id"])
            n = self.count.get(tid, 0) + 1
            self.count[tid] = n
            cuts = self.cuts.setdefault(tid, [])
            if n & (n - 1) == 0:
                cuts.append((n, _jpeg_bytes(track_tile(frame, t["box"]))))
            mid = (n + 1) / 2
            last = max((c for c, _ in cuts if c <= mid), default=None)
            if last is not None:
                cuts[:] = [x for x in cuts if x[0] >= last]

    def pick(self) -> dict:
        """id -> the JPEG bytes of the tile cut nearest the middle of the track's frames."""
        return {tid: min(cuts, key=lambda c: abs(c[0] - (self.count[tid] + 1) / 2))[1]
                for tid, cuts in self.cuts.items() if cuts}


def track_tile(frame, box) -> np.ndarray:
    """The box with a margin of its own size on each side (clipped to the frame), the box
    drawn in red, resized to TRACK_TILE (BGR)."""
    import cv2
    img = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if frame.ndim == 2 else frame[:, :, :3]
    fh, fw = img.shape[:2]
    l, t, r, b = (int(round(float(v))) for v in box)
    m = max(r - l, b - t, 4)
    x0, y0, x1, y1 = max(0, l - m), max(0, t - m), min(fw, r + m), min(fh, b + m)
    if x1 <= x0 or y1 <= y0:            # a box wholly outside the frame: an empty tile
        return np.zeros((TRACK_TILE[1], TRACK_TILE[0], 3), np.uint8)
    cut = np.ascontiguousarray(img[y0:y1, x0:x1])
    sx, sy = TRACK_TILE[0] / (x1 - x0), TRACK_TILE[1] / (y1 - y0)
    cut = cv2.resize(cut, TRACK_TILE, interpolation=cv2.INTER_AREA if sx < 1 else cv2.INTER_LINEAR)
    cv2.rectangle(cut, (int((l - x0) * sx), int((t - y0) * sy)), (int((r - x0) * sx), int((b - y0) * sy)),
                  (0, 0, 255), 1)
    return cut


def track_gallery(records, tiles: dict) -> str:
    """The "Every track, once" section's HTML: a tile per id (JPEG bytes, TrackTiles.pick; caption:
    id, frames, states, source)."""
    life: dict[int, dict] = {}
    for r in records:
        for t in r["tracks"]:
            d = life.setdefault(int(t["id"]), {"first": r["frame"], "n": 0, "states": set(), "sources": set()})
            d["last"] = r["frame"]
            d["n"] += 1
            d["states"].add(t["state"])
            d["sources"].add(t.get("source") or "other")
    ids = sorted((i for i in life if i in tiles), key=lambda i: (-life[i]["n"], i))
    shown = sorted(ids[:MAX_TRACK_TILES])
    figs = "".join(
        f'<figure><img src="{_jpeg_bytes_uri(tiles[i])}" alt="track {i}"><figcaption>'
        f'#{i}: frames {life[i]["first"]}-{life[i]["last"]} ({life[i]["n"]}), '
        f'{"confirmed" if "confirmed" in life[i]["states"] else "never confirmed"}, '
        f'{html.escape("/".join(sorted(life[i]["sources"])))}</figcaption></figure>' for i in shown)
    head = ("Each track id once, cut out at the middle of its life with its box in red: a quick way to see that "
            "every track is on a vehicle.")
    if len(ids) > len(shown):
        head += f" The {len(shown)} longest of {len(ids)} tracks are shown."
    return _note(head) + f'<div class="tracks">{figs}</div>'


# ====================================================================== plots
def plot_timeline(records):
    ids = _ids(records)
    if not ids:
        return None, "No track was started in this recording: nothing to draw on the timeline."
    from matplotlib.patches import Patch
    fig, (ax,) = _fig(h_in=min(1.2 + 0.28 * len(ids), 8.0))
    row = {tid: k for k, tid in enumerate(ids)}
    runs: dict = {}
    for r in records:
        for t in r["tracks"]:
            runs.setdefault((t["id"], t["state"]), []).append(r["frame"])
    for (tid, state), frames in runs.items():
        frames = sorted(frames)
        spans, start, prev = [], frames[0], frames[0]
        for f in frames[1:] + [None]:
            if f is None or f != prev + 1:
                spans.append((start - 0.5, prev - start + 1))
                start = f
            if f is not None:
                prev = f
        ax.broken_barh(spans, (row[tid] - 0.38, 0.76), facecolors=STATE_COLOURS.get(state, "#888"))
    ax.set_yticks(range(len(ids)))
    ax.set_yticklabels([f"#{i}" for i in ids], fontsize=8 if len(ids) > 15 else 10)
    ax.set_ylim(-0.7, len(ids) - 0.3)
    ax.invert_yaxis()
    ax.set_xlim(-0.5, max(r["frame"] for r in records) + 0.5)
    ax.set_xlabel("frame")
    ax.set_ylabel("track id")
    ax.legend(handles=[Patch(color=c, label=s) for s, c in STATE_COLOURS.items()], loc="upper left",
              bbox_to_anchor=(1.0, 1.0), frameon=False)
    return _png_data_uri(fig), None


def _shade_warnings(ax, records, tid=None):
    """Shade the frames where a track (any track when tid is None) warns."""
    on = sorted({r["frame"] for r in records for t in r["tracks"]
                 if t.get("warning") and (tid is None or t["id"] == tid)})
    if not on:
        return False
    start = prev = on[0]
    for f in on[1:] + [None]:
        if f is None or f != prev + 1:
            ax.axvspan(start - 0.5, prev + 0.5, color="#e63946", alpha=0.15, lw=0)
            start = f
        if f is not None:
            prev = f
    return True


TTC_AXIS_MAX_S = 30.0   # a warning acts below a few seconds: longer TTCs are drawn off the axis


def _axis_limit(ax, series: dict, ymax: float, unit: str) -> None:
    """y from 0 to ymax; the curves that go above it are named on the axes with their
    maximum (so nothing leaves the plot unsaid)."""
    ax.set_ylim(0, ymax)
    over = [f"{lab} up to {max(v):.0f} {unit}" for lab, v in series.items() if v and max(v) > ymax]
    if over:
        ax.text(0.99, 0.97, "above the axis: " + ", ".join(over), transform=ax.transAxes, ha="right",
                va="top", fontsize=8, color="#555")


def plot_range_ttc(records, truth: Truth, lead_of_frame: dict, stage_notes=()):
    """Distance and TTC over time per track (estimates), with the truth overlaid on the
    lead car's track and the warning intervals shaded. The TTC drawn is the fused one
    (ttc_fused_s: what `track` draws) where the records have it, with the distance/rate TTC
    (ttc_s: what the warning follows by default) dotted beside it; else the distance/rate
    TTC alone.
    Returns (uri or None, notes)."""
    dist, rate = _series(records, "distance_m"), _series(records, "ttc_s")
    fused = _series(records, "ttc_fused_s")
    ttc = fused or rate
    t_ttc = truth.ttc() if truth.ranges else {}
    notes = []
    if not dist and not ttc:
        notes += list(stage_notes) or ["No distance or TTC estimate in these records."]
    if not truth.ranges:
        notes.append("No range truth given (--truth with a lidar range CSV overlays it here).")
    if not dist and not ttc and not truth.ranges:
        return None, notes
    ids = sorted(set(dist) | set(ttc), key=lambda i: -len(dist.get(i, ([], []))[0]))[:8]
    fig, (a1, a2) = _fig(h_in=5.6, nrows=2)
    for tid in ids:
        c = _id_hex(tid)
        if tid in dist:
            a1.plot(*_gapped(*dist[tid]), "-", color=c, lw=1.6, label=f"#{tid}")
        if tid in ttc:
            a2.plot(*_gapped(*ttc[tid]), "-", color=c, lw=1.6, label=f"#{tid}")
        if fused and tid in rate:
            a2.plot(*_gapped(*rate[tid]), ":", color=c, lw=1.0)
    if truth.ranges:
        f = sorted(truth.ranges)
        a1.plot(*_gapped(f, [truth.ranges[k] for k in f]), "--", color="black", lw=1.3,
                label="truth (lidar, lead car)")
        tf = [k for k in sorted(t_ttc) if t_ttc[k] is not None and t_ttc[k] > 0]
        if tf:
            a2.plot(*_gapped(tf, [t_ttc[k] for k in tf]), "--", color="black", lw=1.3,
                    label="truth (lidar, lead car)")
    # axes sized for the lead car (truth and the lead's track), not for a far, short-lived track
    dvals = {f"#{i}": dist[i][1] for i in ids if i in dist}
    tvals = {f"#{i}": ttc[i][1] for i in ids if i in ttc}
    if truth.ranges:
        dvals["truth"] = list(truth.ranges.values())
        tvals["truth"] = [v for v in t_ttc.values() if v is not None]
    lead = set(lead_of_frame.values())
    core = [v for lab, vs in dvals.items() if lab == "truth" or int(lab[1:]) in lead for v in vs]
    core = core or [v for vs in dvals.values() for v in vs]
    if core:
        _axis_limit(a1, dvals, max(5.0, 1.25 * float(np.percentile(core, 95))), "m")
    allt = [v for vs in tvals.values() for v in vs]
    if allt:
        _axis_limit(a2, tvals, min(TTC_AXIS_MAX_S, max(5.0, 1.1 * max(allt))), "s")
    warned = _shade_warnings(a1, records) | _shade_warnings(a2, records)
    a1.set_ylabel("distance (m)")
    a2.set_ylabel("TTC (s)")
    if fused:
        a2.text(0.01, 0.97, "solid: fused TTC (as `track` draws it); dotted: distance/rate TTC (the warning's)",
                transform=a2.transAxes, ha="left", va="top", fontsize=8, color="#555")
    a2.set_xlabel("frame")
    if not dist:
        a1.text(0.5, 0.92, "no distance estimate (see the note above)", transform=a1.transAxes,
                ha="center", color="#a00", fontsize=10)
    if not ttc:
        a2.text(0.5, 0.92, "no TTC estimate (see the note above)", transform=a2.transAxes,
                ha="center", color="#a00", fontsize=10)
    for a in (a1, a2):
        if a.get_legend_handles_labels()[0]:
            a.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False, fontsize=9)
    n = max([r["frame"] for r in records] + [0])
    a1.set_xlim(-0.5, n + 0.5)
    if not warned:
        notes.append("No forward-collision warning in these records (shaded red where a track warns).")
    return _png_data_uri(fig), notes


def plot_lane_pitch(infos, pitch_source: str = ""):
    lw = [(i.frame, i.lane_width_px) for i in infos if i.lane_width_px is not None]
    vr = [(i.frame, i.vanishing_row) for i in infos if i.vanishing_row is not None]
    pitch = [(i.frame, i.pitch_deg) for i in infos if i.pitch_deg is not None]
    notes = []
    if not lw:
        notes.append("The lane stage found no ego lane pair in any frame: no lane width to plot.")
    if not pitch:
        notes.append("No pitch estimate: it needs the camera (--camera with fy and cy, or the geometry "
                     "stage); the vanishing row of the ego lines is plotted instead" if vr else
                     "No pitch estimate and no vanishing row (no ego lane pair found).")
    if not lw and not vr:
        return None, notes
    n = max(i.frame for i in infos)
    if not vr and not pitch:
        fig, (a1,) = _fig(h_in=2.6)
        a2 = None
    else:
        fig, (a1, a2) = _fig(h_in=4.6, nrows=2)
    if lw:
        a1.plot(*zip(*lw), ".-", color="#4c72b0", lw=1.2, ms=3)
        rows = sorted({i.lane_width_row for i in infos if i.lane_width_row is not None})
        a1.set_ylabel("ego lane width (px)")
        a1.set_title(f"at the road area's bottom row (row {rows[0]}" + (f"..{rows[-1]}" if len(rows) > 1 else "")
                     + ")", fontsize=9, loc="left")
    else:
        a1.text(0.5, 0.5, "no ego lane pair found", transform=a1.transAxes, ha="center", color="#a00")
    if a2 is None:
        a1.set_xlabel("frame")
    elif pitch:
        a2.plot(*zip(*pitch), ".-", color="#8172b3", lw=1.2, ms=3)
        a2.set_ylabel("pitch (deg, + = down)")
        a2.set_title(pitch_source, fontsize=9, loc="left")
    elif vr:
        a2.plot(*zip(*vr), ".-", color="#8172b3", lw=1.2, ms=3)
        a2.set_ylabel("vanishing row (px)")
        a2.invert_yaxis()
        a2.set_title("where straight fits to the two ego lines meet (up = nose down)", fontsize=9, loc="left")
    if a2 is not None:
        a2.set_xlabel("frame")
    a1.set_xlim(-0.5, n + 0.5)
    return _png_data_uri(fig), notes


def plot_runtime(infos):
    if not infos or not any(i.timing_ms for i in infos):
        return None, ["No per-stage timings recorded."]
    fig, (ax,) = _fig(h_in=3.2)
    frames = np.array([i.frame for i in infos])
    bottom = np.zeros(len(infos))
    for s in STAGES:
        v = np.array([i.timing_ms.get(s, 0.0) for i in infos])
        if v.any():
            ax.bar(frames, v, bottom=bottom, width=0.9, color=STAGE_COLOURS[s], label=s, lw=0)
            bottom += v
    ax.set_xlabel("frame")
    ax.set_ylabel("ms (Python wall time)")
    ax.set_xlim(-0.6, frames.max() + 0.6)
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    return _png_data_uri(fig), []


def runtime_table(infos):
    rows = []
    for s in STAGES + ("total",):
        if s == "total":
            v = np.array([sum(i.timing_ms.values()) for i in infos])
        else:
            v = np.array([i.timing_ms[s] for i in infos if s in i.timing_ms])
        if len(v):
            rows.append((s, len(v), f"{np.mean(v):.2f}", f"{np.median(v):.2f}",
                         f"{np.percentile(v, 95):.2f}", f"{np.max(v):.2f}"))
    return _table(("stage", "frames run", "mean ms", "median ms", "p95 ms", "max ms"), rows)


# ====================================================================== figures
def lead_ids(records, truth: Truth, widths: dict | None = None) -> dict:
    """frame -> the lead car's track id: the track overlapping the truth box most (IoU >=
    0.5) when truth boxes are given; else the confirmed/coasting track with a distance
    whose box spans the image's centre column (widths: frame -> width; a frame without
    one: any box), nearest to the camera. Missing = none."""
    from ..reference.tracker import box_iou
    out = {}
    widths = widths or {}
    for r in records:
        k, best = r["frame"], None
        if truth.boxes:
            if k in truth.boxes:
                cands = [(box_iou(t["box"], truth.boxes[k]), t["id"]) for t in r["tracks"]
                         if t["state"] != "tentative"]
                cands = [c for c in cands if c[0] >= 0.5]
                best = max(cands)[1] if cands else None
        else:
            mid = None if widths.get(r["frame"]) is None else (widths[r["frame"]] - 1) / 2
            cands = [(t["distance_m"], t["id"]) for t in r["tracks"]
                     if t["state"] != "tentative" and t.get("distance_m") is not None
                     and (mid is None or t["box"][0] <= mid <= t["box"][2])]
            best = min(cands)[1] if cands else None
        if best is not None:
            out[k] = best
    return out


def tracking_figures(records, truth: Truth):
    """[(what, value)] rows for the summary, and notes."""
    from ..reference.tracker import box_iou
    rows, notes = [], []
    n = len(records)
    tr = np.array([[r["frame"], t["id"], *t["box"], 1.0 if t["state"] == "confirmed" else 0.5]
                   for r in records for t in r["tracks"] if t["state"] != "tentative"], float).reshape(-1, 7)
    if truth.labels is not None:
        from ..eval.tracking import evaluate_kitti
        res = evaluate_kitti(truth.labels, tr, num_frames=max(n, int(truth.labels["frame"].max()) + 1
                                                             if len(truth.labels) else n))
        rows += [("HOTA", f"{res['HOTA']:.1%}"), ("MOTA", f"{res['MOTA']:.1%}"), ("IDF1", f"{res['IDF1']:.1%}"),
                 ("ID switches", int(res["IDSW"])), ("truth ids / track ids",
                                                     f"{res['num_gt_ids']} / {res['num_tracker_ids']}")]
        notes.append("Tracking figures: TrackEval (KITTI rules, class Car) of the confirmed and coasting "
                     "tracks against the KITTI labels.")
    if truth.boxes:
        from ..eval.tracking import evaluate_kitti
        counts: dict = {}
        for r in records:
            b = truth.boxes.get(r["frame"])
            for t in r["tracks"]:
                if b is not None and t["state"] != "tentative" and box_iou(t["box"], b) >= 0.5:
                    counts[t["id"]] = counts.get(t["id"], 0) + 1
        lead = max(counts, key=counts.get) if counts else None
        labelled = [r["frame"] for r in records if r["frame"] in truth.boxes]
        ious = []
        for r in records:
            if r["frame"] in truth.boxes:
                m = [box_iou(t["box"], truth.boxes[r["frame"]]) for t in r["tracks"] if t["id"] == lead
                     and t["state"] != "tentative"]
                ious.append(m[0] if m else 0.0)
        ious = np.array(ious)
        rows += [("lead car id", "none" if lead is None else f"#{lead}"),
                 ("lead id kept (IoU >= 0.5)", f"{np.mean(ious >= 0.5):.1%} of {len(labelled)} labelled frames"),
                 ("lead IoU >= 0.6", f"{np.mean(ious >= 0.6):.1%}"),
                 ("lead mean IoU", f"{ious.mean():.3f}" if len(ious) else "-")]
        if lead is not None:
            gt = np.array([[k, 1, *truth.boxes[k]] for k in sorted(truth.boxes)], float)
            mine = tr[tr[:, 1] == lead]
            res = evaluate_kitti(gt, mine, num_frames=max(n, int(gt[:, 0].max()) + 1), preproc="none")
            rows += [("lead HOTA / MOTA / IDF1", f"{res['HOTA']:.1%} / {res['MOTA']:.1%} / {res['IDF1']:.1%}")]
        notes.append("Lead-car figures: the truth boxes label one car only, so only the track id overlapping "
                     "them most is scored (other vehicles are unlabelled, not false positives); TrackEval "
                     "without KITTI preprocessing.")
    if truth.labels is None and not truth.boxes:
        notes.append("No box truth given: no HOTA/MOTA/IDF1 (--truth with KITTI tracking labels or a "
                     "frame,left,top,right,bottom CSV).")
    return rows, notes


def range_figures(records, truth: Truth, lead: dict):
    rows, notes = [], []
    if not truth.ranges:
        return rows, notes
    est = {}
    for r in records:
        tid = lead.get(r["frame"])
        for t in r["tracks"]:
            if t["id"] == tid:
                est[r["frame"]] = t
    pairs = [(truth.ranges[k], est[k]["distance_m"]) for k in sorted(est)
             if k in truth.ranges and est[k].get("distance_m") is not None]
    if pairs:
        d = np.array(pairs)
        err = d[:, 1] - d[:, 0]
        rows += [("distance: frames compared", len(d)), ("distance MAE", f"{np.mean(np.abs(err)):.2f} m"),
                 ("distance bias", f"{np.mean(err):+.2f} m"),
                 ("distance median |rel. error|", f"{np.median(np.abs(err) / d[:, 0]):.1%}")]
    else:
        notes.append("Range truth given but no distance estimate on the lead car's track: no distance error.")
    tt = truth.ttc()

    def ttc_rows(key, label):
        """The TTC errors of one estimate against the lidar TTC (0-60 s) on the lead's frames."""
        tp = [(tt[k], est[k][key]) for k in sorted(est) if tt.get(k) is not None and 0 < tt[k] < 60
              and est[k].get(key) is not None]
        if not tp:
            return []
        d = np.array(tp)
        e = np.abs(d[:, 1] - d[:, 0])
        return [(f"{label}: frames compared", len(d)), (f"{label} MAE", f"{np.mean(e):.2f} s"),
                (f"{label} median |rel. error|", f"{np.median(e / d[:, 0]):.1%}")]

    # the distance/rate TTC (the one the warning follows by default), then the fused one
    # `track` draws (distance/rate with the block scale) when the records have it
    rate = ttc_rows("ttc_s", "distance/rate TTC")
    if not rate and pairs:
        notes.append("No TTC estimate on the lead car's track: no TTC error.")
    rows += rate + ttc_rows("ttc_fused_s", "fused TTC")
    return rows, notes


# ====================================================================== page
CSS = """
body{font-family:"DejaVu Sans",Arial,sans-serif;margin:24px auto;max-width:1140px;color:#222;background:#fff}
h1{font-size:24px;margin:0 0 4px}h2{font-size:18px;margin:28px 0 8px;border-bottom:1px solid #ddd;padding-bottom:4px}
.meta{color:#555;font-size:13px;margin:0}.note{background:#fff6e0;border-left:4px solid #e0a000;padding:6px 10px;
font-size:13px;margin:6px 0}table{border-collapse:collapse;font-size:13px;margin:6px 0}
td,th{border:1px solid #ddd;padding:3px 10px;text-align:left}th{background:#f3f3f3}
td:first-child{white-space:nowrap}
.sheet{display:grid;grid-template-columns:repeat(3,1fr);gap:8px}.sheet figure{margin:0}
.sheet img{width:100%;display:block;border:1px solid #ccc}.sheet figcaption{font-size:12px;color:#555}
.tracks{display:grid;grid-template-columns:repeat(auto-fill,minmax(200px,1fr));gap:6px}.tracks figure{margin:0}
.tracks img{width:200px;display:block;border:1px solid #ccc}.tracks figcaption{font-size:11px;color:#555}
img.plot{max-width:100%;display:block}.legend span{display:inline-block;margin-right:16px;font-size:13px}
.sw{display:inline-block;width:12px;height:12px;margin-right:5px;vertical-align:-1px;border:1px solid #999}
.cols{display:flex;gap:28px;flex-wrap:wrap;align-items:flex-start}.cols>div{flex:1 1 400px}
.cols table{width:100%}
"""


def _swatch(col: str, label: str) -> str:
    return f'<span><i class="sw" style="background:{col}"></i>{html.escape(label)}</span>'


def render_html(records, infos, thumbs, *, title: str, meta: dict, truth: Truth | None = None,
                extra_notes=(), stage_notes=(), pitch_source: str = "", track_tiles: dict | None = None) -> str:
    """The page as a string. thumbs: [(frame, BGR annotated image)]; meta: label -> value;
    track_tiles: track id -> tile (TrackTiles.pick), the "Every track, once" section."""
    truth = truth or Truth()
    lead = lead_ids(records, truth, {i.frame: i.width for i in infos if i.width is not None})
    parts = [f"<h1>{html.escape(title)}</h1>"]
    parts.append("".join(f'<p class="meta"><b>{html.escape(k)}:</b> {html.escape(str(v))}</p>'
                         for k, v in meta.items()))
    for n in extra_notes:
        parts.append(_note(n))

    # ---- summary
    n = len(records)
    ids = _ids(records)
    conf = sorted({t["id"] for r in records for t in r["tracks"] if t["state"] == "confirmed"})
    rows = [("frames", n), ("track ids (confirmed at least once)", f"{len(ids)} ({len(conf)})"),
            ("track-frames (confirmed / coasting / tentative)",
             " / ".join(str(sum(t["state"] == s for r in records for t in r["tracks"]))
                        for s in ("confirmed", "coasting", "tentative"))),
            ("detection frames", sum(1 for i in infos if i.detections is not None)),
            ("warnings (frames with a warning)", sum(1 for r in records if any(t.get("warning") for t in r["tracks"])))]
    notes = []
    if infos:
        tot = [sum(i.timing_ms.values()) for i in infos]
        rows.append(("mean run time per frame", f"{np.mean(tot):.2f} ms (Python wall time, all stages)"))
    try:
        tr_rows, tr_notes = tracking_figures(records, truth)
    except (ValueError, ImportError) as e:
        tr_rows, tr_notes = [], [f"Tracking figures not computed: {e}"]
    rg_rows, rg_notes = range_figures(records, truth, lead)
    if truth.sources:
        notes.append("Truth: " + "; ".join(truth.sources) + ".")
    right = (_table(("against the truth", ""), tr_rows + rg_rows) if tr_rows or rg_rows else "")
    parts.append("<h2>Summary</h2>" + f'<div class="cols"><div>{_table(("this run", ""), rows)}</div>'
                 f"<div>{right}</div></div>")
    notes += tr_notes + rg_notes
    parts += [_note(x) for x in notes]

    # ---- contact sheet
    parts.append("<h2>Contact sheet</h2>")
    sources = sorted({t.get("source") or "other" for r in records for t in r["tracks"]})
    parts.append('<div class="legend">' + "".join(
                     _swatch(SOURCE_COLOURS.get(s, SOURCE_COLOURS["other"])[1], f"track from {s}") for s in sources)
                 + _swatch(DETECTOR_BOX[1], "detector box (detection frames)")
                 + _swatch("#ffc800", "road area") + _swatch("#005aff", "left lane line")
                 + _swatch("#ff0000", "right lane line")
                 + "<span>thin: tentative; dashed: coasting; #id*: a detector box confirmed it "
                   "on this frame</span></div>")
    if thumbs:
        det = {i.frame for i in infos if i.detections is not None}
        figs = "".join(f'<figure><img src="{_jpeg_data_uri(thumbnail(img))}" alt="frame {k}">'
                       f"<figcaption>frame {k}{' (detection frame)' if k in det else ''}</figcaption></figure>"
                       for k, img in thumbs)
        parts.append(f'<div class="sheet">{figs}</div>')
    else:
        parts.append(_note("No frame in this recording."))
    parts.append("<h2>Every track, once</h2>")
    parts.append(track_gallery(records, track_tiles) if track_tiles else _note("No track in this recording."))

    # ---- plots
    for head, (uri, nts) in (("Track timeline", _one(plot_timeline(records))),
                             ("Distance and time to collision", plot_range_ttc(records, truth, lead, stage_notes)),
                             ("Lane width and pitch", plot_lane_pitch(infos, pitch_source) if infos else (None, ["No frames."])),
                             ("Run time per frame and stage", plot_runtime(infos))):
        parts.append(f"<h2>{head}</h2>")
        parts += [_note(x) for x in nts]
        if uri:
            parts.append(_img(uri, head))
        if head.startswith("Run time") and infos:
            parts.append(runtime_table(infos))
            parts.append('<p class="meta">Wall time of this Python process around each stage\'s call '
                         "(binding and conversions included): a lone tall bar is usually another "
                         "process taking the CPU; the median is the figure to read. <code>make bench</code> "
                         "measures the stages properly.</p>")
    body = "\n".join(parts)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>{html.escape(title)}</title><style>{CSS}</style></head>\n<body>\n{body}\n"
            f'<p class="meta">written {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M UTC} by pyvehtrack report; '
            f"self-contained: no script, no external resource.</p>\n</body></html>\n")


def _one(pair):
    uri, note = pair
    return uri, [note] if note else []


def write_page(out_dir, page: str) -> Path:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    p = out / "index.html"
    p.write_text(page, encoding="utf-8")
    return p
