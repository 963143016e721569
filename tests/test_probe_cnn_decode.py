"""tools/probe_cnn_decode.py names a wrong flag before any frame is read (the frames live
outside the repository; these checks need only the shipped model file)."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TOOL = ROOT / "tools" / "probe_cnn_decode.py"
MODEL = ROOT / "pyvehtrack" / "models" / "cnn_gray_l0_big.npz"


@pytest.mark.parametrize("args,msg", [
    (["--probe", "levels", "--levels-offsets", "0", "4"], "one per level 0..4"),
    (["--probe", "upsample", "--band", "600", "500"], "--band"),
    (["--probe", "upsample", "--cols", "0", "1001"], "--cols"),
    (["--probe", "none", "--stretch", "500"], "--stretch"),
    (["--probe", "none", "--limit", "-1"], "--limit"),
    (["--probe", "fast"], "invalid choice"),
])
def test_probe_tool_rejects_bad_flags(args, msg, tmp_path):
    p = subprocess.run([sys.executable, str(TOOL), "--model", str(MODEL), "--data", str(tmp_path)] + args,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and msg in p.stderr, p.stderr


def test_probe_tool_names_a_file_that_is_not_a_cnn_model(tmp_path):
    bad = tmp_path / "x.npz"
    bad.write_bytes(b"not a model")
    p = subprocess.run([sys.executable, str(TOOL), "--model", str(bad), "--probe", "none"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "--model" in p.stderr, p.stderr


def _tool():
    import importlib.util
    spec = importlib.util.spec_from_file_location("probe_cnn_decode_under_test", TOOL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_probes_first_line_is_the_c_detector(tmp_path):
    """With no probe option, the offline decode of the dumped level outputs gives exactly
    vt_cnn_detect_frame's boxes and heats (same levels, band, stretch, upsampled band, threshold, cap, NMS): the
    'as shipped' line every probe is compared with is the detector itself."""
    import dataclasses
    import json

    import cv2
    import numpy as np

    from pyvehtrack import cnn as C
    tool = _tool()
    # 640x360: within the smallest build's maximum frame (make test's -DVT_MAX_WIDTH=700)
    img = cv2.imread(str(ROOT / "tests" / "data" / "tusimple_vehicles_4065_gray_640x360.png"), cv2.IMREAD_GRAYSCALE)
    (tmp_path / "supp_img").mkdir()
    cv2.imwrite(str(tmp_path / "supp_img" / "0015.jpg"), img)          # (15 // 10) % 5 == 1: 'val'
    (tmp_path / "annotation.json").write_text(json.dumps([{"file_name": "supp_img/0015.jpg", "bbox": []}]))
    model = C.CnnModel.load(MODEL)
    cfg = C.CnnConfig(*[int(v) for v in np.load(MODEL)["cnn_cfg"]])
    up = dict(up_top_permille=440, up_bottom_permille=540, up_left_permille=300, up_right_permille=700)
    for c in (dataclasses.replace(cfg, stretch_tail_permille=0), cfg, dataclasses.replace(cfg, **up)):
        (e, g, outs), = tool.frames_of(model, c, tmp_path, "val", None, 0)
        gray = cv2.imread(str(tmp_path / "supp_img" / "0015.jpg"), cv2.IMREAD_GRAYSCALE)
        want, _ = C.detect_frame(model, gray, c)
        got = tool.frame_boxes(model, c, outs, g.shape[1], g.shape[0])
        assert len(want) > 0
        assert np.array_equal(np.array(got, np.int64).reshape(-1, 5), want.astype(np.int64))
