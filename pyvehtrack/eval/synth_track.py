"""Tracker vs the SORT baseline on the synthetic set, scored with TrackEval (HOTA, MOTA, IDF1).

    python tools/eval_synth_track.py [--n 5] [--seed 0] [--size 640x480] [--frames N] [--json OUT]
                                     [--measurement roi|edges|roi+edges|both|all]
                                     [--codec none|mp4v|h264]

Both trackers are fed the same detections, from two sources:
  - "gt-noisy": GT boxes with 2 px noise per edge and 10% dropped (pyvehtrack.synth.gt_detections),
    isolating the trackers from the detector;
  - "detector": pyvehtrack's own Detector (C engine) run on the frames.
Rows per source:
  - SORT:        filterpy SORT (max_age 1, min_hits 3) on the detections of every frame;
  - ours/1:      the tracker (C engine) given the detections of every frame;
  - ours/10:     the tracker given detections only every 10th frame (the thesis's design), ROI search
                 in between -- the detections of the other 9 frames are not used;
  - ours/10 edges: the same with the edge-curve measurement (GIST paper) in place of the ROI
                 search (rows present with --measurement edges|both|all).
  - ours/10 roi+edges: the ROI search with the edge curves where it fails on a confirmed
                 track it measured before (rows present with --measurement roi+edges|all).
--codec: every sequence is first written as one video and decoded again (mp4v: OpenCV's MPEG-4
part 2 at default quality; h264: libx264 CRF 23, pyvehtrack.eval.conditions.through_h264), as a
dashcam recording would deliver it; the detector and the trackers see the decoded frames, the GT
is the scene's.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from . import synth
from . import tracking as ev
from .sort import run_sort


class _Coded:
    """A sequence whose frames went through a codec: the decoded frames, everything else the scene's."""

    def __init__(self, seq, frames):
        self._seq, self.frames = seq, frames

    def __getattr__(self, name):
        return getattr(self._seq, name)


def through_codec(seq, codec: str):
    """seq with its frames encoded by `codec` ('mp4v' or 'h264') and decoded again (gray in, gray out)."""
    from .conditions import through_codec as coded_frames  # noqa: PLC0415
    coded = coded_frames(enumerate(seq.frames), codec, fps=seq.fps)
    if coded is None or len(coded) != seq.n_frames:
        raise RuntimeError(f"{seq.name}: the {codec} video lost frames")
    return _Coded(seq, [np.ascontiguousarray(f) for _, f in coded])


def run_ours(seq, dets, every: int, engine: str = "c", measurement: str = "roi"):
    from ..tracker import Tracker
    trk = Tracker(engine=engine, detect_every=every, measurement=measurement)
    out = []
    for t in range(seq.n_frames):
        d = np.asarray(dets[t])[:, :4] if t % every == 0 else None
        ts = trk.step(seq.frames[t], detections=d)
        out.append([(x.id, *x.box, 1.0) for x in ts if x.state != "tentative"])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--frames", type=int, default=None, help="frames per sequence (default: the scenario's)")
    ap.add_argument("--preproc", choices=("kitti", "none"), default="kitti")
    ap.add_argument("--measurement", choices=("roi", "edges", "roi+edges", "both", "all"), default="roi",
                    help="both: roi and edges; all: the three")
    ap.add_argument("--codec", choices=("none", "mp4v", "h264"), default="none",
                    help="run on the frames written as one video and decoded (default none)")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    w, h = (int(v) for v in a.size.lower().split("x"))
    seqs = synth.make_set(a.n, a.seed, camera=synth.Camera(w, h), n_frames=a.frames)
    from ..detector import Detector
    rows: dict[str, list] = {}
    for seq in tqdm(seqs, desc="sequences", unit="seq", file=sys.stderr):
        if a.codec != "none":
            seq = through_codec(seq, a.codec)
        det = Detector(engine="c")
        sources = {
            "gt-noisy": synth.gt_detections(seq, sigma=2.0, p_drop=0.10, seed=a.seed),
            "detector": [_det_boxes(det, seq.frames[t]) for t in range(seq.n_frames)],
        }
        for src, dets in sources.items():
            runs = []
            if a.measurement in ("roi", "both", "all"):
                runs += [("SORT", lambda: run_sort(dets)), ("ours/1", lambda: run_ours(seq, dets, 1)),
                         ("ours/10", lambda: run_ours(seq, dets, 10))]
            if a.measurement in ("edges", "both", "all"):
                runs += [("ours/1 edges", lambda: run_ours(seq, dets, 1, measurement="edges")),
                         ("ours/10 edges", lambda: run_ours(seq, dets, 10, measurement="edges"))]
            if a.measurement in ("roi+edges", "all"):
                runs += [("ours/1 roi+edges", lambda: run_ours(seq, dets, 1, measurement="roi+edges")),
                         ("ours/10 roi+edges", lambda: run_ours(seq, dets, 10, measurement="roi+edges"))]
            for name, fn in runs:
                rows.setdefault(f"{src:9} {name}", []).append((seq, fn(), seq.n_frames))
    results = {k: ev.evaluate_many(v, preproc=a.preproc) for k, v in rows.items()}
    print(ev.format_results(results, names=("HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDSW", "FN", "FP")))
    if a.json:
        a.json.write_text(json.dumps({k: {m: float(x) for m, x in r.items() if np.isscalar(x)}
                                      for k, r in results.items()}, indent=2) + "\n")
    return 0


def _det_boxes(det, frame) -> np.ndarray:
    b = np.asarray(det.detect(frame).boxes, float).reshape(-1, 4)
    return np.column_stack([b, np.ones(len(b))])


if __name__ == "__main__":
    sys.exit(main())
