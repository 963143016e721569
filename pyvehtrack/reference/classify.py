"""Float oracle of c/classify.c: HOG, GIST and the linear SVM decision.

Written from the papers with the well-kept libraries, never calling C:
  - HOG is skimage.feature.hog itself (9 bins, 8x8 cells, 2x2 blocks, L2-Hys),
    with feature_vector=False over a whole prepared image, so a window's
    descriptor is the slice of blocks it covers (as vt_hog_descriptor);
  - GIST (GIST paper sec. III, after Oliva & Torralba): 4 scales as the levels of
    a Gaussian pyramid (cv2.pyrDown), 8 orientations, each a complex Gabor filter
    built from cv2.getGaborKernel (gamma 1; psi 0 and -pi/2 are the real and
    imaginary parts), cv2.filter2D with BORDER_REFLECT_101; the energy re^2 + im^2
    is averaged over each 8x8 base cell, then over the 4x4 grid cells of a window;
    the feature is the RMS amplitude sqrt(mean energy), the 512-vector scaled to
    unit L2 norm. (Energy, not magnitude, is averaged so that the mean over a grid
    cell is the mean of its cells' means: the sliding-window design.)
  - the SVM decision is w . x + b in NumPy.
"""
from __future__ import annotations

import math

import cv2
import numpy as np
from skimage.feature import hog as _sk_hog

CELL = 8
HOG_BINS = 9
GIST_SCALES = 4
GIST_ORIENT = 8
GIST_GRID = 4
GIST_SIGMA = 2.0
GIST_LAMBDA = 4.0
GIST_KSIZE = 11


# ---------------------------------------------------------------- HOG
def hog_blocks(img: np.ndarray) -> np.ndarray:
    """Normalised blocks of a gray image: (cells_y - 1, cells_x - 1, 2, 2, 9), floats in [0, 1]."""
    img = np.asarray(img)
    return _sk_hog(img.astype(np.float64), orientations=HOG_BINS, pixels_per_cell=(CELL, CELL),
                   cells_per_block=(2, 2), block_norm="L2-Hys", feature_vector=False)


def hog_window(blocks: np.ndarray, cx: int, cy: int, win_w: int, win_h: int) -> np.ndarray:
    """The descriptor of the window at cell (cx, cy): the blocks it covers, in skimage's order."""
    nbx, nby = win_w // CELL - 1, win_h // CELL - 1
    return blocks[cy:cy + nby, cx:cx + nbx].ravel()


def hog(img: np.ndarray) -> np.ndarray:
    """The descriptor of a whole window-sized crop."""
    return hog_blocks(img).ravel()


