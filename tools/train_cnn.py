"""Train the small fully convolutional vehicle detector (CenterNet-style heat map + box
sides at stride 8, one network shared by three pyramid levels) on tusimple-vehicles-dev.

    python tools/train_cnn.py --out /tmp/cnn [--epochs 60] [--split fit] [--level0 TOP BOTTOM]
                              [--channels C1 .. C6 [C7]] [--strip P] [--seed N]
                              [--stretch PERMILLE] [--low-light P] [--up-band TOP BOTTOM LEFT RIGHT]
                              [--resume] [--stop-after E] [--limit N]

Float training in PyTorch (a tool dependency only: the C core and the shipped model file
need no torch). Writes OUT/cnn_float.pt and OUT/cnn.npz and prints the 'val' scores of the float model and
of the quantised one run by the C core.

After every epoch OUT/checkpoint.pt holds the network, the optimiser, the schedule and both random
generators, so a run stopped part-way (a session's end) goes on with the same command plus --resume and
ends with the same weights as a run never stopped (tests/test_train_cnn_tool.py checks it bit for bit).
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pyvehtrack import eval_boxes as eb  # noqa: E402
from pyvehtrack.cnn import MAX_CH as CNN_MAX_CH  # noqa: E402
from pyvehtrack.datasets import tusimple_frames  # noqa: E402
from pyvehtrack.image import pyr_down  # noqa: E402
from pyvehtrack.reference.cnn import band_rows as ref_band_rows  # noqa: E402
from pyvehtrack.reference.cnn import stretch as ref_stretch  # noqa: E402
from pyvehtrack.reference.cnn import up_rect as ref_up_rect  # noqa: E402
from pyvehtrack.reference.cnn import upsample2x as ref_upsample2x  # noqa: E402

DATA = ROOT.parent / "shared" / "data" / "tusimple-vehicles-dev"
STRIDE = 8
# Level k is the frame after k pyr_down steps (k = 1, 2, 3); a vehicle is a positive on a
# level when its width there lies in that level's band (level pixels), "ignored" (no loss)
# when it lies outside but is visible, so the bands overlap and NMS merges across levels.
BANDS = {0: (6.0, 40.0), 1: (6.0, 56.0), 2: (22.0, 56.0), 3: (22.0, 56.0), 4: (22.0, 400.0),
         # the upsampled band (key -1, the decode's scale shift): 2x pixels, vehicles 4..24 px wide at the frame
         -1: (8.0, 48.0)}
LEVELS = (1, 2, 3, 4)
# --level0 TOP BOTTOM: level 0 (full resolution, for vehicles 6..40 px wide) runs only on
# the rows TOP..BOTTOM permille of the frame height, where small (far) vehicles stand,
# as vt_cnn_cfg's l0_top_permille / l0_bottom_permille do in C; None: no level 0.
L0_BAND = None
# --stretch T: the network learns, is calibrated and is evaluated on frames through the C
# core's contrast stretch (vt_cnn_cfg.stretch_tail_permille = T, reference.cnn.stretch), the
# frames it will see in the file's detector; 0 = none (files before it learnt unstretched frames).
STRETCH = 0
# --up-band TOP BOTTOM LEFT RIGHT: the network also learns (and is evaluated) on that rectangle of
# the frame at 2x (vt_cnn_cfg's upsampled band, reference.cnn.upsample2x), level key -1, last;
# None: no band.
UP_BAND = None
# Flags added after checkpoints were first written, with their defaults: at the default they are
# left out of a checkpoint's run key, so an older run still resumes.
LATER_FLAGS = {"codec": 0.0, "train_part": None}


def seen(gray):
    """The frame as the file's detector gives it to the network: through the stretch with
    --stretch, else as it is."""
    return ref_stretch(gray, STRETCH) if STRETCH else gray


def band_rows(h):
    """Rows y0 .. y1 - 1 of level 0: vt_cnn_cfg's rounding, as the twin computes it."""
    return ref_band_rows(h, *L0_BAND)
DEFAULT_CH = (16, 24, 32, 32, 32, 32)
CH = DEFAULT_CH   # --channels


def up_rect(h, w):
    """The upsampled band's source rectangle (x0, y0, x1, y1): vt_cnn_cfg's rounding."""
    return ref_up_rect(h, w, *UP_BAND)


def level_offset(k, h, w):
    """(dx, dy): where level k's image starts in the frame (level 0's row band, the upsampled band)."""
    if k == 0:
        return 0, band_rows(h)[0]
    if k == -1:
        return up_rect(h, w)[:2]
    return 0, 0


def levels_of(gray):
    out, img = {}, gray
    if 0 in LEVELS:
        y0, y1 = band_rows(gray.shape[0])
        out[0] = np.ascontiguousarray(gray[y0:y1])
    for k in range(1, max(LEVELS) + 1):
        img = pyr_down(np.ascontiguousarray(img))
        if k in LEVELS:
            out[k] = img
    if -1 in LEVELS:
        out[-1] = ref_upsample2x(gray, *up_rect(*gray.shape))
    return out


def build_net():
    import torch.nn as nn

    def cbr(ci, co, s, d=1):
        return [nn.Conv2d(ci, co, 3, s, padding=d, dilation=d, bias=False), nn.BatchNorm2d(co), nn.ReLU()]
    c = CH
    layers = (cbr(1, c[0], 2) + cbr(c[0], c[1], 2) + cbr(c[1], c[2], 2) + cbr(c[2], c[3], 1)
              + cbr(c[3], c[4], 1, 2) + cbr(c[4], c[5], 1, 2))
    if len(c) == 7:
        # a seventh 3x3 layer (dilation 2) at stride 8: the C core takes VT_CNN_MAX_LAYERS = 8
        # layers, the head included, so this is the deepest network it runs
        layers += cbr(c[5], c[6], 1, 2)
    head = nn.Conv2d(c[-1], 5, 1)
    nn.init.constant_(head.bias[:1], -4.0)   # a rare-object prior: the first steps do not drown in negatives
    return nn.Sequential(*layers, head)


