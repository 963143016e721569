"""Scoring tracks against labels with TrackEval (HOTA, CLEAR, Identity).

No metric is computed here: this module only builds the per-sequence data dict that TrackEval's metric
classes take (gt_ids, tracker_ids, similarity_scores as box IoU, num_* counts) and calls
`trackeval.metrics.HOTA / CLEAR / Identity.eval_sequence` on it. The KITTI benchmark's preprocessing
(Van boxes and GT boxes that are truncated or occluded beyond level 2 are distractors; DontCare regions
swallow unmatched tracker boxes; unmatched tracker boxes 25 px high or less are not counted) is
TrackEval's own `Kitti2DBox.get_preprocessed_seq_data`, run on data we load ourselves, so no TrackEval
folder layout (seqmaps, label_02/, trackers/<name>/data/) is needed.

Inputs are KITTI tracking label files or in-memory data:
  * a path to a KITTI tracking file (`frame id type truncated occluded alpha l t r b ... [score]`);
  * a `pyvehtrack.eval.synth.Sequence` or its GT structured array (fields frame, id, left, top, right, bottom
    and optionally trunc_level/occ_level);
  * tracks per frame: a list whose item t is a list of (id, left, top, right, bottom[, score]);
  * an (N, >= 6) numeric array with columns frame, id, left, top, right, bottom[, score].
"""
from __future__ import annotations

import os
from typing import Any, Iterable

import numpy as np

try:
    import trackeval
    from trackeval.datasets.kitti_2d_box import Kitti2DBox as _Kitti2DBox
except ImportError as exc:  # pragma: no cover - trackeval is a declared dependency
    raise ImportError("pyvehtrack.eval.tracking needs TrackEval: `make setup`, or "
                      "pip install --no-deps trackeval==1.3.0 pycocotools tabulate") from exc

__all__ = ["LABEL_DTYPE", "read_kitti", "to_labels", "evaluate_kitti", "evaluate_many", "format_results"]

# Label I/O lives in .kitti; re-exported here, where callers found it before.
from .kitti import LABEL_DTYPE, read_kitti, to_labels  # noqa: E402

# KITTI class names as TrackEval maps them; anything else is read but never evaluated.
_CLASS_IDS = {'car': 1, 'van': 2, 'truck': 3, 'pedestrian': 4, 'person': 5, 'cyclist': 6, 'tram': 7, 'misc': 8,
              'dontcare': 9, 'car_2': 1}

# Scalar summaries: TrackEval's HOTA family is an array over the 19 localisation thresholds
# alpha = 0.05..0.95; the benchmark figure is its mean, which is what we report.
_HOTA_ARRAYS = ['HOTA', 'DetA', 'AssA', 'DetRe', 'DetPr', 'AssRe', 'AssPr', 'LocA', 'OWTA']


# ---------------------------------------------------------------------------------------------------------
# TrackEval data

def _check_finite(lab: np.ndarray, what: str):
    box = np.stack([lab['left'], lab['top'], lab['right'], lab['bottom']], axis=1)
    if len(box) and not np.isfinite(box).all():
        raise ValueError(f"{what}: non-finite box coordinates")


def _dataset(preproc: str) -> _Kitti2DBox:
    """A Kitti2DBox that skips __init__ (which wants the benchmark's folder layout); only the fields
    get_preprocessed_seq_data reads are set. With preproc='none' every box counts: no distractors,
    no height limit (DontCare regions are dropped by the caller)."""
    ds = _Kitti2DBox.__new__(_Kitti2DBox)
    ds.class_name_to_class_id = dict(_CLASS_IDS)
    if preproc == 'kitti':
        ds.max_occlusion, ds.max_truncation, ds.min_height = 2, 0, 25
    elif preproc == 'none':
        ds.max_occlusion, ds.max_truncation, ds.min_height = np.inf, np.inf, -np.inf
    else:
        raise ValueError(f"preproc must be 'kitti' or 'none', got {preproc!r}")
    return ds