def hog_dim(win_w: int, win_h: int) -> int:
    return (win_w // CELL - 1) * (win_h // CELL - 1) * 36


def hog_gradient_stats(img: np.ndarray):
    """Per cell and bin: the number of pixels with a nonzero gradient (skimage's
    gradient rule), and the exact sums of magnitudes; used by the tests to bound
    the C's rounding of magnitudes (<= 1/32 per pixel)."""
    g = np.asarray(img, np.float64)
    gy = np.zeros_like(g)
    gx = np.zeros_like(g)
    gy[1:-1, :] = g[2:, :] - g[:-2, :]
    gx[:, 1:-1] = g[:, 2:] - g[:, :-2]
    mag = np.hypot(gx, gy)
    ori = np.rad2deg(np.arctan2(gy, gx)) % 180
    b = np.minimum((ori // (180 / HOG_BINS)).astype(int), HOG_BINS - 1)
    cy, cx = g.shape[0] // CELL, g.shape[1] // CELL
    cnt = np.zeros((cy, cx, HOG_BINS))
    sm = np.zeros((cy, cx, HOG_BINS))
    for y in range(cy * CELL):
        for k in range(HOG_BINS):
            sel = (b[y, :cx * CELL] == k) & (mag[y, :cx * CELL] > 0)
            np.add.at(cnt[y // CELL, :, k], np.arange(cx * CELL)[sel] // CELL, 1)
            np.add.at(sm[y // CELL, :, k], np.arange(cx * CELL)[sel] // CELL, mag[y, :cx * CELL][sel])
    return cnt, sm


# ---------------------------------------------------------------- GIST
def gabor_pair(theta: float) -> tuple[np.ndarray, np.ndarray]:
    """Real and imaginary parts of the complex Gabor filter (cv2 kernels, float64)."""
    k = (GIST_KSIZE, GIST_KSIZE)
    re = cv2.getGaborKernel(k, GIST_SIGMA, theta, GIST_LAMBDA, 1.0, 0.0, ktype=cv2.CV_64F)
    im = cv2.getGaborKernel(k, GIST_SIGMA, theta, GIST_LAMBDA, 1.0, -math.pi / 2, ktype=cv2.CV_64F)
    return re, im


def gist_cells(img: np.ndarray) -> np.ndarray:
    """Mean Gabor energy per 8x8 base cell: (cells_y, cells_x, 32), filter index
    scale * 8 + orientation; scale s is filtered on pyramid level s."""
    lvl = np.asarray(img, np.uint8)
    cy, cx = lvl.shape[0] // CELL, lvl.shape[1] // CELL
    out = np.zeros((cy, cx, GIST_SCALES * GIST_ORIENT))
    for s in range(GIST_SCALES):
        if s > 0:
            lvl = cv2.pyrDown(lvl)
        cs = CELL >> s
        f = lvl.astype(np.float64)
        for o in range(GIST_ORIENT):
            re_k, im_k = gabor_pair(math.pi * o / GIST_ORIENT)
            re = cv2.filter2D(f, cv2.CV_64F, re_k, borderType=cv2.BORDER_REFLECT_101)
            im = cv2.filter2D(f, cv2.CV_64F, im_k, borderType=cv2.BORDER_REFLECT_101)
            e = (re ** 2 + im ** 2)[:cy * cs, :cx * cs]
            out[:, :, s * GIST_ORIENT + o] = e.reshape(cy, cs, cx, cs).mean(axis=(1, 3))
    return out


def gist_window(cells: np.ndarray, cx: int, cy: int, win_w: int, win_h: int) -> np.ndarray:
    """The 512-value GIST of the window at cell (cx, cy) (win_w, win_h multiples of 32)."""
    gw, gh = win_w // 32, win_h // 32
    c = cells[cy:cy + 4 * gh, cx:cx + 4 * gw]
    grid = c.reshape(4, gh, 4, gw, -1).mean(axis=(1, 3))  # (4, 4, 32)
    rms = np.sqrt(grid).ravel()
    n = np.linalg.norm(rms)
    return rms / n if n > 0 else rms


def gist(img: np.ndarray) -> np.ndarray:
    img = np.asarray(img)
    h, w = img.shape
    return gist_window(gist_cells(img), 0, 0, w // 32 * 32, h // 32 * 32)


# ---------------------------------------------------------------- common
def descriptor(kind: str, img: np.ndarray) -> np.ndarray:
    if kind == "hog":
        return hog(img)
    if kind == "gist":
        return gist(img)
    raise ValueError(f"kind: expected 'hog' or 'gist', got {kind!r}")


def resample_area(src: np.ndarray, box, out_w: int, out_h: int) -> np.ndarray:
    """Integer area means of src[top..bottom, left..right] onto out_h x out_w
    (the rule of vt_resample_area: each output pixel averages the source pixels
    [floor(i bw / ow), max(floor((i+1) bw / ow), that + 1)), rounded half up)."""
    left, top, right, bottom = (int(v) for v in box)
    bw, bh = right - left + 1, bottom - top + 1
    src = np.asarray(src, np.int64)
    out = np.zeros((out_h, out_w), np.uint8)
    x0 = [left + i * bw // out_w for i in range(out_w)]
    x1 = [max(left + (i + 1) * bw // out_w, x0[i] + 1) for i in range(out_w)]
    for j in range(out_h):
        y0 = top + j * bh // out_h
        y1 = max(top + (j + 1) * bh // out_h, y0 + 1)
        for i in range(out_w):
            a = src[y0:y1, x0[i]:x1[i]]
            n = a.size
            out[j, i] = (int(a.sum()) * 2 + n) // (2 * n)
    return out


def svm_decision(w: np.ndarray, b: float, x: np.ndarray) -> np.ndarray:
    """w . x + b for one descriptor or a stack of them (float)."""
    return np.asarray(x, np.float64) @ np.asarray(w, np.float64) + float(b)


def mlp_decision(w1: np.ndarray, b1: np.ndarray, w2: np.ndarray, b2: float, x: np.ndarray) -> np.ndarray:
    """One hidden ReLU layer and a linear output (the logit of sklearn's MLPClassifier):
    w2 . max(0, w1 x + b1) + b2, for one descriptor or a stack of them."""
    h = np.maximum(0.0, np.asarray(x, np.float64) @ np.asarray(w1, np.float64).T + np.asarray(b1, np.float64))
    return h @ np.asarray(w2, np.float64) + float(b2)
