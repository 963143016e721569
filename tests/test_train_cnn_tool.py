"""tools/train_cnn.py's frame preparation, the parts a model file depends on without torch:
the contrast stretch a network learns through (--stretch, written to the file's cnn_cfg so the
C core applies the same stretch) and the low-light augmentation (--low-light); and, where torch
and the training frames are at hand, that a run taken up with --resume ends where one never
stopped does."""
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pyvehtrack import cnn as C
from pyvehtrack.reference import cnn as rc

ROOT = Path(__file__).resolve().parent.parent
TOOL = ROOT / "tools" / "train_cnn.py"


@pytest.fixture()
def tool():
    spec = importlib.util.spec_from_file_location("train_cnn_under_test", TOOL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)      # no torch at import: torch is imported inside the functions
    return mod


def test_cfg_row_carries_the_stretch_the_network_learnt_through(tool):
    tool.L0_BAND, tool.STRETCH = None, 0
    assert len(tool.cfg_row()) == C.CFG_KEYS_OLD                     # as files before the band
    tool.STRETCH = 5
    row = tool.cfg_row()
    cfg = C.CnnConfig(*row)                                          # a row the loader takes
    assert (cfg.l0_top_permille, cfg.l0_bottom_permille, cfg.stretch_tail_permille) == (0, 1000, 5)
    tool.L0_BAND, tool.LEVELS = (380, 640), (0, 1, 2, 3, 4)
    cfg = C.CnnConfig(*tool.cfg_row())
    assert (cfg.first_level, cfg.n_levels, cfg.l0_top_permille, cfg.l0_bottom_permille,
            cfg.stretch_tail_permille) == (0, 5, 380, 640, 5)


def test_up_band_level_is_the_c_cores(tool):
    """--up-band: the file's cnn_cfg carries the rectangle (13 entries, the loader's order), and the
    level the network learns on is the 2x image vt_cnn_detect_frame runs (reference.cnn.level_inputs'
    last item, the same pixels and offset), boxes moved by its corner and doubled for targets."""
    tool.L0_BAND, tool.LEVELS, tool.STRETCH, tool.UP_BAND = (380, 640), (0, 1, 2, 3, 4, -1), 5, (450, 530, 350, 650)
    row = tool.cfg_row()
    assert len(row) == len(C.CFG_KEYS)
    cfg = C.CnnConfig(*row)
    cfg.c()                                                          # a row the core takes
    assert (cfg.first_level, cfg.n_levels, cfg.stretch_tail_permille) == (0, 5, 5)
    assert (cfg.up_top_permille, cfg.up_bottom_permille, cfg.up_left_permille, cfg.up_right_permille) == \
        (450, 530, 350, 650)
    g = np.random.default_rng(0).integers(0, 256, (90, 160)).astype(np.uint8)
    lv = tool.levels_of(g)
    # levels_of takes the frame after seen() (the stretch): compare with the detector's inputs unstretched
    k, dx, dy, want = list(rc.level_inputs(g, dict(zip(C.CFG_KEYS, row[:8] + [0] + row[9:]))))[-1]
    assert k == -1 and np.array_equal(lv[-1], want) and tool.level_offset(-1, 90, 160) == (dx, dy) == (56, 40)
    tool.UP_BAND, tool.LEVELS = None, (0, 1, 2, 3, 4)
    assert len(tool.cfg_row()) == 9 and -1 not in tool.levels_of(g)  # without it, the 9 entries of before


def test_training_stretch_is_the_c_cores(tool):
    # the tool's stretch is the NumPy twin, which equals vt_cnn's stretch bit for bit
    # (tests/test_cnn_frame.py); here: the tool takes exactly that function
    assert tool.ref_stretch is rc.stretch