def targets(boxes, h, w, band, noreg=None):
    """Heat (1), ltrb log-distance (4), regression weight (1), loss mask (1) on the stride-8
    grid of a level image h x w; boxes (N, 4) exclusive level pixels; `noreg` (N,) True: a
    heat target only (a pasted crop, whose square is not the vehicle's exact box)."""
    gh, gw = (h + STRIDE - 1) // STRIDE, (w + STRIDE - 1) // STRIDE
    heat = np.zeros((gh, gw), np.float32)
    reg = np.zeros((4, gh, gw), np.float32)
    rw = np.zeros((gh, gw), np.float32)
    mask = np.ones((gh, gw), np.float32)
    ys, xs = (np.arange(gh) + 0.5) * STRIDE, (np.arange(gw) + 0.5) * STRIDE
    # larger boxes first so a small box in front wins the cells they share
    order = np.argsort(-(boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])) if len(boxes) else []
    for i in order:
        x0, y0, x1, y1 = boxes[i]
        bw, bh = x1 - x0, y1 - y0
        if bw < 2 or bh < 2:
            continue
        # out of the level's band, or centred outside its image (level 0's row band, the
        # upsampled band's rectangle): no positive here, and no negative either where it shows
        if not (band[0] <= bw < band[1]) or not (0 <= (y0 + y1) / 2 < h) or not (0 <= (x0 + x1) / 2 < w):
            gx0, gx1 = int(max(0, x0 // STRIDE)), int(min(gw, math.ceil(x1 / STRIDE)))
            gy0, gy1 = int(max(0, y0 // STRIDE)), int(min(gh, math.ceil(y1 / STRIDE)))
            mask[gy0:gy1, gx0:gx1] = 0
            continue
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        sx, sy = max(0.6, bw / STRIDE / 6), max(0.6, bh / STRIDE / 6)
        g = np.exp(-((xs[None, :] / STRIDE - cx / STRIDE) ** 2) / (2 * sx * sx)
                   - ((ys[:, None] / STRIDE - cy / STRIDE) ** 2) / (2 * sy * sy))
        icx, icy = int(min(gw - 1, cx // STRIDE)), int(min(gh - 1, cy // STRIDE))
        g[icy, icx] = 1.0
        heat = np.maximum(heat, g)
        inside = (g > 0.3) & (xs[None, :] > x0) & (xs[None, :] < x1) & (ys[:, None] > y0) & (ys[:, None] < y1)
        inside[icy, icx] = True
        yy, xx = np.nonzero(inside)
        cxs, cys = xs[xx], ys[yy]
        d = np.stack([cxs - x0, cys - y0, x1 - cxs, y1 - cys])
        reg[:, yy, xx] = np.log(np.maximum(d, 1.0) / STRIDE)
        rw[yy, xx] = 0.0 if noreg is not None and noreg[i] else g[yy, xx]
    mask = np.maximum(mask, (heat > 0).astype(np.float32))
    return heat, reg, rw, mask


def step_back(gray, rng):
    """The frame a step earlier: zoomed out 0-4% about a point near the centre, shifted up to 6 / 3 px."""
    h, w = gray.shape
    s = 1.0 / rng.uniform(1.0, 1.04)
    cx, cy = w * rng.uniform(0.4, 0.6), h * rng.uniform(0.4, 0.6)
    m = cv2.getRotationMatrix2D((cx, cy), 0.0, s)
    m[:, 2] += (rng.uniform(-6, 6), rng.uniform(-3, 3))
    return cv2.warpAffine(gray, m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def video_codec(gray, rng, tmpdir):
    """The frame as a dashcam clip shows it: written with OpenCV's mp4v (MPEG-4 part 2) at its
    default quality, as the second frame of a two-frame clip whose first is the frame seen a step
    earlier (zoomed out 0-4% about a point near the centre and shifted up to 6 / 3 px: the car
    moved), so it is decoded as a predicted frame with its motion-compensation blocks, not as a
    still. The pixels stay where they were, so the boxes do not change."""
    h, w = gray.shape
    prev = step_back(gray, rng)
    path = str(Path(tmpdir) / "codec.avi")
    vw = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"mp4v"), 10, (w, h), isColor=False)
    if not vw.isOpened():
        raise RuntimeError("--codec: OpenCV cannot write mp4v video here (cv2.VideoWriter did not open)")
    vw.write(prev)
    vw.write(gray)
    vw.release()
    cap = cv2.VideoCapture(path)
    frames = [cap.read() for _ in range(2)]
    cap.release()
    if not all(ok for ok, _ in frames):
        raise RuntimeError("--codec: OpenCV wrote an mp4v clip it cannot read back")
    return np.ascontiguousarray(cv2.cvtColor(frames[1][1], cv2.COLOR_BGR2GRAY))


def augment(gray, boxes, rng, flags=None, low_light=0.0, codec=0.0, tmpdir=None):
    """Scale jitter (crop / pad back to the frame size), flip, light, JPEG; boxes (N, 4)
    exclusive full-frame pixels. With `flags` (N,) the flags of the boxes kept are returned too.
    With probability `low_light` the light's gain is drawn from 0.3..0.6 instead of 0.6..1.3 and
    the sensor's noise shows (Gaussian, sigma 1..4 grey levels, before the JPEG step): the frames
    of dusk, whose noise the contrast stretch then amplifies as much as the light. With
    probability `codec` the last step is video_codec (in `tmpdir`) instead of the JPEG step; with
    codec 0 no draw is made for it, so the other recipes' random streams stay as they were."""
    h, w = gray.shape
    if flags is None:
        flags = np.zeros(len(boxes), bool)
    s = math.exp(rng.uniform(math.log(0.7), math.log(1.45)))
    img = cv2.resize(gray, (int(round(w * s)), int(round(h * s))), interpolation=cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR)
    b = boxes * s
    H, W = img.shape
    out = np.full((h, w), int(gray.mean()), np.uint8)
    ox = rng.integers(min(0, w - W), max(0, w - W) + 1)
    oy = rng.integers(min(0, h - H), max(0, h - H) + 1)
    sx0, sy0 = max(0, -ox), max(0, -oy)
    dx0, dy0 = max(0, ox), max(0, oy)
    cw, ch = min(W - sx0, w - dx0), min(H - sy0, h - dy0)
    out[dy0:dy0 + ch, dx0:dx0 + cw] = img[sy0:sy0 + ch, sx0:sx0 + cw]
    b = b + np.array([ox, oy, ox, oy], np.float32)
    vis = b.copy()
    vis[:, [0, 2]] = vis[:, [0, 2]].clip(0, w)
    vis[:, [1, 3]] = vis[:, [1, 3]].clip(0, h)
    area = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    varea = (vis[:, 2] - vis[:, 0]).clip(0) * (vis[:, 3] - vis[:, 1]).clip(0)
    keep = varea > 0.4 * np.maximum(area, 1)
    b = vis[keep]
    flags = flags[keep]
    if rng.random() < 0.5:
        out = out[:, ::-1].copy()
        b = np.stack([w - b[:, 2], b[:, 1], w - b[:, 0], b[:, 3]], 1) if len(b) else b
    g = rng.uniform(0.6, 1.6)
    dark = low_light > 0 and rng.random() < low_light
    a, c = rng.uniform(0.3, 0.6) if dark else rng.uniform(0.6, 1.3), rng.uniform(-30, 30)
    if dark:
        c = rng.uniform(0, 10)      # a dark frame is not lifted by an offset
    lut = np.clip(a * 255.0 * (np.arange(256) / 255.0) ** g + c, 0, 255).astype(np.uint8)
    out = lut[out]
    if dark:
        noise = rng.normal(0.0, rng.uniform(1.0, 4.0), out.shape)
        out = np.clip(np.rint(out + noise), 0, 255).astype(np.uint8)
    if codec > 0 and rng.random() < codec:
        out = video_codec(np.ascontiguousarray(out), rng, tmpdir)
    elif rng.random() < 0.5:
        q = int(rng.integers(20, 90))
        out = cv2.imdecode(cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, q])[1], cv2.IMREAD_GRAYSCALE)
    return np.ascontiguousarray(out), b.astype(np.float32).reshape(-1, 4), flags


def gti_train_crops(kind: str, folder_prefix: str = "") -> list:
    """Gray crops of gti-vehicles/KIND (vehicles or non-vehicles) in gti_split's TRAIN blocks,
    folder by folder in name order; only the folders whose name starts with folder_prefix."""
    from pyvehtrack.datasets import gti_sorted, gti_split
    crops = []
    for folder in sorted((DATA.parent / "gti-vehicles" / kind).iterdir()):
        if folder.name.startswith(folder_prefix):
            crops += [read_gray(f)
                      for i, f in enumerate(gti_sorted(folder)) if gti_split(i) == "train"]
    return crops


def load_paste_crops():
    """Gray vehicle crops of the GTI folders' TRAIN blocks (KITTI_extracted left out, so the
    KITTI frames stay unseen), for --paste."""
    return gti_train_crops("vehicles", "GTI")


def paste(gray, boxes, crops, places, rng, n_max=3):
    """Copy-paste: 1..n_max vehicle crops laid on the frame, each where a labelled vehicle of
    another training frame stood (`places`: its box, so the size fits the row), shifted
    sideways by up to a quarter of its width, 12..80 px wide, not over a vehicle already there; the crop's border
    feathered over a tenth of its width so no square edge marks it. Returns the frame, the
    boxes with the pasted ones appended, and a flag per box (True: pasted)."""
    h, w = gray.shape
    out = gray.astype(np.float32)
    bx = [b for b in boxes]
    flags = [False] * len(boxes)
    for _ in range(int(rng.integers(1, n_max + 1))):
        x0, y0, x1, y1 = places[int(rng.integers(len(places)))]
        bw = int(round(x1 - x0))
        if not 12 <= bw <= 80:       # a 64 px crop blown up further is a blur
            continue
        x0 = x0 + rng.uniform(-0.25, 0.25) * bw
        x0, y1 = int(round(min(max(0, x0), w - bw))), int(round(min(y1, h)))
        y0 = y1 - bw
        if y0 < 0:
            continue
        nb = np.float32([x0, y0, x0 + bw, y1])
        if any(max(0, min(nb[2], o[2]) - max(nb[0], o[0])) * max(0, min(nb[3], o[3]) - max(nb[1], o[1]))
               > 0.1 * bw * bw for o in bx):
            continue
        c = cv2.resize(crops[int(rng.integers(len(crops)))], (bw, bw), interpolation=cv2.INTER_AREA
                       if bw < 64 else cv2.INTER_LINEAR).astype(np.float32)
        if rng.random() < 0.5:
            c = c[:, ::-1]
        f = max(1.0, bw / 10)
        r = np.minimum(np.arange(bw) + 0.5, bw - 0.5 - np.arange(bw)) / f
        a = np.clip(np.minimum(r[None, :], r[:, None]), 0, 1)
        out[y0:y1, x0:x0 + bw] = a * c + (1 - a) * out[y0:y1, x0:x0 + bw]
        bx.append(nb)
        flags.append(True)
    return (np.clip(out + 0.5, 0, 255).astype(np.uint8), np.float32(bx).reshape(-1, 4),
            np.array(flags, bool))


def strip(gray, boxes, ratio, at, horizon=330 / 720):
    """A wide-aspect strip of the frame (KITTI-like 1242 x 375: width / height `ratio`,
    drawn in 2.5..3.5): full width, the rows chosen so that the frame's horizon (tusimple's
    mean, 0.46 h) lies at `at` (drawn in 0.35..0.6) of the strip, as on KITTI (0.45..0.5); boxes at least 40% inside kept,
    cut to the strip. A network whose level images are only this high sees the near car
    with little context above and below, as it will on such cameras."""
    h, w = gray.shape
    hs = min(h, int(round(w / ratio)))
    y0 = int(round(horizon * h - at * hs))
    y0 = min(max(0, y0), h - hs)
    b = boxes - np.float32([0, y0, 0, y0])
    vis = b.copy()
    vis[:, [1, 3]] = vis[:, [1, 3]].clip(0, hs)
    area = (b[:, 3] - b[:, 1]).clip(1)
    keep = (vis[:, 3] - vis[:, 1]).clip(0) > 0.4 * area
    return np.ascontiguousarray(gray[y0:y0 + hs]), vis[keep].reshape(-1, 4)


def read_gray(path) -> np.ndarray:
    """A training image as the command line sees it: decoded in colour, then pyvehtrack.frames.to_gray
    (BGR -> gray). IMREAD_GRAYSCALE would let libjpeg decode luma directly, which differs by a few
    levels on about 0.5% of a TuSimple frame's pixels: enough to move a box between training and use."""
    from pyvehtrack.frames import to_gray
    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise FileNotFoundError(f"cannot read image {path}")
    return to_gray(img)


def _frame_number(item) -> int:
    """The file number NNNN of a loaded training frame (load()'s item)."""
    return int(re.findall(r"\d+", Path(item[0]["file_name"]).stem)[-1])


def train_part(items, k: int, n: int) -> list:
    """Part k of n of load()'s items (--train-part): file number NNNN with (NNNN // 100) % n == k,
    so each part spreads over the whole set in blocks of 100 numbers."""
    return [t for t in items if (_frame_number(t) // 100) % n == k]


def load(split):
    frames = tusimple_frames(DATA, split)
    out = []
    for e in frames:
        g = read_gray(DATA / e["file_name"])
        bx = np.array([[d["left"], d["top"], d["right"] + 1, d["bottom"] + 1] for d in e["bbox"]],
                      np.float32).reshape(-1, 4)
        out.append((e, g, bx))
    return out


def focal(pred, gt, mask):
    import torch
    p = torch.sigmoid(pred).clamp(1e-4, 1 - 1e-4)
    pos = gt.eq(1).float()
    neg = (1 - pos) * mask
    pl = torch.log(p) * (1 - p) ** 2 * pos
    nl = torch.log(1 - p) * p ** 2 * (1 - gt) ** 4 * neg
    n = pos.sum().clamp(min=1)
    return -(pl.sum() + nl.sum()) / n


def giou_loss(pred, target):
    """1 - GIoU of the boxes the side codes (log distances from the cell centre, (B, 4, h, w))
    give, per cell: a loss on the box's overlap itself, which the L1 on the codes only
    approximates (a short box costs as much as a narrow one there)."""
    import torch
    p, t = torch.exp(pred.clamp(max=6)), torch.exp(target)
    pl, pt, pr, pb = p.unbind(1)
    tl, tt, tr, tb = t.unbind(1)
    inter = (torch.minimum(pl, tl) + torch.minimum(pr, tr)) * (torch.minimum(pt, tt) + torch.minimum(pb, tb))
    union = (pl + pr) * (pt + pb) + (tl + tr) * (tt + tb) - inter
    enc = (torch.maximum(pl, tl) + torch.maximum(pr, tr)) * (torch.maximum(pt, tt) + torch.maximum(pb, tb))
    return 1 - inter / union + (enc - union) / enc


def decode(out, k, thr=0.3, topk=60):
    """Boxes (N, 5) [l, t, r, b, score] in full-frame exclusive pixels from one level's
    network output (5, gh, gw) as NumPy float."""
    heat = 1 / (1 + np.exp(-out[0]))
    gh, gw = heat.shape
    pad = np.pad(heat, 1, constant_values=0)
    mx = np.max(np.stack([pad[dy:dy + gh, dx:dx + gw] for dy in range(3) for dx in range(3)]), 0)
    peak = (heat >= mx) & (heat >= thr)
    ys, xs = np.nonzero(peak)
    sc = heat[ys, xs]
    o = np.argsort(-sc)[:topk]
    ys, xs, sc = ys[o], xs[o], sc[o]
    cx, cy = (xs + 0.5) * STRIDE, (ys + 0.5) * STRIDE
    d = np.exp(out[1:5, ys, xs]) * STRIDE
    f = 2.0 ** k
    return np.stack([(cx - d[0]) * f, (cy - d[1]) * f, (cx + d[2]) * f, (cy + d[3]) * f, sc], 1)


def nms(b, iou=0.5, contain=0.7):
    """The float network's boxes (N, 5) [l, t, r, b exclusive, score] thinned by the
    reference's greedy NMS (vt_nms' rule: IoU above `iou` or more than `contain` of the
    smaller box inside the other), on the inclusive integer boxes the C core would hold."""
    from pyvehtrack.reference.windows import nms as ref_nms
    if not len(b):
        return b
    ib = np.stack([np.floor(b[:, 0]), np.floor(b[:, 1]), np.floor(b[:, 2]) - 1, np.floor(b[:, 3]) - 1], 1)
    return b[ref_nms(ib.astype(np.int64), b[:, 4], iou, contain)]


def evaluate(net, data, thr=0.3):
    import torch
    net.eval()
    preds = []
    with torch.no_grad():
        for i, (e, g, _) in enumerate(data):
            lv = levels_of(seen(g))
            allb = []
            for k in LEVELS:
                x = torch.from_numpy(lv[k].astype(np.float32) / 255.0)[None, None]
                bk = decode(net(x)[0].numpy(), k, thr)
                dx, dy = level_offset(k, *g.shape)
                bk[:, [0, 2]] += dx
                bk[:, [1, 3]] += dy
                allb.append(bk)
            b = nms(np.concatenate(allb))
            preds.append({"frame": i, "file": e["file_name"],
                          "boxes": [[int(v[0]), int(v[1]), int(v[2]) - 1, int(v[3]) - 1, float(v[4])] for v in b]})
    net.train()
    return eb.score(eb.load_gt([d[0] for d in data]), eb.load_pred(preds)), preds


def fold(net):
    """Conv + BatchNorm pairs folded into float (w (cout, k, k, cin), b, meta) per layer."""
    import torch.nn as nn
    mods, out, i = list(net), [], 0
    while i < len(mods):
        c = mods[i]
        if not isinstance(c, nn.Conv2d):
            i += 1
            continue
        w = c.weight.detach().double().numpy()
        b = c.bias.detach().double().numpy() if c.bias is not None else np.zeros(w.shape[0])
        relu = 0
        if i + 1 < len(mods) and isinstance(mods[i + 1], nn.BatchNorm2d):
            bn = mods[i + 1]
            g = (bn.weight / (bn.running_var + bn.eps).sqrt()).detach().double().numpy()
            w = w * g[:, None, None, None]
            b = (bn.bias.detach().double().numpy() - bn.running_mean.detach().double().numpy() * g) + b * g
            relu = 1
        out.append({"w": w.transpose(0, 2, 3, 1).copy(), "b": b, "k": c.kernel_size[0], "s": c.stride[0],
                    "d": c.dilation[0], "relu": relu})
        i += 1
    return out


def float_forward(layers, img):
    """The folded float network on a uint8 image (h, w) scaled to [0, 1]: per layer the
    HWC activation (for calibration) and the head output."""
    import torch
    import torch.nn.functional as F
    x = torch.from_numpy(img.astype(np.float64) / 255.0)[None, None]
    acts = []
    for L in layers:
        w = torch.from_numpy(L["w"].transpose(0, 3, 1, 2).copy())
        p = L["d"] * (L["k"] // 2)
        x = F.conv2d(x, w, torch.from_numpy(L["b"]), L["s"], p, L["d"])
        if L["relu"]:
            x = torch.relu(x)
        acts.append(x[0].numpy().transpose(1, 2, 0))
    return acts


def _mult_shift(m):
    e = np.floor(np.log2(m)).astype(int)
    shift = 30 - e
    mult = np.round(m * 2.0 ** shift).astype(np.int64)
    big = mult >= 2 ** 31
    mult[big] //= 2
    shift[big] -= 1
    if (shift < 1).any() or (shift > 62).any():
        raise ValueError(f"requantisation scale out of range: {m}")
    return mult.astype(np.int32), shift.astype(np.uint8)


def quantise(layers, calib_imgs, pct=99.99, heat_p=0.3):
    """Post-training quantisation to the vt_cnn_model arithmetic (include/vehtrack/cnn.h):
    int8 weights per output channel, uint8 activations with the scale of each layer's
    `pct` percentile on the calibration images, int8 head outputs per channel."""
    acts = [[] for _ in layers]
    for img in calib_imgs:
        for i, a in enumerate(float_forward(layers, img)):
            acts[i].append(a.reshape(-1, a.shape[-1]))
    z, s_in = {"cnn_n_layers": np.int32(len(layers))}, 1.0 / 255.0
    for i, L in enumerate(layers):
        a = np.concatenate(acts[i])
        last = i == len(layers) - 1
        if last:
            s_out = np.maximum(np.abs(a).max(0), 1e-6) / 127.0          # per channel
        else:
            s_out = max(float(np.percentile(a, pct)), 1e-6) / 255.0
        sw = np.maximum(np.abs(L["w"]).reshape(L["w"].shape[0], -1).max(1), 1e-12) / 127.0
        wq = np.clip(np.round(L["w"] / sw[:, None, None, None]), -127, 127).astype(np.int8)
        bq = np.round(L["b"] / (sw * s_in)).astype(np.int64)
        if (np.abs(bq) > 2 ** 30).any():
            raise ValueError(f"layer {i}: bias beyond 2^30 accumulator units")
        mult, shift = _mult_shift(sw * s_in / s_out)
        cout, k, _, cin = wq.shape
        z[f"cnn_l{i}_meta"] = np.array([k, L["s"], L["d"], L["relu"], cin, cout], np.int32)
        z[f"cnn_l{i}_w"], z[f"cnn_l{i}_bias"] = wq, bq.astype(np.int32)
        z[f"cnn_l{i}_mult"], z[f"cnn_l{i}_shift"] = mult, shift
        s_in = s_out
    q = np.arange(-128, 128)
    lut = np.stack([np.minimum(65535, np.round(np.exp(q * s_in[c]) * STRIDE * 16)) for c in range(1, 5)])
    z["cnn_side_lut"] = lut.astype(np.uint16)
    z["cnn_heat_thr"] = np.int32(min(127, max(-128, math.ceil(math.log(heat_p / (1 - heat_p)) / s_in[0]))))
    z["cnn_out_scale"] = s_in.astype(np.float64)   # information: the head's float per step
    return z


def cfg_row():
    """pyvehtrack.cnn.CFG_KEYS' values: the levels trained, the decoder cap, nms()'s limits
    (and level 0's row band when it runs)."""
    lv = [k for k in LEVELS if k >= 0]
    row = [lv[0], len(lv), 0, 64, 500, 700]
    if L0_BAND is None and not STRETCH and UP_BAND is None:
        return row
    row += (list(L0_BAND) if L0_BAND is not None else [0, 1000])
    if UP_BAND is None:
        return row + ([STRETCH] if STRETCH else [])
    return row + [STRETCH] + list(UP_BAND)


def evaluate_int(z, data):
    """The quantised model z (its file keys) on the eval frames through the C core
    (pyvehtrack.cnn.detect_frame at the levels trained, the decoder's threshold, nms()'s
    limits): exactly what the shipped file does."""
    from pyvehtrack import cnn
    m = cnn.CnnModel.load(z)
    cfg = cnn.CnnConfig(*cfg_row())
    preds = []
    for i, (e, g, _) in enumerate(data):
        b, _ = cnn.detect_frame(m, g, cfg)
        preds.append({"frame": i, "file": e["file_name"], "boxes": [[int(v) for v in r[:4]] + [int(r[4])] for r in b]})
    return eb.score(eb.load_gt([d[0] for d in data]), eb.load_pred(preds)), preds


def pretrain_gti(net, epochs, rng, log=print):
    """The backbone (every layer but the head) first learns vehicle / non-vehicle on the GTI
    crops of gti_split's TRAIN blocks (global average pool + one linear unit): a start with
    vehicle features for a detector that has only a few hundred frames to learn from. Each
    vehicle crop is shrunk to 24..64 px and laid on a random non-vehicle crop."""
    import torch
    import torch.nn as nn
    pos, neg = gti_train_crops("vehicles"), gti_train_crops("non-vehicles")
    log(f"GTI pretraining: {len(pos)} vehicle, {len(neg)} non-vehicle TRAIN crops")
    body = nn.Sequential(*list(net)[:-1])
    cls = nn.Linear(CH[-1], 1)
    opt = torch.optim.AdamW(list(body.parameters()) + list(cls.parameters()), lr=3e-3, weight_decay=1e-4)
    items = [(x, 1.0) for x in pos] + [(x, 0.0) for x in neg]
    for ep in range(epochs):
        perm = rng.permutation(len(items))
        tot, nb = 0.0, 0
        for bi in range(0, len(perm), 64):
            xs, ys = [], []
            for j in perm[bi:bi + 64]:
                img, y = items[j]
                if y > 0:
                    s = int(rng.integers(24, 65))
                    bg = neg[int(rng.integers(len(neg)))].copy()
                    ox, oy = rng.integers(0, 64 - s + 1, 2)
                    bg[oy:oy + s, ox:ox + s] = cv2.resize(img, (s, s), interpolation=cv2.INTER_AREA)
                    img = bg
                if rng.random() < 0.5:
                    img = img[:, ::-1]
                xs.append(img.astype(np.float32) / 255.0)
                ys.append(y)
            x = torch.from_numpy(np.stack(xs))[:, None]
            logit = cls(body(x).mean((2, 3)))[:, 0]
            loss = nn.functional.binary_cross_entropy_with_logits(logit, torch.tensor(ys))
            opt.zero_grad()
            loss.backward()
            opt.step()
            tot, nb = tot + float(loss.detach()), nb + 1
        log(f"GTI epoch {ep + 1}/{epochs} loss {tot / nb:.3f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--epochs", type=int, default=60)
    ap.add_argument("--split", default="fit")
    ap.add_argument("--eval-split", default="val")
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--lr", type=float, default=3e-3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--giou", type=float, default=0.0, metavar="W",
                    help="add W x (1 - GIoU) of the decoded boxes to the side codes' L1 loss")
    ap.add_argument("--pretrain-gti", type=int, default=0, metavar="EPOCHS",
                    help="first train the backbone on GTI TRAIN crops for this many epochs")
    ap.add_argument("--export-only", metavar="PT", help="quantise a saved cnn_float.pt, no training")
    ap.add_argument("--strip", type=float, default=0.0, metavar="P",
                    help="a batch is made of wide-aspect strips of its frames (width / height 2.5..3.5, "
                         "as KITTI's) with probability P")
    ap.add_argument("--channels", nargs="+", type=int, metavar="C", default=list(DEFAULT_CH),
                    help=f"output channels of the six (or seven: a 7th dilated layer) 3x3 layers (default "
                         f"{' '.join(map(str, DEFAULT_CH))}; each 1..{CNN_MAX_CH}, the C core's VT_CNN_MAX_CH)")
    ap.add_argument("--paste", type=float, default=0.0, metavar="P",
                    help="with probability P a training frame gets 1..3 GTI TRAIN vehicle crops pasted "
                         "where labelled vehicles of other frames stood (copy-paste; heat targets only)")
    ap.add_argument("--stretch", type=int, default=0, metavar="PERMILLE",
                    help="learn, calibrate and evaluate on frames through the C core's contrast stretch with "
                         "this tail (vt_cnn_cfg.stretch_tail_permille, 1..100; written to the file's cnn_cfg)")
    ap.add_argument("--low-light", type=float, default=0.0, metavar="P",
                    help="with probability P a training frame is dark (light gain 0.3..0.6) with sensor noise")
    ap.add_argument("--codec", type=float, default=0.0, metavar="P",
                    help="with probability P a training frame goes through OpenCV's mp4v as a dashcam clip's "
                         "predicted frame, instead of the JPEG step")
    ap.add_argument("--level0", nargs=2, type=int, metavar=("TOP", "BOTTOM"),
                    help="also run on level 0 (full resolution, vehicles 6..40 px wide), rows TOP..BOTTOM "
                         "permille of the frame height")
    ap.add_argument("--up-band", nargs=4, type=int, metavar=("TOP", "BOTTOM", "LEFT", "RIGHT"),
                    help="also learn on this rectangle (permille of the height / width) at 2x, vehicles 4..24 px "
                         "wide at the frame (vt_cnn_cfg's upsampled band; written to the file's cnn_cfg)")
    ap.add_argument("--resume", action="store_true",
                    help="go on from OUT/checkpoint.pt (written after every epoch) with the same flags")
    ap.add_argument("--limit", type=int, default=0, metavar="N",
                    help="only the first N frames of each split (a quick check of the tool, not a model)")
    ap.add_argument("--train-part", nargs=2, type=int, metavar=("K", "N"),
                    help="learn on part K of N of the training frames only: those whose file number NNNN has "
                         "(NNNN // 100) %% N == K (blocks of 100 numbers, spread over the whole set; the eval "
                         "split stays whole): a learning curve's smaller sets")
    ap.add_argument("--stop-after", type=int, metavar="E",
                    help="stop after epoch E, leaving the checkpoint for --resume (a run cut short on purpose)")
    a = ap.parse_args(argv)
    if a.limit < 0:
        ap.error(f"--limit: expected N >= 0 (0: every frame), got {a.limit}")
    if a.train_part is not None and not 0 <= a.train_part[0] < a.train_part[1]:
        ap.error(f"--train-part: expected 0 <= K < N, got {a.train_part[0]} {a.train_part[1]}")
    if a.stop_after is not None and a.stop_after < 1:
        ap.error(f"--stop-after: expected an epoch >= 1, got {a.stop_after}")
    global LEVELS, L0_BAND, CH, STRETCH, UP_BAND
    if not 0 <= a.stretch <= 100:
        ap.error(f"--stretch: expected 0..100 permille (vt_cnn_cfg.stretch_tail_permille), got {a.stretch}")
    if a.up_band:
        t, b, lf, r = a.up_band
        if not (0 <= t < b <= 1000 and 0 <= lf < r <= 1000):
            ap.error("--up-band: expected 0 <= TOP < BOTTOM <= 1000 and 0 <= LEFT < RIGHT <= 1000")
        UP_BAND = tuple(a.up_band)
    if not 0.0 <= a.low_light <= 1.0:
        ap.error(f"--low-light: expected a probability 0..1, got {a.low_light}")
    if not 0.0 <= a.codec <= 1.0:
        ap.error(f"--codec: expected a probability 0..1, got {a.codec}")
    STRETCH = a.stretch
    if len(a.channels) not in (6, 7):
        ap.error(f"--channels: 6 or 7 values, got {len(a.channels)}")
    if not all(1 <= c <= CNN_MAX_CH for c in a.channels):
        ap.error(f"--channels: each 1..{CNN_MAX_CH} (VT_CNN_MAX_CH)")
    CH = tuple(a.channels)
    if a.level0:
        if not 0 <= a.level0[0] < a.level0[1] <= 1000:
            ap.error("--level0: 0 <= TOP < BOTTOM <= 1000")
        L0_BAND, LEVELS = tuple(a.level0), (0,) + LEVELS
    if UP_BAND is not None:
        LEVELS = LEVELS + (-1,)      # last, as vt_cnn_detect_frame runs it
    try:    # after the flags are checked: a wrong flag is named on a machine without torch too
        import torch
    except ImportError:
        raise SystemExit("train_cnn.py needs PyTorch (the extra train-cnn; on this project's machines "
                         "`pip install torch==2.13.0` takes the CPU wheel)") from None
    torch.manual_seed(a.seed)
    rng = np.random.default_rng(a.seed)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    codec_dir = tempfile.TemporaryDirectory(prefix="train_cnn_codec_") if a.codec else None
    tmpdir = codec_dir.name if codec_dir else None
    train, val = load(a.split), load(a.eval_split)
    if a.limit:
        train, val = train[:a.limit], val[:a.limit]
    if a.train_part is not None:
        k, n = a.train_part
        train = train_part(train, k, n)
        if not train:
            raise SystemExit(f"--train-part {k} {n}: no {a.split} frame in that part")
    print(f"{len(train)} {a.split} frames, {len(val)} {a.eval_split} frames", flush=True)
    net = build_net()
    if a.export_only:
        net.load_state_dict(torch.load(a.export_only))
        return export(net, train, val, out)
    if a.pretrain_gti and not a.resume:     # resuming: the checkpoint's weights are after it
        pretrain_gti(net, a.pretrain_gti, rng, lambda m: print(m, flush=True))
    if a.paste:
        if a.strip:
            ap.error("--paste and --strip are not combined")
        crops = load_paste_crops()
        places = [bx for _, _, b in train for bx in b if bx[2] - bx[0] >= 12]
        print(f"paste: {len(crops)} GTI TRAIN vehicle crops, {len(places)} places", flush=True)
    opt = torch.optim.AdamW(net.parameters(), lr=a.lr, weight_decay=1e-4)
    steps = a.epochs * math.ceil(len(train) / a.batch)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=a.lr, total_steps=steps, pct_start=0.1)
    # the flags that shape the run: a checkpoint is taken up only by the same run
    # (a flag added later is in the key only when set, so checkpoints written before it still resume)
    run_key = {k: v for k, v in sorted(vars(a).items()) if k not in ("out", "resume", "stop_after")
               and not (k in LATER_FLAGS and v == LATER_FLAGS[k])}
    ckpt, start, t_before = out / "checkpoint.pt", 0, 0.0
    if a.resume:
        if not ckpt.exists():
            raise SystemExit(f"--resume: no {ckpt} (a run writes it after its first epoch)")
        st = torch.load(ckpt, weights_only=False)
        if st["run"] != run_key:
            diff = sorted(k for k in set(st["run"]) | set(run_key) if st["run"].get(k) != run_key.get(k))
            raise SystemExit(f"--resume: {ckpt} is of another run (flags differ: {', '.join(diff)})")
        net.load_state_dict(st["net"])
        opt.load_state_dict(st["opt"])
        sched.load_state_dict(st["sched"])
        rng.bit_generator.state = st["rng"]
        torch.set_rng_state(st["torch_rng"])
        start, t_before = st["epoch"], st["seconds"]
        print(f"resumed after epoch {start} ({t_before:.0f} s before)", flush=True)
    t0 = time.time() - t_before
    for ep in range(start, a.epochs):
        perm = rng.permutation(len(train))
        tot = 0.0
        for bi in range(0, len(perm), a.batch):
            loss = 0.0
            lv_imgs = {k: [] for k in LEVELS}
            lv_t = {k: [] for k in LEVELS}
            # one strip height per batch: the level images of a batch are stacked
            ratio = rng.uniform(2.5, 3.5) if a.strip and rng.random() < a.strip else None
            for j in perm[bi:bi + a.batch]:
                g, b, fl = train[j][1], train[j][2], None
                if a.paste and rng.random() < a.paste:
                    g, b, fl = paste(g, b, crops, places, rng)
                g, b, fl = augment(g, b, rng, fl, a.low_light, a.codec, tmpdir)
                if ratio is not None:
                    g, b = strip(g, b, ratio, rng.uniform(0.35, 0.6))
                    fl = None   # strips and pastes are not combined
                g = seen(g)     # after the strip: a strip is a wide camera's whole frame
                lv = levels_of(g)
                for k in LEVELS:
                    f = 2.0 ** k
                    lv_imgs[k].append(lv[k].astype(np.float32) / 255.0)
                    # level 0 is the row band, -1 the upsampled band: boxes move by where they start
                    dx, dy = level_offset(k, *g.shape)
                    bk = b - np.float32([dx, dy, dx, dy])
                    lv_t[k].append(targets(bk / f, *lv[k].shape, BANDS[k], fl))
            for k in LEVELS:
                x = torch.from_numpy(np.stack(lv_imgs[k]))[:, None]
                heat, reg, rw, mask = (torch.from_numpy(np.stack([t[i] for t in lv_t[k]])) for i in range(4))
                p = net(x)
                loss = loss + focal(p[:, 0], heat, mask)
                wsum = rw.sum().clamp(min=1)
                loss = loss + (torch.abs(p[:, 1:5] - reg).sum(1) * rw).sum() / wsum
                if a.giou:
                    loss = loss + a.giou * (giou_loss(p[:, 1:5], reg) * rw).sum() / wsum
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            tot += float(loss.detach())
        msg = f"epoch {ep + 1}/{a.epochs} loss {tot / math.ceil(len(train) / a.batch):.3f} ({time.time() - t0:.0f} s)"
        if (ep + 1) % 30 == 0 or ep + 1 == a.epochs:
            s, _ = evaluate(net, val)
            msg += "  " + eb.format_scores(s).replace("\n", " | ")
        print(msg, flush=True)
        # written whole, then renamed: a run killed while writing keeps the previous epoch's
        torch.save({"run": run_key, "epoch": ep + 1, "seconds": time.time() - t0, "net": net.state_dict(),
                    "opt": opt.state_dict(), "sched": sched.state_dict(), "rng": rng.bit_generator.state,
                    "torch_rng": torch.get_rng_state()}, out / "checkpoint.tmp")
        (out / "checkpoint.tmp").replace(ckpt)
        if a.stop_after and ep + 1 == a.stop_after and ep + 1 < a.epochs:
            print(f"stopped after epoch {ep + 1}: go on with --resume", flush=True)
            return 0
    torch.save(net.state_dict(), out / "cnn_float.pt")
    return export(net, train, val, out)


def export(net, train, val, out, heat_p=0.3):
    """Quantise on 'fit' frames, compare the integer model with the float one on the eval
    frames, write OUT/cnn.npz."""
    net.eval()
    calib = [levels_of(seen(g))[k] for _, g, _ in train[::6] for k in LEVELS]
    z = quantise(fold(net), calib, heat_p=heat_p)
    z["cnn_heat_scale_q16"] = np.int32(max(1, round(float(z["cnn_out_scale"][0]) * 65536)))
    s_f, _ = evaluate(net, val, heat_p)
    s_q, _ = evaluate_int(z, val)
    print("float:    " + eb.format_scores(s_f).replace("\n", " | "))
    print("integer:  " + eb.format_scores(s_q).replace("\n", " | "))
    # the detection settings it is validated with (pyvehtrack.cnn.CFG_KEYS order): the levels
    # trained, the decoder cap, the NMS of nms() above; the ego-lane detector beside it
    z["cnn_cfg"] = np.array(cfg_row(), np.int32)
    z["cnn_detector_json"] = np.array(json.dumps({"sources": ["windows", "ego"]}))
    np.savez_compressed(out / "cnn.npz", **z)
    print(f"wrote {out / 'cnn.npz'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
