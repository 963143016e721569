"""Float reference for vehicle detection in one frame (thesis sec. 2.4.2), twin of
c/detect.c: shadow hypotheses (reference.shadow), then their verification by vertical
edges (reference.verify).

With ShadowConfig.reduce_verified = 0 (the thesis) the shadow stage reduces its edges
to one per vehicle -- walking bottom-up, a kept edge suppresses the edges above it
within a vehicle height -- and the kept edges are verified.

With reduce_verified = 1 (issue 8 item 5, not in the thesis) the two steps are
interleaved: the edges are walked bottom-up, each one not suppressed by a VERIFIED edge
below it becomes a hypothesis and is verified at once, and only one that passes
suppresses the edges above it. Why: a codec (mp4v, H.264, JPEG) hardens the soft lower
border of a shadow into a step below the car; under the thesis's rule that false edge
wins, hides the car's own shadow edge above it, and then fails verification, so the
car is lost. Hypotheses past max_hyp are not verified (so they suppress nothing) and
are counted in n_dropped.

Only integer comparisons, as in the two stages: C and this oracle agree exactly.
"""
from __future__ import annotations

import numpy as np

from . import shadow as rshadow
from . import verify as rverify


def detect(gray: np.ndarray, road, scfg: rshadow.ShadowConfig = rshadow.ShadowConfig(),
           vcfg: rverify.VerifyConfig = rverify.VerifyConfig(), *, max_active: int = 64,
           max_cand: int = 64, max_hyp: int = 32, max_boxes: int = 32):
    """(ShadowResult whose `hypotheses` are the hypotheses examined, boxes (N, 4) int
    [left, top, right, bottom]). Capacities mirror VT_MAX_SHADOW_ACTIVE,
    VT_MAX_SHADOW_CAND, VT_MAX_HYPOTHESES and VT_MAX_BOXES."""
    gray = np.asarray(gray, np.uint8)
    if not scfg.reduce_verified:
        res = rshadow.find_hypotheses(gray, road, scfg, max_active=max_active, max_cand=max_cand,
                                      max_out=max_hyp)
        return res, rverify.verify(gray, res.hypotheses, vcfg, max_out=max_boxes)
    res = rshadow.find_hypotheses(gray, road, scfg, max_active=max_active, max_cand=max_cand,
                                  max_out=max_cand)
    sx_abs = rverify.vertical_edges(gray, vcfg.vedge_reach) if len(res.hypotheses) else None
    hyps, ok, boxes = [], [], []
    for c in (tuple(int(v) for v in h) for h in res.hypotheses):
        if any(o and rshadow.suppresses(scfg, k, c) for k, o in zip(hyps, ok)):
            continue
        if len(hyps) >= max_hyp:
            res.n_dropped += 1
            continue
        box = rverify.verify_one(gray, c, vcfg, sx_abs)
        hyps.append(c)
        ok.append(box is not None)
        if box is not None and len(boxes) < max_boxes:
            boxes.append(box)
    res.hypotheses = np.array(hyps, np.int64).reshape(-1, 3)
    return res, np.array(boxes, np.int64).reshape(-1, 4)


__all__ = ["detect"]