def _seq_data(gt: np.ndarray, tr: np.ndarray, num_frames: int, preproc: str, name: str) -> dict:
    ds = _dataset(preproc)
    gt_cls = np.array([_CLASS_IDS.get(c.lower(), 0) for c in gt['cls']], dtype=int)
    tr_cls = np.array([_CLASS_IDS.get(c.lower(), 0) for c in tr['cls']], dtype=int)
    is_dc = gt_cls == _CLASS_IDS['dontcare']
    if preproc == 'none':
        gt_cls = np.where(is_dc, gt_cls, _CLASS_IDS['car'])
        tr_cls[:] = _CLASS_IDS['car']
    gt_keep = ~is_dc & (gt['id'] >= 0)
    tr_keep = tr['id'] >= 0                      # TrackEval drops negative ids on load
    raw: dict[str, Any] = {k: [None] * num_frames for k in (
        'gt_ids', 'gt_classes', 'gt_dets', 'gt_extras', 'gt_crowd_ignore_regions',
        'tracker_ids', 'tracker_classes', 'tracker_dets', 'tracker_confidences', 'similarity_scores')}
    gf, tf = gt['frame'], tr['frame']
    for t in range(num_frames):
        g = gt_keep & (gf == t)
        d = tr_keep & (tf == t)
        gd = np.stack([gt['left'][g], gt['top'][g], gt['right'][g], gt['bottom'][g]], axis=1).reshape(-1, 4)
        td = np.stack([tr['left'][d], tr['top'][d], tr['right'][d], tr['bottom'][d]], axis=1).reshape(-1, 4)
        raw['gt_ids'][t] = gt['id'][g].astype(int)
        raw['gt_classes'][t] = gt_cls[g]
        raw['gt_dets'][t] = gd
        raw['gt_extras'][t] = {'truncation': gt['truncated'][g].astype(int),
                               'occlusion': gt['occluded'][g].astype(int)}
        ign = is_dc & (gf == t) if preproc == 'kitti' else np.zeros(len(gt), bool)
        raw['gt_crowd_ignore_regions'][t] = np.stack(
            [gt['left'][ign], gt['top'][ign], gt['right'][ign], gt['bottom'][ign]], axis=1).reshape(-1, 4)
        raw['tracker_ids'][t] = tr['id'][d].astype(int)
        raw['tracker_classes'][t] = tr_cls[d]
        raw['tracker_dets'][t] = td
        sc = tr['score'][d]
        raw['tracker_confidences'][t] = np.where(np.isfinite(sc), sc, 1.0)
        raw['similarity_scores'][t] = ds._calculate_similarities(gd, td)
    raw['num_timesteps'] = num_frames
    raw['seq'] = name
    try:
        return ds.get_preprocessed_seq_data(raw, 'car')
    except trackeval.utils.TrackEvalException as exc:
        raise ValueError(f"{name}: {exc}") from None


def _metrics(threshold: float):
    cfg = {'THRESHOLD': float(threshold), 'PRINT_CONFIG': False}
    return [trackeval.metrics.HOTA(), trackeval.metrics.CLEAR(cfg), trackeval.metrics.Identity(cfg)]


def _summarise(res: dict, data_counts: dict | None = None) -> dict:
    out: dict[str, Any] = {}
    for name, r in res.items():
        for k, v in r.items():
            if name == 'HOTA' and k in _HOTA_ARRAYS:
                out[k] = float(np.mean(v))
            elif name == 'HOTA' and k in ('HOTA_TP', 'HOTA_FN', 'HOTA_FP'):
                continue                       # per-alpha counts; see the arrays if needed
            elif isinstance(v, np.ndarray):
                continue
            elif k in _INT_FIELDS:
                out[k] = int(round(float(v)))
            else:
                out[k] = float(v)
    # short aliases for the usual table
    out['FN'], out['FP'], out['TP'] = out['CLR_FN'], out['CLR_FP'], out['CLR_TP']
    if data_counts:
        out.update(data_counts)
    return out


_INT_FIELDS = {'CLR_TP', 'CLR_FN', 'CLR_FP', 'IDSW', 'MT', 'PT', 'ML', 'Frag', 'CLR_Frames', 'IDTP', 'IDFN', 'IDFP'}


def _prepare(gt, tracks, num_frames, preproc, name):
    g = to_labels(gt)
    t = to_labels(tracks)
    _check_finite(g, 'gt')
    _check_finite(t, 'tracks')
    if num_frames is None:
        num_frames = int(max(g['frame'].max(initial=-1), t['frame'].max(initial=-1)) + 1)
        n_seq = getattr(gt, 'n_frames', None)
        if isinstance(n_seq, int):
            num_frames = max(num_frames, n_seq)
    num_frames = int(num_frames)
    if len(t) and t['frame'].max() >= num_frames:
        raise ValueError(f"tracks have frame {int(t['frame'].max())} >= num_frames {num_frames}")
    if len(g) and g['frame'].max() >= num_frames:
        raise ValueError(f"gt has frame {int(g['frame'].max())} >= num_frames {num_frames}")
    return _seq_data(g, t, max(num_frames, 0), preproc, name)


