"""Fixed splits of the data sets, shared by everyone who trains, tunes or scores.

The splits are functions of file names only (never random), so a figure can say
exactly which files it comes from, and the classifier (wip/classify) and the
full-frame detector (wip/detect) tune and score on the same parts.
"""
from __future__ import annotations

import re
from pathlib import Path

__all__ = ["tusimple_split", "tusimple_subsplit", "gti_split", "GTI_BLOCK", "GTI_TEST_EVERY"]

_NUM = re.compile(r"(\d+)")


def _last_number(name: str) -> int:
    stem = Path(str(name)).stem
    nums = _NUM.findall(stem)
    if not nums:
        raise ValueError(f"file_name: no number in {name!r}")
    return int(nums[-1])


def tusimple_split(file_name: str) -> str:
    """'test' or 'train' for a tusimple-vehicles-dev frame (e.g. 'supp_img/0005.jpg').

    A frame NNNN is TEST when (NNNN // 10) % 5 == 0: every 5th file of the set
    (0005, 0055, 0105, ...; 102 of the 507 frames); all others are TRAIN. Never
    tune on TEST."""
    return "test" if (_last_number(file_name) // 10) % 5 == 0 else "train"


def tusimple_subsplit(file_name: str) -> str:
    """'test', 'fit' or 'val' for a tusimple-vehicles-dev frame: TEST as tusimple_split;
    the TRAIN frames with (NNNN // 10) % 5 == 1 are 'val' (the TRAIN part that choices
    such as C, thresholds and window sizes are made on; ~100 frames), the other TRAIN
    frames are 'fit' (the classifier's training frames)."""
    k = (_last_number(file_name) // 10) % 5
    return "test" if k == 0 else ("val" if k == 1 else "fit")


def tusimple_frames(data, split: str, limit: int = 0) -> list[dict]:
    """The annotation records of tusimple-vehicles-dev (folder `data`, its
    annotation.json) in `split`: 'train' / 'test' (tusimple_split) or 'fit' / 'val'
    (tusimple_subsplit), in file order; the first `limit` only when limit > 0."""
    import json  # noqa: PLC0415
    ann = json.loads((Path(data) / "annotation.json").read_text())
    part = tusimple_split if split in ("train", "test") else tusimple_subsplit
    frames = [e for e in ann if part(e["file_name"]) == split]
    return frames[:limit] if limit else frames


# GTI crops come from video: neighbouring file numbers are near-duplicates, so the
# split is by blocks of GTI_BLOCK consecutive files (in the folder's numeric order);
# every GTI_TEST_EVERY-th block is TEST.
GTI_BLOCK = 40
GTI_TEST_EVERY = 5


def gti_split(index_in_folder: int) -> str:
    """'test' or 'train' for the file at position `index_in_folder` (0-based) of a
    gti-vehicles folder sorted by the number in the file name: blocks of 40
    consecutive files, every 5th block (blocks 0, 5, 10, ...) is TEST (20%)."""
    if isinstance(index_in_folder, bool) or not isinstance(index_in_folder, int) or index_in_folder < 0:
        raise ValueError(f"index_in_folder: expected an int >= 0, got {index_in_folder!r}")
    return "test" if (index_in_folder // GTI_BLOCK) % GTI_TEST_EVERY == 0 else "train"


def gti_sorted(folder) -> list[Path]:
    """The .png files of one gti-vehicles folder in numeric file-name order (the
    order gti_split's index refers to)."""
    files = [p for p in Path(folder).iterdir() if p.suffix.lower() == ".png"]
    return sorted(files, key=lambda p: (_last_number(p.name) if _NUM.search(p.stem) else -1, p.name))
