"""eval-boxes: box matching, size classes, the lead vehicle and COCO AP50 on a tiny
hand-made annotation whose answers are worked out below, and bad input."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pyvehtrack import eval_boxes as eb
from pyvehtrack.cli import main as cli_main

# Two 100x100 frames. Frame a: a 40-px car at the bottom centre (the lead), a 20-px far
# car, a 70-px car on the right. Frame b: one 80-px lead car.
GT = [
    {"file_name": "supp_img/0001.jpg", "bbox": [
        {"left": 30, "top": 60, "right": 69, "bottom": 99},     # 40 px, lead
        {"left": 10, "top": 10, "right": 29, "bottom": 29},     # 20 px
        {"left": 0, "top": 0, "right": 69, "bottom": 20}]},     # 70 px (top-left, far from bottom)
    {"file_name": "supp_img/0002.jpg", "bbox": [
        {"left": 10, "top": 19, "right": 89, "bottom": 98}]},   # 80 px, lead
]
PRED = [
    # frame a: the lead exactly (0.9), the far car shifted by 2 px (IoU 18*20/(2*400-360) =
    # 0.818, 0.8), a false 40-px box (0.95), nothing on the 70-px car.
    {"frame": 0, "file": "/x/supp_img/0001.jpg", "boxes": [[30, 60, 69, 99, 0.9], [12, 10, 31, 29, 0.8],
                                                         [50, 30, 89, 69, 0.95]]},
    # frame b: the lead shifted by 30 px: IoU 50*80 / (2*6400 - 4000) = 0.4545 -> a miss and a
    # false positive; it is still the frame's predicted lead, and wrong.
    {"frame": 1, "file": "0002.jpg", "boxes": [[40, 19, 119, 98, 0.5]]},
]


def test_scores_by_hand():
    s = eb.score(eb.load_gt(GT), eb.load_pred(PRED), image_size=(100, 100))
    assert s.frames == 2 and s.unscored_gt_frames == 0
    a = s.classes["all"]
    # 4 gt, 2 matched; 4 predictions, 2 right
    assert (a["gt"], a["pred"]) == (4, 4)
    assert a["recall"] == pytest.approx(2 / 4) and a["precision"] == pytest.approx(2 / 4)
    c32 = s.classes[">=32px"]
    # gt >= 32: lead a, 70-px, lead b -> 1 matched. preds: lead a (TP), false 40 (FP), b (80 px, FP);
    # the 20-px box matched a 20-px gt: left out of this class.
    assert (c32["gt"], c32["pred"]) == (3, 3)
    assert c32["recall"] == pytest.approx(1 / 3) and c32["precision"] == pytest.approx(1 / 3)
    c64 = s.classes[">=64px"]
    assert (c64["gt"], c64["pred"]) == (2, 1)
    assert c64["recall"] == 0 and c64["precision"] == 0
    ld = s.lead
    assert (ld["frames"], ld["pred_frames"]) == (2, 2)
    assert ld["recall"] == pytest.approx(0.5) and ld["precision"] == pytest.approx(0.5)
    # by the lead's width: both true leads are >= 32 px (40, 80), both predicted leads too
    # (40, 80): as the plain row. >= 64 px: frame b's true lead (80, missed) and its
    # predicted lead (80 px wide, IoU 0.4545: wrong); frame a's 40-px leads are left out.
    l32, l64 = s.lead_by_size["lead>=32px"], s.lead_by_size["lead>=64px"]
    assert (l32["frames"], l32["pred_frames"], l32["recall"], l32["precision"]) == (2, 2, 0.5, 0.5)
    assert (l64["frames"], l64["pred_frames"], l64["recall"], l64["precision"]) == (1, 1, 0.0, 0.0)
    text = eb.format_scores(s).splitlines()
    assert [ln.split()[0] for ln in text[2:]] == ["all", ">=32px", ">=64px", "lead", "lead>=32px",
                                                  "lead>=64px", "COCO"]
    # COCO AP50, by hand: detections by score 0.95 FP, 0.9 TP, 0.8 TP, 0.5 FP over 4 gt;
    # precision envelope up to recall 0.5 is 2/3; 101-point interpolation: recall points
    # 0..0.50 (51 of 101) at 2/3, the rest 0.
    assert s.ap50 == pytest.approx(51 / 101 * 2 / 3, abs=1e-9)


def test_iou_inclusive():
    assert eb.box_iou_matrix([[0, 0, 9, 9]], [[0, 0, 9, 9]])[0, 0] == 1.0
    assert eb.box_iou_matrix([[0, 0, 9, 9]], [[5, 0, 14, 9]])[0, 0] == pytest.approx(50 / 150)
    assert eb.box_iou_matrix([[0, 0, 9, 9]], [[10, 0, 19, 9]])[0, 0] == 0.0


def test_no_score_and_empty():
    pred = [{"frame": 0, "file": "0001.jpg", "boxes": [[30, 60, 69, 99]]}]
    s = eb.score(eb.load_gt(GT), eb.load_pred(pred), image_size=(100, 100))
    assert s.frames == 1 and s.unscored_gt_frames == 1
    assert s.classes["all"]["recall"] == pytest.approx(1 / 3) and s.classes["all"]["precision"] == 1.0
    s = eb.score(eb.load_gt(GT), eb.load_pred([{"frame": 0, "file": "0002.jpg", "boxes": []}]),
                 image_size=(100, 100))
    assert s.classes["all"]["recall"] == 0 and math.isnan(s.classes["all"]["precision"])
    assert s.ap50 == 0.0


@pytest.mark.parametrize("pred, msg", [
    ({"file": "x"}, "JSON list"),
    ([{"file": "0001.jpg"}], "needs 'file' and 'boxes'"),
    ([{"file": "0003.jpg", "boxes": []}], "matches 0 ground-truth"),
    ([{"file": "0001.jpg", "boxes": [[1, 2, 3]]}], "box 0"),
    ([{"file": "0001.jpg", "boxes": [[5, 2, 3, 9]]}], "right < left"),
    ([{"file": "0001.jpg", "boxes": [[1, 2, 3, "a"]]}], "non-numeric"),
    ([{"file": "0001.jpg", "boxes": [[1, 2, 3, 4, float("nan")]]}], "non-finite"),
    ([{"file": "0001.jpg", "boxes": [[1, 2, 3, 4, 0.5], [1, 2, 3, 4]]}], "some boxes carry a score"),
    ([{"file": "0001.jpg", "boxes": []}, {"file": "a/0001.jpg", "boxes": []}], "two entries"),
])
def test_bad_pred(pred, msg):
    with pytest.raises(ValueError, match=msg):
        eb.score(eb.load_gt(GT), eb.load_pred(pred))


def test_cli(tmp_path, capsys):
    gt, pred, out = tmp_path / "gt.json", tmp_path / "pred.json", tmp_path / "s.json"
    gt.write_text(json.dumps(GT))
    pred.write_text(json.dumps(PRED))
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(pred), "--image-size", "100x100",
                     "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "COCO AP50" in text and ">=32px" in text and "lead" in text
    d = json.loads(out.read_text())
    assert d["classes"]["all"]["recall"] == pytest.approx(0.5)
    assert np.isclose(d["coco_ap50"], 51 / 101 * 2 / 3)


@pytest.mark.parametrize("args, msg", [
    (["--gt", "MISSING", "--pred", "P"], "--gt MISSING: no such file"),
    (["--gt", "G", "--pred", "P", "--image-size", "0x5"], "--image-size"),
    (["--gt", "BAD", "--pred", "P"], "not readable as JSON"),
    (["--gt", "G", "--pred", "BADP"], "--pred"),
])
def test_cli_errors(tmp_path, capsys, args, msg):
    (tmp_path / "G").write_text(json.dumps(GT))
    (tmp_path / "P").write_text(json.dumps(PRED))
    (tmp_path / "BAD").write_text("{")
    (tmp_path / "BADP").write_text(json.dumps([{"file": "0001.jpg", "boxes": [[1]]}]))
    args = [str(tmp_path / a) if a in ("G", "P", "BAD", "BADP", "MISSING") else a for a in args]
    assert cli_main(["eval-boxes"] + args) == 2
    err = capsys.readouterr().err
    assert msg.replace("MISSING", str(tmp_path / "MISSING")) in err


def test_errors_are_the_class_s_misses_and_false_boxes():
    """errors(): frame a's 70-px car (only the far car's box touches it: 20 x 11 px of a union
    of 1470 + 400 - 220, IoU 0.133) and frame b's 80-px lead (the shifted box, IoU 0.4545) are
    the misses >= 32 px; the false 40-px box of frame a and frame
    b's shifted box the false ones -- score()'s >=32px counts (gt - matched, FP)."""
    gt, pred = eb.load_gt(GT), eb.load_pred(PRED)
    errs = eb.errors(gt, pred, min_w=32)
    miss = [e for e in errs if e["kind"] == "missed"]
    false = [e for e in errs if e["kind"] == "false"]
    assert [(e["file"], e["box"]) for e in miss] == [("supp_img/0001.jpg", [0, 0, 69, 20]),
                                                     ("supp_img/0002.jpg", [10, 19, 89, 98])]
    assert miss[0]["iou"] == pytest.approx(220 / 1650) and miss[1]["iou"] == pytest.approx(4000 / 8800)
    assert [(e["file"], e["box"], e["score"]) for e in false] == [("supp_img/0001.jpg", [50, 30, 89, 69], 0.95),
                                                                  ("supp_img/0002.jpg", [40, 19, 119, 98], 0.5)]
    c = eb.score(gt, pred, image_size=(100, 100)).classes[">=32px"]
    assert len(miss) == c["gt"] - round(c["recall"] * c["gt"]) and len(false) == c["pred"] - round(
        c["precision"] * c["pred"])
    assert len(eb.errors(gt, pred, min_w=0)) == 4   # + nothing: the 20-px car is matched


def _fixture_files(tmp_path):
    """The fixture's two frames (gray 128) under tmp_path/supp_img and its gt / pred JSON files."""
    import cv2
    (tmp_path / "supp_img").mkdir()
    for f in ("0001.jpg", "0002.jpg"):
        cv2.imwrite(str(tmp_path / "supp_img" / f), np.full((100, 100, 3), 128, np.uint8))
    gt, pred = tmp_path / "gt.json", tmp_path / "pred.json"
    gt.write_text(json.dumps(GT))
    pred.write_text(json.dumps(PRED))
    return gt, pred