def test_low_light_frames_are_dark_and_noisy(tool):
    # a flat 128 frame: the scale jitter pads with the frame's mean, so before the light it
    # stays flat. Low light: gain <= 0.6, gamma >= 0.6, offset <= 10, so every pixel's level
    # before the noise is <= 0.6 x 255 x (128 / 255)^0.6 + 10 = 111.2; the noise (mean 0,
    # sigma <= 4, clipped at 0 only far below) and a JPEG step move the mean by well under 1.
    img = np.full((72, 128), 128, np.uint8)
    boxes = np.zeros((0, 4), np.float32)
    stds = []
    for seed in range(12):
        out, _, _ = tool.augment(img, boxes, np.random.default_rng(seed), None, low_light=1.0)
        assert out.dtype == np.uint8 and out.shape == img.shape
        assert out.mean() < 112.2
        stds.append(out.std())
    assert max(stds) > 0.8                     # sigma >= 1 shows on some frame through the JPEG
    # without it the gain is >= 0.6, gamma <= 1.6, offset >= -30: >= 255 x 0.6 x 0.502^1.6 - 30 = 20.8,
    # and the same seeds give no noise on a flat frame but JPEG's (which keeps a flat block flat)
    for seed in range(12):
        out, _, _ = tool.augment(img, boxes, np.random.default_rng(seed), None, low_light=0.0)
        assert out.std() == 0.0


@pytest.mark.parametrize("args,msg", [(["--stretch", "500"], "--stretch"), (["--stretch", "-1"], "--stretch"),
                                      (["--stretch", "101"], "vt_cnn_cfg.stretch_tail_permille"),
                                      (["--low-light", "1.5"], "--low-light"),
                                      (["--codec", "-0.1"], "--codec"),
                                      (["--up-band", "500", "400", "0", "1000"], "--up-band"),
                                      (["--up-band", "0", "100", "700", "700"], "--up-band")])
