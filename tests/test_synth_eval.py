"""Synthetic sequences (pyvehtrack.synth), TrackEval scoring (pyvehtrack.evaluate) and the SORT
baseline (pyvehtrack.reference.sort).

The generator's ground truth is analytic; these tests check it against what is drawn (a pixel belongs
to a vehicle when its centre lies in the vehicle's half-open rectangle and in no nearer one), check
determinism, and check that TrackEval, fed through evaluate.py, gives the counts CLEAR defines for
known perturbations."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyvehtrack import evaluate as ev
from pyvehtrack import synth
from pyvehtrack.reference.sort import Sort, iou_matrix, run_sort, write_tracks_kitti

SMALL = synth.Camera(320, 240)          # a quarter of the pixels: same geometry, faster tests


@pytest.fixture(scope="module")
def seqs():
    return {name: synth.make_sequence(name, 3, camera=SMALL) for name in synth.SCENARIOS}


# ---------------------------------------------------------------------------------------------------------
# geometry core

def _raster_area(rect, others, step=0.25):
    """Area of rect minus others by counting cell centres on a grid of `step` (exact for rectangles
    whose sides lie on the grid)."""
    l, t, r, b = rect
    xs = np.arange(l + step / 2, r, step)
    ys = np.arange(t + step / 2, b, step)
    X, Y = np.meshgrid(xs, ys)
    free = np.ones_like(X, bool)
    for o in others:
        free &= ~((X >= o[0]) & (X < o[2]) & (Y >= o[1]) & (Y < o[3]))
    if not free.any():
        return 0.0, None
    return free.sum() * step * step, (X[free].min() - step / 2, Y[free].min() - step / 2,
                                      X[free].max() + step / 2, Y[free].max() + step / 2)


_q = st.integers(0, 40).map(lambda v: v * 0.25)


@st.composite
def _rect(draw):
    x0, y0 = draw(_q), draw(_q)
    return (x0, y0, x0 + 0.25 * draw(st.integers(1, 24)), y0 + 0.25 * draw(st.integers(1, 24)))


@settings(max_examples=150)
@given(_rect(), st.lists(_rect(), max_size=4))
def test_rect_minus_rects_exact(rect, others):
    # Sides on a 0.25 grid make the raster count exact, so area and box must agree to rounding.
    area, box = synth._rect_minus_rects(rect, others)
    ref_area, ref_box = _raster_area(rect, others)
    assert area == pytest.approx(ref_area, abs=1e-9)
    if ref_box is None:
        assert box is None
    else:
        assert np.allclose(box, ref_box, atol=1e-9)


# ---------------------------------------------------------------------------------------------------------
# generator ground truth

def test_gt_boxes_bound_drawn_pixels(seqs):
    checked_occ = 0
    for seq in seqs.values():
        W, H = seq.camera.width, seq.camera.height
        for t in range(0, seq.n_frames, 9):
            lab = seq.label_map(t)
            g = seq.gt_frame(t)
            drawn = set(np.unique(lab)) - {-1}
            assert drawn <= set(g["id"].tolist()), "a drawn vehicle has no GT row"
            for row in g:
                ys, xs = np.nonzero(lab == row["id"])
                l, tp, r, b = row["left"], row["top"], row["right"], row["bottom"]
                assert 0 <= l < r <= W - 1 and 0 <= tp < b <= H - 1
                if len(xs) == 0:
                    continue                    # a sliver thinner than a pixel: no centre inside
                # every drawn pixel centre is inside the box
                assert xs.min() >= l and xs.max() <= r and ys.min() >= tp and ys.max() <= b
                full = (row["full_left"], row["full_top"], row["full_right"], row["full_bottom"])
                clip = (max(full[0], 0), max(full[1], 0), min(full[2], W - 1), min(full[3], H - 1))
                clip_area = (clip[2] - clip[0]) * (clip[3] - clip[1])
                vis_area = (1 - row["occlusion"]) * clip_area
                # centres in a union of rectangles miss or gain at most about one pixel per unit of perimeter
                per = 2 * ((r - l) + (b - tp)) + 4
                assert abs(len(xs) - vis_area) <= per
                if row["occlusion"] == 0:
                    # a plain (clipped) rectangle: the drawn extremes are within 1 px of its sides
                    assert xs.min() - l < 1 and r - xs.max() <= 1 and ys.min() - tp < 1 and b - ys.max() <= 1
                elif row["occlusion"] * clip_area > per:
                    # visibly occluded: fewer pixels drawn than the clipped rectangle holds
                    checked_occ += 1
                    assert len(xs) < (math.floor(clip[2]) - math.ceil(clip[0]) + 1) * \
                        (math.floor(clip[3]) - math.ceil(clip[1]) + 1)
    assert checked_occ > 0


def test_occlusion_scenario_hides_and_uncovers(seqs):
    seq = seqs["occlusion"]
    far = seq.vehicles[1]
    present = [t for t in range(seq.n_frames) if far.vid in seq.gt_frame(t)["id"]]
    missing = sorted(set(range(seq.n_frames)) - set(present))
    assert missing, "the far car is never fully hidden"
    assert min(present) < min(missing) and max(present) > max(missing), "it must be seen before and after"
    levels = set(seq.gt[seq.gt["id"] == far.vid]["occ_level"].tolist())
    assert {0, 1, 2, 3} <= levels
    g = seq.gt[seq.gt["id"] == far.vid]
    assert np.all((g["occ_level"] > 0) == (g["occlusion"] > 0))
    for t in missing:                     # hidden, but still in the world and inside the image
        assert np.isfinite(far.z[t])


def test_overtake_enters_truncated(seqs):
    seq = seqs["overtake"]
    g = seq.gt[seq.gt["id"] == 1]
    first = g[g["frame"] == g["frame"].min()][0]
    assert first["trunc_level"] >= 1 and first["left"] == 0.0
    assert (g["trunc_level"] == 0).any()


def test_shadow_and_side_cues():
    # What the thesis detector needs (sec. 2.4.2): the band just above the bottom edge is much darker
    # than the road just below it, and the body differs from its surroundings at the left and right
    # sides. Measured minima over 4 seeds x 5 scenarios: 65 grey levels and 33; asserted with margin.
    seq = synth.make_sequence("traffic", 1)
    n = 0
    for t in range(0, seq.n_frames, 30):
        im = seq.frame(t).astype(np.float64)
        for g in seq.gt_frame(t):
            if g["occlusion"] > 0 or g["truncation"] > 0:
                continue
            l, tp, r, b = g["left"], g["top"], g["right"], g["bottom"]
            w = r - l
            c0, c1 = math.ceil(l + 0.3 * w), math.floor(r - 0.3 * w)
            jb = math.ceil(b) - 1                 # last row drawn
            assert im[jb + 2, c0:c1 + 1].mean() - im[jb - 1, c0:c1 + 1].mean() >= 40
            j0 = math.ceil(tp)
            il, ir = math.ceil(l), math.ceil(r) - 1
            side = 0.5 * (np.abs(im[j0:jb, il + 1] - im[j0:jb, il - 2]).mean()
                          + np.abs(im[j0:jb, ir - 1] - im[j0:jb, ir + 2]).mean())
            assert side >= 20
            n += 1
    assert n >= 10


def test_deterministic_by_seed():
    a = synth.make_sequence("lane_change", 11, camera=SMALL, n_frames=40)
    b = synth.make_sequence("lane_change", 11, camera=SMALL, n_frames=40)
    c = synth.make_sequence("lane_change", 12, camera=SMALL, n_frames=40)
    assert np.array_equal(a.gt, b.gt)
    assert len(a.gt) != len(c.gt) or not np.array_equal(a.gt["left"], c.gt["left"])
    f5 = a.frame(5)
    assert np.array_equal(b.frame(30), a.frame(30)) and np.array_equal(b.frame(5), f5)
    assert not np.array_equal(c.frame(5), f5)
    assert np.array_equal(np.asarray(a.frames)[5], f5) and len(a.frames) == 40
    s1, s2 = synth.make_set(3, seed=7, camera=SMALL), synth.make_set(3, seed=7, camera=SMALL)
    assert [s.name for s in s1] == [s.name for s in s2]
    assert all(np.array_equal(x.gt, y.gt) for x, y in zip(s1, s2))
    assert len({s.name.split("_")[0] for s in s1}) == 3


def test_bad_arguments():
    with pytest.raises(ValueError):
        synth.make_sequence("nope")
    with pytest.raises(ValueError):
        synth.make_sequence("follow", n_frames=0)
    with pytest.raises(ValueError):
        synth.make_sequence("follow", seed=-1)
    with pytest.raises(ValueError):
        synth.Camera(8, 8)
    with pytest.raises(IndexError):
        synth.make_sequence("follow", camera=SMALL, n_frames=3).frame(3)


def test_write_kitti_roundtrip(tmp_path):
    import cv2
    seq = synth.make_sequence("occlusion", 4, camera=SMALL, n_frames=12)
    paths = synth.write_kitti(seq, tmp_path / "s")
    names = sorted(p.name for p in (tmp_path / "s" / "frames").iterdir())
    assert names == [f"{t:06d}.png" for t in range(12)]
    assert np.array_equal(cv2.imread(str(tmp_path / "s" / "frames" / "000007.png"), cv2.IMREAD_UNCHANGED),
                          seq.frame(7))
    lines = open(paths["gt"]).read().splitlines()
    assert len(lines) == len(seq.gt) and all(len(ln.split()) == 17 for ln in lines)
    lab = ev.read_kitti(paths["gt"])
    assert np.array_equal(lab["frame"], seq.gt["frame"]) and np.array_equal(lab["id"], seq.gt["id"])
    assert np.array_equal(lab["occluded"], seq.gt["occ_level"])
    for k in ("left", "top", "right", "bottom"):
        assert np.allclose(lab[k], seq.gt[k], atol=1e-6)


def test_gt_detections():
    seq = synth.make_sequence("follow", 2, camera=SMALL, n_frames=20)
    dets = synth.gt_detections(seq)
    for t, d in enumerate(dets):
        ref = seq.boxes(t)
        assert d.shape == (len(ref), 5)
        assert np.allclose(np.sort(d[:, :4], axis=0), np.sort(ref, axis=0))
    assert all(len(d) == 0 for d in synth.gt_detections(seq, p_drop=1.0))


# ---------------------------------------------------------------------------------------------------------
# TrackEval through evaluate.py

def _gt_tracks(seq):
    """The GT as tracker output (per frame (id, l, t, r, b, score))."""
    return [[(int(g["id"]), g["left"], g["top"], g["right"], g["bottom"], 1.0) for g in seq.gt_frame(t)]
            for t in range(seq.n_frames)]


@pytest.mark.parametrize("preproc", ["kitti", "none"])
def test_gt_against_itself(seqs, preproc):
    seq = seqs["occlusion"]
    r = ev.evaluate_kitti(seq, _gt_tracks(seq), preproc=preproc)
    for k in ("HOTA", "DetA", "AssA", "MOTA", "MOTP", "IDF1"):
        assert r[k] == pytest.approx(1.0, abs=1e-12), k
    assert r["IDSW"] == 0 and r["FN"] == 0 and r["FP"] == 0
    # 'kitti' leaves out GT at occlusion level 3 (TrackEval's max_occlusion = 2); 'none' counts every row
    n3 = int(((seq.gt["occ_level"] > 2) | (seq.gt["trunc_level"] > 0)).sum())
    assert r["num_gt_dets"] == len(seq.gt) - (n3 if preproc == "kitti" else 0)


def _swap_frame(seq, a, b):
    """A frame t where vehicles a and b are both evaluated (levels 0-2, not truncated) at t-1, t, t+1
    and their boxes do not overlap, so a swapped pair cannot be matched to its own GT."""
    ok = (seq.gt["occ_level"] <= 2) & (seq.gt["trunc_level"] == 0)
    have = {}
    for g in seq.gt[ok]:
        have.setdefault(int(g["frame"]), {})[int(g["id"])] = g
    for t in sorted(have):
        if all(x in have.get(s, {}) for s in (t - 1, t, t + 1) for x in (a, b)):
            ga, gb = have[t][a], have[t][b]
            boxes = [[g["left"], g["top"], g["right"], g["bottom"]] for g in (ga, gb)]
            if iou_matrix(boxes[:1], boxes[1:])[0, 0] == 0 and t > 10:
                return t
    raise AssertionError("no frame to swap")


def test_perturbed_copy_counts(seqs):
    seq = seqs["follow"]
    ref = ev.evaluate_kitti(seq, _gt_tracks(seq))
    n = ref["num_gt_dets"]
    t_sw = _swap_frame(seq, 0, 1)
    swapped = _gt_tracks(seq)
    swapped[t_sw] = [((1 - tr[0]) if tr[0] in (0, 1) else tr[0], *tr[1:]) for tr in swapped[t_sw]]
    r = ev.evaluate_kitti(seq, swapped)
    # CLEAR: at t_sw each GT is matched to the other id (IDSW x2), at t_sw + 1 back to its own (x2).
    assert (r["IDSW"], r["FN"], r["FP"]) == (4, 0, 0)
    assert r["MOTA"] == pytest.approx(1 - 4 / n)
    assert r["DetA"] == pytest.approx(1.0) and r["AssA"] < 1.0 and r["HOTA"] < 1.0 and r["IDF1"] < 1.0

    dropped = _gt_tracks(seq)
    t_dr = t_sw + 20
    dropped[t_dr] = [tr for tr in dropped[t_dr] if tr[0] != 0]
    r = ev.evaluate_kitti(seq, dropped)
    # one missing box: one FN, no switch (the id continues after the gap), one fragmentation more
    assert (r["IDSW"], r["FN"], r["FP"]) == (0, 1, 0)
    assert r["Frag"] == ref["Frag"] + 1
    assert r["MOTA"] == pytest.approx(1 - 1 / n)
    assert r["DetA"] < 1.0 and r["HOTA"] < 1.0 and r["IDF1"] < 1.0

    both = [list(x) for x in swapped]
    both[t_dr] = dropped[t_dr]
    r = ev.evaluate_kitti(seq, both)
    assert (r["IDSW"], r["FN"], r["FP"]) == (4, 1, 0)
    assert r["MOTA"] == pytest.approx(1 - 5 / n)

    extra = _gt_tracks(seq)
    extra[5] = extra[5] + [(99, 10.0, 150.0, 60.0, 200.0, 0.5)]     # 50 px high, on nothing: one FP
    r = ev.evaluate_kitti(seq, extra)
    assert (r["IDSW"], r["FN"], r["FP"]) == (0, 0, 1)


def test_kitti_preprocessing_is_trackevals():
    # 2 frames; GT: car 0 (visible), car 1 truncated, a DontCare region; tracker: both cars, a box in
    # the DontCare region, and a 20 px high box on nothing.
    gt = np.zeros(4, ev.LABEL_DTYPE)
    gt[:] = [(0, 0, "Car", 0, 0, 100, 100, 160, 150, np.nan), (0, 1, "Car", 1, 0, 0, 100, 40, 150, np.nan),
             (0, -1, "DontCare", -1, -1, 200, 50, 300, 150, np.nan), (1, 0, "Car", 0, 0, 102, 100, 162, 150, np.nan)]
    tr = [[(7, 100, 100, 160, 150), (8, 0, 100, 40, 150), (9, 210, 60, 290, 140), (10, 400, 10, 440, 30)],
          [(7, 102, 100, 162, 150)]]
    r = ev.evaluate_kitti(gt, tr, preproc="kitti")
    assert (r["TP"], r["FN"], r["FP"], r["num_gt_dets"]) == (2, 0, 0, 2)
    r = ev.evaluate_kitti(gt, tr, preproc="none")
    assert (r["TP"], r["FN"], r["FP"], r["num_gt_dets"]) == (3, 0, 2, 3)


def test_input_forms_agree(tmp_path, seqs):
    seq = seqs["lane_change"]
    dets = synth.gt_detections(seq, sigma=1.0, p_drop=0.05, seed=3)
    tracks = run_sort(dets)
    write_tracks_kitti(tracks, tmp_path / "t.txt")
    synth.write_kitti(seq, tmp_path, frames=False)
    mem = ev.evaluate_kitti(seq, tracks)
    files = ev.evaluate_kitti(tmp_path / "gt.txt", tmp_path / "t.txt", num_frames=seq.n_frames)
    arr = np.array([(t, *tr) for t, fr in enumerate(tracks) for tr in fr])
    numeric = ev.evaluate_kitti(seq.gt, arr)
    for k in ("IDSW", "FN", "FP", "TP"):
        assert mem[k] == files[k] == numeric[k]
    # files hold boxes to 1e-3 px: HOTA moves by far less than 1e-3
    assert abs(mem["HOTA"] - files["HOTA"]) < 1e-3 and mem["HOTA"] == numeric["HOTA"]
    many = ev.evaluate_many([(seq, tracks), (seq, tracks)], per_sequence=True)
    assert many["num_gt_dets"] == 2 * mem["num_gt_dets"] and many["IDSW"] == 2 * mem["IDSW"]
    assert many["HOTA"] == pytest.approx(mem["HOTA"]) and len(many["sequences"]) == 2
    assert "HOTA" in ev.format_results({"sort": many})


def test_eval_bad_input(tmp_path):
    p = tmp_path / "bad.txt"
    p.write_text("0 1 Car 0 0\n")
    with pytest.raises(ValueError):
        ev.read_kitti(p)
    with pytest.raises(ValueError):
        ev.evaluate_kitti(np.zeros((3, 4)), [])
    with pytest.raises(ValueError):      # the same id twice in one frame
        ev.evaluate_kitti([[(1, 0, 0, 10, 10)]], [[(1, 0, 0, 10, 10), (1, 20, 0, 30, 10)]], preproc="none")
    with pytest.raises(TypeError):
        ev.evaluate_kitti(3.0, [])
    r = ev.evaluate_kitti([[(1, 0, 0, 10, 30)]], [[]], preproc="none")
    assert (r["FN"], r["FP"], r["HOTA"]) == (1, 0, 0.0)


# ---------------------------------------------------------------------------------------------------------
# SORT baseline

def test_sort_on_noisy_gt_boxes(seqs):
    # 1 px of noise on every edge barely moves IoU for boxes 12+ px wide; SORT's KF smooths it. HOTA
    # measured 0.92-0.94 at 320x240 over seeds 0-9 on these two scenarios (no full occlusion, where
    # SORT with max_age 1 must start a new id by design); 0.8 is the floor.
    for name in ("follow", "lane_change"):
        seq = seqs[name]
        r = ev.evaluate_kitti(seq, run_sort(synth.gt_detections(seq, sigma=1.0, seed=1)))
        assert r["HOTA"] > 0.8, (name, r["HOTA"])
        assert r["IDSW"] == 0


def test_sort_deterministic(seqs):
    seq = seqs["overtake"]
    dets = synth.gt_detections(seq, sigma=2.0, p_drop=0.1, p_false=0.2, seed=5)
    dets2 = synth.gt_detections(seq, sigma=2.0, p_drop=0.1, p_false=0.2, seed=5)
    assert all(np.array_equal(a, b) for a, b in zip(dets, dets2))
    a, b = run_sort(dets), run_sort(dets2)
    assert a == b
    assert any(len(f) for f in a)


def test_sort_lifecycle():
    s = Sort(max_age=1, min_hits=3)
    box = np.array([[100.0, 100.0, 150.0, 140.0]])
    outs = [s.update(box + [2.0 * t, 0, 2.0 * t, 0]) for t in range(6)]
    assert all(len(o) == 1 and o[0][0] == 1 for o in outs)
    assert s.update(np.zeros((0, 4))) == []                 # missed once: kept, not output
    assert s.update(np.zeros((0, 4))) == []                 # missed twice: deleted (max_age 1)
    new = [s.update(box) for _ in range(5)]
    assert new[-1][0][0] == 2                                # ids are never reused
    # a new track is output once it has min_hits = 3 matches after the detection that started it
    assert new[2] == [] and new[3] != []
    with pytest.raises(ValueError):
        s.update(np.zeros((2, 3)))
    with pytest.raises(ValueError):
        s.update(np.array([[0, 0, np.nan, 1]]))