def test_cli_sheet(tmp_path, capsys):
    """--sheet: a picture with a band per kind; the frames come from --images (default: the
    --gt file's folder); a frame that cannot be read or --images without --sheet is a clear error."""
    import cv2
    gt, pred = _fixture_files(tmp_path)
    sheet = tmp_path / "errors.png"
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(pred), "--image-size", "100x100",
                     "--sheet", str(sheet)]) == 0
    assert "2 missed, 2 false" in capsys.readouterr().out
    img = cv2.imread(str(sheet))
    assert img.shape == (2 * (24 + 120), 8 * 160, 3)   # two bands: a header and one row of tiles each
    # a missed tile holds the frame's gray (128) and the red box
    tile = img[24:144, :160]
    assert (np.abs(tile.astype(int) - 128).max(2) <= 2).sum() > 1000
    assert ((tile[:, :, 2] > 200) & (tile[:, :, 0] < 60)).any()
    (tmp_path / "supp_img" / "0002.jpg").unlink()
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(pred), "--sheet", str(sheet)]) == 2
    assert "cannot read the frame" in capsys.readouterr().err
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(pred), "--images", str(tmp_path)]) == 2
    assert "--images is read only with --sheet or --lead-sheet" in capsys.readouterr().err
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(pred), "--sheet", str(tmp_path / "e.txt")]) == 2
    assert "--sheet" in capsys.readouterr().err