def test_tool_rejects_bad_flags_without_torch_work(args, msg, tmp_path):
    p = subprocess.run([sys.executable, str(TOOL), "--out", str(tmp_path / "m")] + args,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and msg in p.stderr
    assert not (tmp_path / "m").exists()


def _run_tool(args, timeout=600):
    return subprocess.run([sys.executable, str(TOOL)] + args, capture_output=True, text=True, timeout=timeout)


_DATA = ROOT.parent / "shared" / "data" / "tusimple-vehicles-dev"
# training runs are the tool's, not the build's: the sanitizer and smallest-build suites
# (VT_SECONDARY_RUN=1) leave them out, as conftest's BUILD_INDEPENDENT modules (and the
# smallest build cannot take the 1280x720 frames the tool's export scores)
_training_run = pytest.mark.skipif(
    not _DATA.is_dir() or os.environ.get("VT_SECONDARY_RUN") == "1",
    reason="needs ../shared/data/tusimple-vehicles-dev; the first suite only")


@_training_run
def test_resume_ends_with_the_weights_of_a_run_never_stopped(tmp_path):
    """A run stopped after epoch 1 and taken up with --resume ends bit for bit where a run of
    both epochs ends: the checkpoint holds every state the loop reads (weights and BatchNorm
    statistics, AdamW's moments, the one-cycle schedule, numpy's and torch's generators)."""
    torch = pytest.importorskip("torch")
    base = ["--epochs", "2", "--limit", "3", "--batch", "2", "--channels", "4", "4", "4", "4", "4", "4",
            "--stretch", "5", "--seed", "3"]
    whole, part = tmp_path / "whole", tmp_path / "part"
    p = _run_tool(["--out", str(whole)] + base)
    assert p.returncode == 0, p.stderr
    # the same run stopped after its first epoch: its checkpoint is epoch 1's (the 1-epoch run's
    # schedule is another, so epoch 1 is made by the 2-epoch run with the loop cut short)
    p = _run_tool(["--out", str(part)] + base + ["--stop-after", "1"])
    assert p.returncode == 0, p.stderr
    assert torch.load(part / "checkpoint.pt", weights_only=False)["epoch"] == 1
    assert not (part / "cnn.npz").exists()
    p = _run_tool(["--out", str(part)] + base + ["--resume"])
    assert p.returncode == 0, p.stderr
    assert "resumed after epoch 1" in p.stdout
    a, b = torch.load(whole / "cnn_float.pt"), torch.load(part / "cnn_float.pt")
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    za, zb = np.load(whole / "cnn.npz"), np.load(part / "cnn.npz")
    assert sorted(za.files) == sorted(zb.files) and all(np.array_equal(za[k], zb[k]) for k in za.files)
    # another run's flags: refused, nothing written
    p = _run_tool(["--out", str(part)] + base[:-1] + ["4", "--resume"])
    assert p.returncode != 0 and "flags differ: seed" in p.stderr
    # a flag added after checkpoints existed (--codec) is in the key only when set: unset, the
    # resume above took the checkpoint; set, it is another run
    p = _run_tool(["--out", str(part)] + base + ["--codec", "0.5", "--resume"])
    assert p.returncode != 0 and "flags differ: codec" in p.stderr


@pytest.mark.parametrize("args,msg", [(["--limit", "-1"], "--limit"), (["--stop-after", "0"], "--stop-after"),
                                      (["--train-part", "2", "2"], "--train-part"),
                                      (["--train-part", "-1", "2"], "--train-part")])
def test_resume_flags_rejected(args, msg, tmp_path):
    p = _run_tool(["--out", str(tmp_path / "m")] + args, timeout=120)
    assert p.returncode == 2 and msg in p.stderr
    assert not (tmp_path / "m").exists()


@_training_run
def test_resume_without_a_checkpoint_is_a_clear_error(tmp_path):
    pytest.importorskip("torch")
    p = _run_tool(["--out", str(tmp_path / "m"), "--resume", "--limit", "1"], timeout=300)
    assert p.returncode != 0 and "no " in p.stderr and "checkpoint.pt" in p.stderr


def test_training_frames_are_gray_as_the_command_line_makes_them(tool):
    """The tool's frames equal what detect/track hand the core (colour decode, then to_gray); on this
    JPEG libjpeg's own gray decode differs on some pixels, so a tool reading IMREAD_GRAYSCALE fails here."""
    import cv2
    from pyvehtrack.frames import to_gray
    p = ROOT / "tests" / "data" / "udacity_test4.jpg"
    want = to_gray(cv2.imread(str(p)))
    assert not np.array_equal(cv2.imread(str(p), cv2.IMREAD_GRAYSCALE), want)    # the check can fail
    assert np.array_equal(tool.read_gray(p), want)
    with pytest.raises(FileNotFoundError, match="cannot read"):
        tool.read_gray(ROOT / "tests" / "data" / "no_such_frame.jpg")


def test_codec_frame_is_the_clips_predicted_frame(tool, tmp_path):
    """--codec: the frame comes back through mp4v as the second frame of a two-frame clip. It is
    the frame itself, coded (nearer to the input than to the first frame, the car a step back,
    and not equal to it), the same for the same generator, and augment's boxes do not move."""
    import cv2
    g = cv2.imread(str(ROOT / "tests" / "data" / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    out = tool.video_codec(g, np.random.default_rng(4), tmp_path)
    assert out.dtype == np.uint8 and out.shape == g.shape and not np.array_equal(out, g)
    assert np.array_equal(out, tool.video_codec(g, np.random.default_rng(4), tmp_path))
    prev = tool.step_back(g, np.random.default_rng(4))       # the clip's first frame, the same draws
    # mp4v's error here is about 2 grey levels a pixel; the two frames differ by 12-15 (seeds 0-4)
    d_in, d_prev = (np.abs(out.astype(int) - x).mean() for x in (g, prev))
    assert d_in < 0.5 * d_prev, (d_in, d_prev)
    boxes = np.array([[408, 206, 471, 246], [527, 204, 635, 252]], np.float32)
    a = tool.augment(g, boxes, np.random.default_rng(7), None, codec=0.0)
    b = tool.augment(g, boxes, np.random.default_rng(7), None, codec=1.0, tmpdir=tmp_path)
    assert np.array_equal(a[1], b[1]) and not np.array_equal(a[0], b[0])


def test_train_part_splits_by_blocks_of_100(tool):
    """--train-part K N: the N parts are disjoint, cover the frames, and part K holds exactly the
    file numbers with (NNNN // 100) % N == K (a learning curve's smaller sets)."""
    items = [({"file_name": f"supp_img/{i:04d}.jpg"}, None, None) for i in range(5, 5066, 10)]
    for n in (1, 2, 4):
        parts = [tool.train_part(items, k, n) for k in range(n)]
        assert sum(len(p) for p in parts) == len(items)
        for k, p in enumerate(parts):
            assert p and all((int(t[0]["file_name"][9:13]) // 100) % n == k for t in p)
    assert tool.train_part(items, 0, 2) != tool.train_part(items, 1, 2)
