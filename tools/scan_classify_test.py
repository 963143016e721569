#!/usr/bin/env python3
"""Count, on the 102 tusimple-vehicles-dev TEST frames, the background windows a HOG model scores >= 0 and the
vehicles >= 64 px wide that some window (IoU >= 0.5) scored >= 0, scanning every window position at scales
1, 0.75, 0.5, 0.35 with vt_hog_scan. A classifier figure, not the detector's (that is `pyvehtrack eval-boxes`).

    PYTHONPATH=. python3 tools/scan_classify_test.py     # default_hog vs hog_hardneg
"""
import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import numpy as np, cv2
from pathlib import Path
from pyvehtrack import train as T, _native as N
D = Path('/work/shared/data/tusimple-vehicles-dev')
ROOT = Path(__file__).resolve().parent.parent
models = {k: T.load_model(ROOT / 'tools' / 'models' / f'{k}.npz') for k in ['default_hog', 'hog_hardneg']}
cm = {k: T.c_model(d) for k, d in models.items()}
ws = N.hog_ws_new()
fp = {k: 0 for k in models}; hit = {k: 0 for k in models}; ngt = 0; nfr = 0
def iou(a, b):
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]) + 1); iy = max(0, min(a[3], b[3]) - max(a[1], b[1]) + 1)
    i = ix * iy; return i / ((a[2]-a[0]+1)*(a[3]-a[1]+1) + (b[2]-b[0]+1)*(b[3]-b[1]+1) - i)
for name, boxes in T.load_annotation(D / 'annotation.json'):
    if (T._last_number(name) // 10) % 5 != 0: continue
    nfr += 1
    img = T.read_gray(D / name); fh, fw = img.shape
    big = [b for b in boxes if b[2] - b[0] + 1 >= 64]; ngt += len(big)
    wins = {k: [] for k in models}
    for s in (1.0, 0.75, 0.5, 0.35):
        sw, sh = int(fw*s)//8*8, int(fh*s)//8*8
        im = np.ascontiguousarray(cv2.resize(img, (sw, sh), interpolation=cv2.INTER_AREA))
        for y0 in range(0, max(1, sh - 64 + 1), 128):
            band = im[y0:y0+192, :min(sw, 1280)]
            if band.shape[0] < 64: continue
            N.hog_prepare(ws, band)
            ncx, ncy = ws.cells_x - 7, ws.cells_y - 7
            for k in models:
                sc = N.hog_scan(ws, cm[k][0], 0, 0, ncx, ncy)
                for cy, cx in zip(*np.nonzero(sc >= 0)):
                    x0, yy = cx*8/s, (y0+cy*8)/s
                    wins[k].append((x0, yy, x0 + 64/s - 1, yy + 64/s - 1))
    for k in models:
        fp[k] += sum(T._overlap_frac(w, boxes) <= 0.1 for w in wins[k])
        hit[k] += sum(any(iou(w, b) >= 0.5 for w in wins[k]) for b in big)
for k in models:
    print(k, 'TEST frames', nfr, 'background windows scored >= 0 per frame %.1f' % (fp[k]/nfr), 'boxes >= 64 px with a window IoU>=0.5 scored >= 0: %d/%d' % (hit[k], ngt))