def test_lead_errors_are_the_lead_rows_misses():
    """lead_errors: the frames behind the lead>=S px rows that went wrong. In the fixture frame a
    is right (its 40-px lead boxed exactly, and the predicted lead is that box); frame b's 80-px
    lead is missed and its predicted lead (IoU 0.4545) is wrong: one entry, both kinds. The
    counts equal the rows' (missed = frames - matched, wrong = pred_frames - right)."""
    gt, pred = eb.load_gt(GT), eb.load_pred(PRED)
    for s in (32, 64):
        ent = eb.lead_errors(gt, pred, (100, 100), min_w=s)
        assert [(e["file"], e["kinds"]) for e in ent] == [("supp_img/0002.jpg", ["missed", "wrong"])]
        assert ent[0]["iou"] == pytest.approx(4000 / 8800) and ent[0]["score"] == 0.5
        assert ent[0]["gt_lead"] == [10, 19, 89, 98] and ent[0]["pred_lead"] == [40, 19, 119, 98]
        row = eb.score(gt, pred, (100, 100)).lead_by_size[f"lead>={s}px"]
        assert sum("missed" in e["kinds"] for e in ent) == row["frames"] - round(row["recall"] * row["frames"])
        assert sum("wrong" in e["kinds"] for e in ent) == row["pred_frames"] - round(
            row["precision"] * row["pred_frames"])
    # wider than every lead: nothing to show
    assert eb.lead_errors(gt, pred, (100, 100), min_w=100) == []
    # frame a's lead predicted 5 px off (IoU 1400/1800): still right; 25 px off (IoU 600/2600): missed and wrong
    for dx, kinds in ((5, None), (25, ["missed", "wrong"])):
        moved = [dict(PRED[0], boxes=[[30 + dx, 60, 69 + dx, 99, 0.9]])]
        ent = eb.lead_errors(gt[:1], eb.load_pred(moved), (100, 100))
        assert (ent[0]["kinds"] if ent else None) == kinds, dx


def test_cli_lead_sheet(tmp_path, capsys):
    """--lead-sheet: a header and one tile per frame with a missed or wrong near lead, the
    whole frame with the boxes drawn (the true lead thick green, the predicted one thick red)."""
    import cv2
    gt, pred = _fixture_files(tmp_path)
    sheet = tmp_path / "leads.png"
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(pred), "--image-size", "100x100",
                     "--lead-sheet", str(sheet)]) == 0
    assert "1 frames: near lead missed in 1, predicted near lead wrong in 1" in capsys.readouterr().out
    img = cv2.imread(str(sheet))
    assert img.shape == (24 + 270, 3 * 480, 3)
    tile = img[24:, :480]
    assert ((tile[:, :, 1] > 200) & (tile[:, :, 2] < 60) & (tile[:, :, 0] < 60)).any()   # green lead
    assert ((tile[:, :, 2] > 200) & (tile[:, :, 1] < 60) & (tile[:, :, 0] < 60)).any()   # red lead
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(pred), "--lead-sheet",
                     str(tmp_path / "l.txt")]) == 2
    assert "--lead-sheet" in capsys.readouterr().err
    (tmp_path / "supp_img" / "0002.jpg").unlink()
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(pred), "--lead-sheet", str(sheet)]) == 2
    assert "--lead-sheet: cannot read the frame" in capsys.readouterr().err
