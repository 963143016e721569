"""The flow stage computes its level image only where it reads it (c/flow.c: the
lateral areas widened by twice the search range, each hand-over track's cells widened
by the search range + 1 px, recorded per level image in vt_flow_state.rect), with
vt_pyr_down_rect. What must hold, C vs the float oracle (pyvehtrack/reference/flow.py,
which computes whole level images and mirrors only the recorded rectangles' rules):

- nothing else is read: the state's level images are filled with random bytes before
  the first step, so a read of a pixel no step computed would show as a difference
  from the oracle (which has no such bytes);
- a hand-over track seeded without its frame (vt_flow_seed) follows, on its first
  step, only the cells whose block lies inside a recorded rectangle; seeded with it
  (vt_flow_seed_frame) it follows all of them, exactly as if whole level images had
  been computed (the behaviour before this change);
- a frame whose areas the previous level image did not cover (a cfg change that
  widened them) is a first frame again.

Tolerance 0 throughout, for the reasons tests/test_flow.py gives (exact integer SAD,
the same candidate order and ties, level images equal to the LSB)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native
from pyvehtrack import flow as F
from pyvehtrack.reference import flow as rflow

from test_flow import _hyps_c, _hyps_ref, _moving_scene, _ns, scenes

lib, ffi = _native.lib, _native.ffi


def _oracle(cfg):
    return rflow.FlowOracle(_ns(cfg), int(lib.VT_FLOW_MAX_HYPS), int(lib.VT_FLOW_MAX_SEEDS),
                            int(lib.VT_FLOW_MAX_BLOBS))


def _poisoned_state(seed: int):
    """A fresh vt_flow_state whose two level images and level-1 scratch hold random bytes.
    They sit right after next_id (include/vehtrack/flow.h: img[2][P], scratch[P], then gw);
    the layout is checked before writing."""
    st_ = _native.flow_new()
    p = int(lib.VT_FLOW_MAX_PIXELS)
    off = ffi.offsetof("vt_flow_state", "next_id") + 4
    assert 0 <= ffi.offsetof("vt_flow_state", "gw") - (off + 3 * p) < 4
    buf = ffi.buffer(st_)
    buf[off:off + 3 * p] = np.random.default_rng(seed).integers(0, 256, 3 * p, dtype=np.uint8).tobytes()
    return st_


@st.composite
def seeded_scenes(draw):
    frames, kw = draw(scenes())
    h, w = frames[0].shape
    seeds = []
    for _ in range(draw(st.integers(1, 2))):     # after frame 0, and maybe one more after frame 1
        l = draw(st.integers(-(w // 4), w - 1))
        r = draw(st.integers(max(l, 0), l + w))
        t = draw(st.integers(-(h // 4), h - 1))
        b = draw(st.integers(max(t, 0), t + h))
        seeds.append(((l, t, r, b), draw(st.booleans())))   # with the frame or without
    return frames, kw, seeds, draw(st.integers(0, 2**31))


@settings(max_examples=50, deadline=None)
@given(scene=seeded_scenes())
def test_seeded_anywhere_exact_on_poisoned_state(scene):
    frames, kw, seeds, poison = scene
    cfg = F.make_cfg(**kw)
    st_ = _poisoned_state(poison)
    ref = _oracle(cfg)
    for t, f in enumerate(frames):
        ready, hyps, stats = _native.flow_step(st_, cfg, f)
        r_ready, r_hyps = ref.step(np.ascontiguousarray(f))
        assert ready == r_ready == (t > 0)
        assert _hyps_c(hyps) == _hyps_ref(r_hyps), t
        for side in (0, 1):
            _, _, dx, dy, flag, sad = _native.flow_field(st_, side)
            ar = ref.areas[side] if ref.areas else None
            if ar is not None and ar.dx.size:
                np.testing.assert_array_equal(flag, ar.flag)
                np.testing.assert_array_equal(dx, ar.dx)
                np.testing.assert_array_equal(sad, ar.sad)
        if t < len(seeds):
            box, with_frame = seeds[t]
            if with_frame:
                tid = _native.flow_seed_frame(st_, cfg, f, box)
                assert tid == ref.seed(box, frame=np.ascontiguousarray(f))
            else:
                tid = _native.flow_seed(st_, cfg, box)
                assert tid == ref.seed(box)


def _overtaken_scene(n=6, h=64, w=128, seed=5):
    """A textured background drifting outward and a textured car in the MIDDLE of the
    frame, far from the left area (strip 30 %, rows 40..100 %), moving left 2 px/frame."""
    rng = np.random.default_rng(seed)
    from test_flow import _texture
    bg = _texture(rng, h, w + 4 * n, 1)
    car = _texture(rng, 20, 24, 1)
    frames = []
    for t in range(n):
        f = bg[:, 2 * t: 2 * t + w].copy()
        x = 80 - 2 * t
        f[6:26, x:x + 24] = car
        frames.append(f)
    return frames, (80, 6, 103, 25)


def test_seed_frame_matches_whole_images_and_plain_seed_skips(monkeypatch):
    frames, box = _overtaken_scene()
    cfg = F.make_cfg(level=1, cell=4, search_x=4, search_y=2, seed_min_visible_permille=100)
    # whole level images everywhere (the behaviour before this change): the oracle with
    # every block counted as computed
    full = _oracle(cfg)
    with monkeypatch.context() as m:
        m.setattr(rflow, "_inside", lambda r, rects: True)
        full.step(frames[0])
        full.seed(box)
        expect = [_hyps_ref(full.step(f)[1]) for f in frames[1:]]
    assert all([h[2] for h in e] == [2] for e in expect)        # followed every frame
    # vt_flow_seed_frame: the same, to the bit, on a poisoned state
    st_ = _poisoned_state(1)
    _native.flow_step(st_, cfg, frames[0])
    tid = _native.flow_seed_frame(st_, cfg, frames[0], box)
    got = [_hyps_c(_native.flow_step(st_, cfg, f)[1]) for f in frames[1:]]
    assert tid == 1 and got == expect
    # the friendly API passes the last frame on
    det = F.OvertakingDetector(level=1, cell=4, search_x=4, search_y=2, seed_min_visible_permille=100)
    det.step(frames[0])
    det.seed(box)
    assert [[(h.box, h.cells) for h in det.step(f).hyps] for f in frames[1:]] == \
        [[(h[0], h[4]) for h in e] for e in expect]
    # vt_flow_seed: the box lies outside every computed rectangle of frame 0's level
    # image, so no cell is followed on the first step and the track ends there, as the
    # oracle's rule says
    st_ = _poisoned_state(2)
    ref = _oracle(cfg)
    _native.flow_step(st_, cfg, frames[0])
    ref.step(frames[0])
    assert _native.flow_seed(st_, cfg, box) == ref.seed(box)
    for f in frames[1:]:
        _, hyps, _ = _native.flow_step(st_, cfg, f)
        c = _hyps_c(hyps)
        assert c == _hyps_ref(ref.step(f)[1]) and all(h[2] != 2 for h in c)
    # half inside the left area's rectangle: only the cells inside it count on the first
    # step (fewer than with the whole image), all of them from the second step on
    # level x 12..29, rows 20..31; the left area's rectangle is x 0..23 (4 cells of 4 px
    # + 2 x 4), rows 8..31: three of the four cell columns lie inside it
    ab = (24, 40, 59, 63)
    st_ = _poisoned_state(3)
    ref, whole = _oracle(cfg), _oracle(cfg)
    _native.flow_step(st_, cfg, frames[0])
    ref.step(frames[0])
    with monkeypatch.context() as m:
        m.setattr(rflow, "_inside", lambda r, rects: True)
        whole.step(frames[0])
        whole.seed(ab)
        w1 = _hyps_ref(whole.step(frames[1])[1])
    _native.flow_seed(st_, cfg, ab)
    ref.seed(ab)
    c1 = _hyps_c(_native.flow_step(st_, cfg, frames[1])[1])
    assert c1 == _hyps_ref(ref.step(frames[1])[1])
    c1h, w1h = [h for h in c1 if h[2] == 2], [h for h in w1 if h[2] == 2]
    assert len(c1h) == len(w1h) == 1 and 0 < c1h[0][4] < w1h[0][4], (c1h, w1h)
    c2 = _hyps_c(_native.flow_step(st_, cfg, frames[2])[1])
    assert c2 == _hyps_ref(ref.step(frames[2])[1])


def test_widened_areas_restart_narrowed_do_not():
    frames = _moving_scene(5)
    narrow, wide = F.make_cfg(strip_permille=200, cell=4), F.make_cfg(strip_permille=400, cell=4)
    st_ = _poisoned_state(4)
    ref = _oracle(narrow)
    seq = [(narrow, False), (narrow, True), (wide, False), (wide, True), (narrow, True)]
    for f, (cfg, ready) in zip(frames, seq):
        ref.cfg = _ns(cfg)
        r, hyps, _ = _native.flow_step(st_, cfg, f)
        r_ready, r_hyps = ref.step(f)
        assert r == r_ready == ready
        assert _hyps_c(hyps) == _hyps_ref(r_hyps)


def test_seed_frame_bad_inputs():
    cfg = F.make_cfg()
    st_ = _native.flow_new()
    f = np.zeros((40, 50), np.uint8)
    out = ffi.new("int32_t *")
    b = ffi.new("vt_box *")
    b.left, b.top, b.right, b.bottom = 1, 1, 9, 9
    v = _native.view(f, "f")
    assert lib.vt_flow_seed_frame(st_, cfg, v, b, out) == lib.VT_E_ARG       # no frame yet
    _native.flow_step(st_, cfg, f)
    assert lib.vt_flow_seed_frame(ffi.NULL, cfg, v, b, out) == lib.VT_E_ARG
    assert lib.vt_flow_seed_frame(st_, ffi.NULL, v, b, out) == lib.VT_E_ARG
    assert lib.vt_flow_seed_frame(st_, cfg, ffi.NULL, b, out) == lib.VT_E_ARG
    assert lib.vt_flow_seed_frame(st_, cfg, v, ffi.NULL, out) == lib.VT_E_ARG
    assert lib.vt_flow_seed_frame(st_, cfg, v, b, ffi.NULL) == lib.VT_E_ARG
    with pytest.raises(_native.VtError, match="vt_flow_seed_frame.*size"):
        _native.flow_seed_frame(st_, cfg, np.zeros((41, 50), np.uint8), (1, 1, 9, 9))
    with pytest.raises(_native.VtError, match="vt_flow_seed_frame"):
        _native.flow_seed_frame(st_, cfg, f, (60, 1, 70, 5))                   # outside the frame
    n = int(lib.VT_FLOW_MAX_SEEDS)
    assert len({_native.flow_seed_frame(st_, cfg, f, (1, 1, 9, 9)) for _ in range(n)}) == n
    with pytest.raises(_native.VtError, match="capacity"):
        _native.flow_seed_frame(st_, cfg, f, (1, 1, 9, 9))
    ref = _oracle(cfg)
    ref.step(f)
    with pytest.raises(ValueError, match="frame"):
        ref.seed((1, 1, 9, 9), frame=np.zeros((41, 50), np.uint8))


def test_rect_list_merges_past_capacity():
    """Seed, unseed and seed again between two steps: past VT_FLOW_MAX_RECTS rectangles
    the last one grows to cover the new one, in C as in the oracle, and the tracks still
    follow all their cells (the merged rectangle is computed from the frame too)."""
    frames, box = _overtaken_scene()
    cfg = F.make_cfg(level=1, cell=4, search_x=4, search_y=2, seed_min_visible_permille=100)
    st_ = _poisoned_state(5)
    ref = _oracle(cfg)
    _native.flow_step(st_, cfg, frames[0])
    ref.step(frames[0])
    boxes = [(8 + 9 * k, 2 + (k % 3) * 5, 30 + 9 * k, 24 + (k % 3) * 5) for k in range(12)]
    for k, bx in enumerate(boxes):
        tid = _native.flow_seed_frame(st_, cfg, frames[0], bx)
        assert tid == ref.seed(bx, frame=frames[0])
        if k < len(boxes) - int(lib.VT_FLOW_MAX_SEEDS):
            _native.flow_unseed(st_, tid)
            ref.unseed(tid)
    assert int(st_.n_rect[st_.prev_index]) == int(lib.VT_FLOW_MAX_RECTS) == ref.max_rects
    for f in frames[1:3]:
        _, hyps, _ = _native.flow_step(st_, cfg, f)
        assert _hyps_c(hyps) == _hyps_ref(ref.step(f)[1])


@pytest.mark.parametrize("cell,sx,sy", [(32, 32, 32), (32, 0, 32), (2, 32, 0), (17, 9, 5)])
def test_search_extremes_exact(cell, sx, sy):
    """vt__search's successive elimination (candidates whose block sum differs from the
    cell's by at least the best SAD so far are not matched) and its column-sum row at the
    largest cell and search ranges (96 columns) and degenerate ones: the same vectors and
    SADs as the oracle's exhaustive search, on textured frames moving 5 px right and 3 down
    with noise (so SADs are rarely 0 and the pruning has work to do)."""
    rng = np.random.default_rng(cell * 1000 + sx * 10 + sy)
    from test_flow import _texture
    h, w = (150, 170) if cell > 2 else (48, 90)      # 2 px cells: fewer of them (oracle time)
    bg = _texture(rng, h + 40, w + 40, 1)
    frames = []
    for t in range(2):
        f = bg[20 - 3 * t:20 - 3 * t + h, 20 - 5 * t:20 - 5 * t + w].astype(np.int16)
        frames.append(np.clip(f + rng.integers(-4, 5, f.shape), 0, 255).astype(np.uint8))
    cfg = F.make_cfg(level=0, sides="both", strip_permille=500 if cell > 2 else 150, top_permille=0, cell=cell,
                     search_x=sx, search_y=sy, diff_min_permille=0, min_texture=0, max_sad_per_px=255,
                     min_inward=0, max_mag=128, back_tol=1, min_blob_cells=1, min_age=1)
    st_ = _poisoned_state(cell)
    ref = _oracle(cfg)
    for f in frames:
        _, hyps, stats = _native.flow_step(st_, cfg, f)
        _, r_hyps = ref.step(f)
    assert stats["cells_computed"] > 0
    for side in (0, 1):
        _, _, dx, dy, flag, sad = _native.flow_field(st_, side)
        ar = ref.areas[side]
        np.testing.assert_array_equal(flag, ar.flag)
        np.testing.assert_array_equal(dx, ar.dx)
        np.testing.assert_array_equal(dy, ar.dy)
        np.testing.assert_array_equal(sad, ar.sad)
    assert _hyps_c(hyps) == _hyps_ref(r_hyps)