def _eval_data(data, threshold):
    res = {}
    for m in _metrics(threshold):
        res[m.get_name()] = m.eval_sequence(data)
    return res


def _counts(data) -> dict:
    return {'num_frames': int(data['num_timesteps']), 'num_gt_dets': int(data['num_gt_dets']),
            'num_tracker_dets': int(data['num_tracker_dets']), 'num_gt_ids': int(data['num_gt_ids']),
            'num_tracker_ids': int(data['num_tracker_ids'])}


def evaluate_kitti(gt_path, tracks_path, *, num_frames: int | None = None, preproc: str = 'kitti',
                   threshold: float = 0.5, name: str = 'seq') -> dict:
    """Score one sequence with TrackEval's HOTA, CLEAR and Identity metrics (class Car).

    gt_path / tracks_path: a KITTI file path or any in-memory form in the module doc. num_frames
    defaults to 1 + the last frame in either (or the Sequence's length). preproc='kitti' applies the
    KITTI benchmark rules via TrackEval's Kitti2DBox; 'none' counts every box. threshold is the IoU
    for a CLEAR/Identity match. Returns a flat dict: HOTA, DetA, AssA, DetRe, DetPr, AssRe, AssPr, LocA
    (means over TrackEval's 19 alphas), HOTA(0), MOTA, MOTP, MODA, IDSW, CLR_TP/FN/FP (also TP/FN/FP),
    MT, PT, ML, Frag, IDF1, IDR, IDP, IDTP, IDFN, IDFP, plus num_frames and num_* counts. Rates are
    in [0, 1], as TrackEval returns them."""
    data = _prepare(gt_path, tracks_path, num_frames, preproc, name)
    return _summarise(_eval_data(data, threshold), _counts(data))


def evaluate_many(pairs: Iterable, *, preproc: str = 'kitti', threshold: float = 0.5,
                  per_sequence: bool = False) -> dict:
    """Score several sequences and combine them as TrackEval does (sums of counts; HOTA's AssA etc.
    weighted by detections). `pairs` yields (gt, tracks) or (gt, tracks, num_frames). Returns the
    combined dict (as evaluate_kitti), with 'sequences' holding each one's dict when per_sequence."""
    per_res, per_out = {}, {}
    totals = {'num_frames': 0, 'num_gt_dets': 0, 'num_tracker_dets': 0, 'num_gt_ids': 0, 'num_tracker_ids': 0}
    for i, p in enumerate(pairs):
        gt, tr, *rest = p
        nf = rest[0] if rest else None
        name = getattr(gt, 'name', None) or f'seq{i:04d}'
        if name in per_res:
            name = f'{name}_{i}'
        data = _prepare(gt, tr, nf, preproc, name)
        per_res[name] = _eval_data(data, threshold)
        c = _counts(data)
        for k in totals:
            totals[k] += c[k]
        if per_sequence:
            per_out[name] = _summarise(per_res[name], c)
    if not per_res:
        raise ValueError("evaluate_many: no sequences")
    combined = {}
    for m in _metrics(threshold):
        combined[m.get_name()] = m.combine_sequences({k: v[m.get_name()] for k, v in per_res.items()})
    out = _summarise(combined, totals)
    if per_sequence:
        out['sequences'] = per_out
    return out


_TABLE = [('HOTA', '{:.2%}'), ('DetA', '{:.2%}'), ('AssA', '{:.2%}'), ('LocA', '{:.2%}'), ('MOTA', '{:.2%}'),
          ('MOTP', '{:.2%}'), ('IDF1', '{:.2%}'), ('IDSW', '{}'), ('FN', '{}'), ('FP', '{}'), ('Frag', '{}')]


def format_results(results: dict, names: Iterable[str] | None = None) -> str:
    """A two-line text table of the usual figures; `results` is one dict or {label: dict}."""
    if 'HOTA' in results:
        results = {'': results}
    cols = [c for c in _TABLE if names is None or c[0] in names]
    w = max([len(k) for k in results] + [4])
    lines = [' ' * w + ''.join(f'{c:>9}' for c, _ in cols)]
    for label, r in results.items():
        lines.append(f'{label:<{w}}' + ''.join(f'{fmt.format(r[c]):>9}' for c, fmt in cols))
    return '\n'.join(lines)
