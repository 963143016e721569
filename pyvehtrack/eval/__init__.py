"""Evaluation, in one package: every score pyvehtrack reports is computed here.

    boxes     the one IoU (continuous [l, t, r, b] boxes; `from_inclusive` for the C core's)
    kitti     KITTI tracking labels: read into one structured array, write tracks
    tracking  HOTA / CLEAR (MOTA) / Identity (IDF1) through TrackEval (needs trackeval)
    lanes     the TuSimple lane metric
    synth     synthetic road sequences with exact ground truth
    sort      the SORT baseline tracker (filterpy + SciPy)

and the evaluations the README's figures come from, each with `main(argv)` (run them as
`python -m pyvehtrack.eval.NAME --help`, or through the thin tools/eval_*.py scripts):

    kitti_lead   lead-vehicle detection on the KITTI clip vs the lidar box
    kitti_track  lead-car tracking on the KITTI clip (id share, IoU, HOTA/MOTA/IDF1)
    synth_track  tracker vs SORT on the synthetic set (TrackEval)
    tusimple     the lane detector on TuSimple frames (TuSimple's rules)

Submodules load on first use (`from pyvehtrack.eval import tracking`), so importing the
package stays light. The CLI (`pyvehtrack eval`) and tools/eval_*.py call these; the old
paths pyvehtrack.evaluate, .eval_lanes, .synth and .reference.sort still import.
"""
from .boxes import from_inclusive, iou, iou_matrix  # noqa: F401

__all__ = ["boxes", "kitti", "tracking", "lanes", "synth", "sort", "kitti_lead", "kitti_track", "synth_track",
           "tusimple", "iou", "iou_matrix", "from_inclusive"]
