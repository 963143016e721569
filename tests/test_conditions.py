"""pyvehtrack.eval.conditions: the transforms that score the detector on frames as users feed
them (issue 8 item 5). Each does what its docstring states, to the stated rounding."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pyvehtrack.eval import conditions as cd

ROOT = Path(__file__).resolve().parent.parent


def test_dusk_darkens_by_the_stated_curve_and_is_deterministic():
    img = np.full((200, 200), 128, np.uint8)
    a, b, c = cd.dusk(img, seed=1), cd.dusk(img, seed=1), cd.dusk(img, seed=2)
    assert a.dtype == np.uint8 and a.shape == img.shape
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    # 255 x 0.4 x (128 / 255)^1.6 = 33.86; the noise (sigma 3) averages out over 40,000 pixels
    # (standard error 0.015) and rounding to integers is unbiased there: 0.1 is > 6 standard errors
    assert abs(a.mean() - 255 * 0.4 * (128 / 255) ** 1.6) < 0.1
    assert 2.5 < a.std() < 3.5          # the noise: sigma 3 plus rounding (1/12 variance)
    col = np.dstack([img] * 3)
    assert cd.dusk(col, seed=1).shape == col.shape


def test_overcast_halves_the_contrast_about_the_mean():
    rng = np.random.default_rng(0)
    img = rng.integers(60, 200, (120, 160)).astype(np.uint8)   # no clipping after the lift
    out = cd.overcast(img).astype(np.float64)
    # each pixel is rounded once (<= 0.5 level): means and deviations move by at most 0.5
    assert abs(out.mean() - (img.mean() + 20)) <= 0.5
    assert abs(out.std() - 0.5 * img.std()) <= 0.5
    assert np.array_equal(cd.light(img, "overcast"), cd.overcast(img))


def test_rescale_sizes_and_bad_factors():
    img = np.zeros((375, 1242), np.uint8)
    assert cd.rescale(img, 0.5).shape == (188, 621)
    assert cd.rescale(img, 1.5).shape == (562, 1863)
    assert cd.rescale(np.zeros((3, 3, 3), np.uint8), 0.01).shape == (1, 1, 3)
    for bad in (0, -1, float("nan"), float("inf"), "2"):
        with pytest.raises(ValueError, match="factor"):
            cd.rescale(img, bad)


@pytest.mark.parametrize("bad", [np.zeros((4, 4), np.float32), np.zeros((0, 4), np.uint8),
                                 np.zeros((2, 2, 2, 2), np.uint8), [[1, 2]]])
def test_bad_images_are_clear_errors(bad):
    with pytest.raises(ValueError, match="uint8"):
        cd.dusk(bad)
    with pytest.raises(ValueError, match="uint8"):
        cd.overcast(bad)


def test_light_names():
    with pytest.raises(ValueError, match="dusk"):
        cd.light(np.zeros((2, 2), np.uint8), "night")


def _psnr(a, b):
    return 10 * np.log10(255.0 ** 2 / np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))


@pytest.mark.parametrize("shape", [(375, 1242), (121, 161, 3)])   # odd sides: padded and cut back
def test_h264_round_trip_keeps_size_count_and_picture(shape):
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    base = (128 + 60 * np.sin(xx / 17.0) * np.cos(yy / 11.0)).astype(np.uint8)
    frames = []
    for k in range(4):
        f = np.roll(base, 3 * k, axis=1)
        frames.append((10 + k, np.dstack([f] * 3) if len(shape) == 3 else f))
    out = cd.through_h264(frames, crf=23)
    assert [i for i, _ in out] == [10, 11, 12, 13]
    for (_, a), (_, b) in zip(frames, out):
        assert b.shape == a.shape and b.dtype == np.uint8
        # a smooth picture at x264's default quality: well above 30 dB (a lost or shifted frame
        # of this pattern scores under 10 dB)
        assert _psnr(a, b) > 30
    # a stronger CRF loses more
    lossy = cd.through_h264(frames, crf=45)
    assert np.mean([_psnr(a, b) for (_, a), (_, b) in zip(frames, lossy)]) < \
        np.mean([_psnr(a, b) for (_, a), (_, b) in zip(frames, out)])


def test_h264_bad_arguments():
    f = [(0, np.zeros((8, 8), np.uint8))]
    with pytest.raises(ValueError, match="no frames"):
        cd.through_h264([])
    for crf in (-1, 52, 2.5):
        with pytest.raises(ValueError, match="CRF"):
            cd.through_h264(f, crf=crf)
    with pytest.raises(ValueError, match="size"):
        cd.through_h264(f + [(1, np.zeros((8, 10), np.uint8))])


@pytest.mark.parametrize("args,msg", [(["--scale", "0"], "--scale"), (["--h264", "60"], "--h264"),
                                      (["--mp4", "--h264"], "choose one"), (["--light", "night"], "invalid choice")])
def test_eval_tool_rejects_bad_condition_flags(args, msg):
    p = subprocess.run([sys.executable, str(ROOT / "tools" / "eval_tusimple_boxes.py"), "--split", "test"] + args,
                       capture_output=True, text=True)
    assert p.returncode == 2 and msg in p.stderr
