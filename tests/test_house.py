"""The house around the core: the CLI package (registry, one-module-per-subcommand, no
import loops, old import paths) and the eval package (one IoU, KITTI track lines)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pyvehtrack import cli
from pyvehtrack.eval import boxes, kitti

ROOT = Path(__file__).resolve().parent.parent


def _fresh_python(code: str) -> subprocess.CompletedProcess:
    import os
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)


# The CLI modules are the ones that imported each other before the package; the eval
# modules only import .boxes / .kitti (TrackEval and filterpy take seconds to load, so
# they are covered by test_old_import_paths_are_the_new_modules instead).
@pytest.mark.parametrize("module", ["pyvehtrack.cli.track", "pyvehtrack.cli.detect", "pyvehtrack.cli.eval",
                                    "pyvehtrack.cli.common", "pyvehtrack.cli_track", "pyvehtrack.synth"])
def test_each_module_imports_first_without_loops(module):
    """Imported first in a fresh interpreter, each module loads (an import loop would fail)."""
    r = _fresh_python(f"import {module}")
    assert r.returncode == 0, r.stderr


def test_old_import_paths_are_the_new_modules():
    import pyvehtrack.cli.detect
    import pyvehtrack.cli.track
    import pyvehtrack.cli_track
    import pyvehtrack.eval.lanes
    import pyvehtrack.eval.sort
    import pyvehtrack.eval.synth
    import pyvehtrack.eval.tracking
    import pyvehtrack.eval_lanes
    import pyvehtrack.evaluate
    import pyvehtrack.reference.sort
    import pyvehtrack.synth
    assert pyvehtrack.synth is pyvehtrack.eval.synth
    assert pyvehtrack.evaluate is pyvehtrack.eval.tracking
    assert pyvehtrack.eval_lanes is pyvehtrack.eval.lanes
    assert pyvehtrack.reference.sort is pyvehtrack.eval.sort
    assert pyvehtrack.cli_track is pyvehtrack.cli.track
    from pyvehtrack.cli import CliError, IMAGE_EXTS, VIDEO_EXTS, main  # noqa: F401  (kept names)
    from pyvehtrack.cli import (_count_frames, _frames_of, _iter_frames, detection_json,  # noqa: F401
                                draw_detection, register_detect, run_detect)
    from pyvehtrack.cli_track import draw_tracks, kitti_line, register_track  # noqa: F401
    assert run_detect is pyvehtrack.cli.detect.run and pyvehtrack.cli.run_track is pyvehtrack.cli.track.run
    from pyvehtrack.reference.sort import iou_matrix, run_sort, write_tracks_kitti  # noqa: F401


def test_a_subcommand_registers_with_one_line(tmp_path, monkeypatch, capsys):
    """The documented way to add a command: a module with register(subparsers), one line in
    SUBCOMMANDS; its CliError becomes one line and exit status 2."""
    mod = tmp_path / "vt_hello_cmd.py"
    mod.write_text(
        "from pyvehtrack.cli.common import CliError\n"
        "def register(sub):\n"
        "    p = sub.add_parser('hello', help='say hello', epilog='examples:\\n  pyvehtrack hello')\n"
        "    p.add_argument('--fail', action='store_true')\n"
        "    p.set_defaults(func=run)\n"
        "def run(args):\n"
        "    if args.fail:\n"
        "        raise CliError('--fail: asked to fail')\n"
        "    print('hello')\n"
        "    return 0\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(cli.SUBCOMMANDS, "hello", "vt_hello_cmd")
    assert cli.main(["hello"]) == 0 and capsys.readouterr().out == "hello\n"
    assert cli.main(["hello", "--fail"]) == 2
    assert capsys.readouterr().err == "pyvehtrack hello: error: --fail: asked to fail\n"
    monkeypatch.setitem(cli.SUBCOMMANDS, "hello", "vt_hello_cmd:register")   # "module:function" form
    assert cli.main(["hello"]) == 0


def test_old_frame_reader_api():
    src = [("image", str(ROOT / "tests" / "data" / "kitti_0000_gray_320x96.png"))]
    got = list(cli._iter_frames(src))
    assert len(got) == 1 and got[0][1] == 0 and got[0][2].shape == (96, 320)
    assert cli._count_frames(src) == 1


def test_one_extension_list():
    from pyvehtrack.cli import common
    assert common.VIDEO_OUT_EXTS <= common.VIDEO_EXTS
    assert not common.IMAGE_EXTS & common.VIDEO_EXTS
    assert common.output_kind("a.PNG") == "image" and common.output_kind("a.mp4") == "video"
    assert common.output_kind("a.webm") is None          # readable, but no writer here
    assert common.output_kind("a.txt") is None


# ---------------------------------------------------------------- eval: one IoU
def test_iou_continuous_convention():
    # two 10x10 boxes overlapping in a 5x10 strip: 50 / 150
    assert boxes.iou([0, 0, 10, 10], [5, 0, 15, 10]) == pytest.approx(50 / 150)
    assert boxes.iou([0, 0, 10, 10], [10, 0, 20, 10]) == 0.0         # touching edges do not overlap
    assert boxes.iou([0, 0, 0, 0], [0, 0, 0, 0]) == 0.0              # empty boxes: no union
    m = boxes.iou_matrix(np.zeros((0, 4)), [[0, 0, 1, 1]])
    assert m.shape == (0, 1)


def test_inclusive_boxes_convert_once():
    # an inclusive [0, 0, 9, 9] box covers pixels 0..9, i.e. the continuous [0, 10)
    np.testing.assert_array_equal(boxes.from_inclusive([0, 0, 9, 9]), [0, 0, 10, 10])
    np.testing.assert_array_equal(boxes.from_inclusive([[1, 2, 3, 4]] * 2), [[1, 2, 4, 5]] * 2)
    # the same pixels described both ways give IoU 1
    assert boxes.iou(boxes.from_inclusive([3, 4, 20, 30]), [3, 4, 21, 31]) == 1.0


def test_iou_matches_reference_tracker_on_inclusive_boxes():
    """The oracle's integer IoU (reference.tracker.box_iou, inclusive boxes, mirroring C) and
    eval.boxes on the converted boxes are the same number: one convention, two arithmetics."""
    from pyvehtrack.reference.tracker import box_iou
    rng = np.random.default_rng(1)
    for _ in range(200):
        a = np.sort(rng.integers(0, 50, (2, 2)), axis=0).T.reshape(-1)[[0, 2, 1, 3]]
        b = np.sort(rng.integers(0, 50, (2, 2)), axis=0).T.reshape(-1)[[0, 2, 1, 3]]
        assert boxes.iou(boxes.from_inclusive(a), boxes.from_inclusive(b)) == pytest.approx(box_iou(a, b))


# ---------------------------------------------------------------- eval: KITTI lines
def test_track_lines_round_trip(tmp_path):
    per_frame = [[(1, 10.5, 20.25, 30.0, 40.0, 0.5)], [], [(2, 0, 0, 5, 5)]]
    p = tmp_path / "t.txt"
    kitti.write_tracks_kitti(per_frame, p)
    lab = kitti.read_kitti(p)
    assert list(lab["frame"]) == [0, 2] and list(lab["id"]) == [1, 2]
    np.testing.assert_allclose(lab["left"], [10.5, 0]) and np.testing.assert_allclose(lab["score"], [0.5, 1.0])
    line = kitti.track_line(3, 7, (1, 2, 3, 4), 1.0)
    assert line == "3 7 Car -1 -1 -10 1.00 2.00 3.00 4.00 -1 -1 -1 -1000 -1000 -1000 -10 1.00"
    assert len(line.split()) == 18


def test_kitti_reader_refuses_fractional_frame(tmp_path):
    p = tmp_path / "l.txt"
    p.write_text("1.5 1 Car 0 0 0 1 2 3 4\n")
    with pytest.raises(ValueError, match=":1:"):
        kitti.read_kitti(p)
    p.write_text("2.0 1 Car 0 0 0 1 2 3 4\n")       # an integer written as a float is fine
    assert kitti.read_kitti(p)["frame"][0] == 2


# ---------------------------------------------------------------- the friendly layer and the oracle
# Issue 10 item 4: the friendly layer (pyvehtrack/*.py and its packages, outside reference/)
# imports pyvehtrack.reference only to construct the reference engine, i.e. inside the
# function that runs it, never at module level. The plain types both engines need (config
# dataclasses, result records) live in pyvehtrack/shared.py and the oracle re-exports them.
# No exception is left; the dict stays so a future one has to be named (and removed again:
# a module that no longer needs its entry fails the test until the entry is removed).
STILL_IMPORTING_AT_MODULE_LEVEL: dict = {}
# Evaluation code may run the oracle as a baseline (the SORT tracker, synthetic scenes).
NOT_FRIENDLY = ("reference/", "eval/")


def _module_level_reference_imports(path: Path) -> list[int]:
    import ast
    tree = ast.parse(path.read_text(), str(path))
    rel = path.relative_to(ROOT / "pyvehtrack")
    depth = len(rel.parts) - 1                     # package depth of the module

    def names_reference(node) -> bool:
        if isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level == 0:
                return mod.startswith("pyvehtrack.reference")
            if node.level == depth + 1:            # relative to the pyvehtrack package
                return mod.split(".")[0] == "reference" or (
                    not mod and any(a.name == "reference" for a in node.names))
            return False
        return isinstance(node, ast.Import) and any(a.name.startswith("pyvehtrack.reference")
                                                    for a in node.names)

    lines = []
    for node in tree.body:                         # module level only (also inside if/try)
        for sub in ast.walk(node) if isinstance(node, (ast.If, ast.Try)) else [node]:
            if isinstance(sub, (ast.Import, ast.ImportFrom)) and names_reference(sub):
                lines.append(sub.lineno)
    return lines


def test_friendly_layer_imports_reference_only_for_the_reference_engine():
    found = {}
    for p in sorted((ROOT / "pyvehtrack").rglob("*.py")):
        rel = p.relative_to(ROOT / "pyvehtrack").as_posix()
        if rel.startswith(NOT_FRIENDLY):
            continue
        lines = _module_level_reference_imports(p)
        if lines:
            found[rel] = lines
    assert "detector.py" not in found and "fullroad.py" not in found, found
    unexpected = {k: v for k, v in found.items() if k not in STILL_IMPORTING_AT_MODULE_LEVEL}
    assert not unexpected, f"module-level imports of pyvehtrack.reference in the friendly layer: {unexpected}"
    stale = sorted(set(STILL_IMPORTING_AT_MODULE_LEVEL) - set(found))
    assert not stale, f"no longer import the oracle: drop them from STILL_IMPORTING_AT_MODULE_LEVEL: {stale}"


def test_the_scanner_sees_a_module_level_import(tmp_path, monkeypatch):
    """The check above can fail: a module-level import is found, one inside a function is not."""
    pkg = tmp_path / "pyvehtrack"
    (pkg / "cli").mkdir(parents=True)
    (pkg / "a.py").write_text("from .reference import shadow\n")
    (pkg / "b.py").write_text("def f():\n    from .reference import shadow\n")
    (pkg / "cli" / "c.py").write_text("try:\n    from ..reference.lane import LaneConfig\nexcept ImportError:\n    pass\n")
    (pkg / "d.py").write_text("from . import reference\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert _module_level_reference_imports(pkg / "a.py") == [1]
    assert _module_level_reference_imports(pkg / "b.py") == []
    assert _module_level_reference_imports(pkg / "cli" / "c.py") == [2]
    assert _module_level_reference_imports(pkg / "d.py") == [1]


def test_c_engine_detection_never_loads_the_oracle():
    """The C engine's whole-road detector and the Detector module run without
    pyvehtrack.reference ever being imported."""
    r = _fresh_python(
        "import sys, numpy as np\n"
        "import pyvehtrack.detector, pyvehtrack.fullroad as fr\n"
        "det = fr.FullRoadDetector(sources=('shadow',), model=None)\n"
        "g = np.full((96, 160), 120, np.uint8); g[60:64, 50:90] = 20\n"
        "det.detect_gray(g); det.camera_road(96, 160)\n"
        "print(sorted(m for m in sys.modules if m.startswith('pyvehtrack.reference')))\n")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"



def test_c_engine_views_never_load_the_oracle():
    """The seven modules that took config classes from the oracle at module level (issue 10
    item 4) import, and their C engines construct and run one small frame, without
    pyvehtrack.reference being imported: their plain types come from pyvehtrack.shared."""
    r = _fresh_python(
        "import sys, numpy as np\n"
        "import pyvehtrack.classify, pyvehtrack.train, pyvehtrack.vehicle_model\n"
        "from pyvehtrack.lane import LaneDetector\n"
        "from pyvehtrack.tracker import Tracker\n"
        "from pyvehtrack.flow import OvertakingDetector\n"
        "from pyvehtrack.camera import Camera, RangeEstimator\n"
        "g = np.full((96, 160), 120, np.uint8); g[60:64, 50:90] = 20\n"
        "LaneDetector().detect(g)\n"
        "Tracker().step(g, [])\n"
        "OvertakingDetector().step(g)\n"
        "cam = Camera(fx=200.0, fy=200.0, cx=80.0, cy=48.0, height_m=1.2)\n"
        "rng = RangeEstimator(cam, (160, 96), fps=10)\n"
        "rng.box_distance([60, 50, 90, 70])\n"
        "print(sorted(m for m in sys.modules if m.startswith('pyvehtrack.reference')))\n")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1] == "[]"


# ---------------------------------------------------------------- one argument order
# Issue 10 item 6: every stage function takes (state, cfg, ...). The reordered ones
# must reject the old (cfg, state, ...) order at compile time: the two pointers have
# different types, so an old caller is an incompatible-pointer error, never a silent swap.
_OLD_ORDER_CALLS = {
    "lane": "vt_lane_detect(&lc, &ls, &img, &lr, 0)",
    "pitch_init": "vt_pitch_init(&cc, &ps)",
    "pitch_update": "vt_pitch_update(&cc, &ps, 1, 0)",
    "fcw": "vt_fcw_step(&rc, &fs, 0, 0, 0, 0, &o)",
    "model_prepare": "vt_model_prepare(&img, &mc, &se, 0, &mw)",
    "model_fitness": "vt_model_fitness(&img, &mc, &se, 0, &mw, &mp, &o)",
    "model_fit": "vt_model_fit(&img, &mc, &se, &mw, &mr)",
}
_NEW_ORDER_CALLS = ["vt_lane_detect(&ls, &lc, &img, &lr, 0)", "vt_pitch_init(&ps, &cc)",
                    "vt_pitch_update(&ps, &cc, 1, 0)", "vt_fcw_step(&fs, &rc, 0, 0, 0, 0, &o)",
                    "vt_model_prepare(&mw, &mc, &img, &se, 0)",
                    "vt_model_fitness(&mw, &mc, &img, &se, 0, &mp, &o)", "vt_model_fit(&mw, &mc, &img, &se, &mr)"]


def _compile(calls, tmp_path) -> subprocess.CompletedProcess:
    import os
    import shutil
    cc = os.environ.get("CC", "cc").split()[0]
    if shutil.which(cc) is None:
        pytest.skip(f"no C compiler ({cc}) on PATH")
    src = tmp_path / "order.c"
    src.write_text(
        "#include \"vehtrack/vehtrack.h\"\n#include \"vehtrack/lane.h\"\n#include \"vehtrack/camera.h\"\n"
        "#include \"vehtrack/vehicle_model.h\"\n"
        "static vt_lane_cfg lc; static vt_lane_state ls; static vt_lane_result lr; static vt_camera_cfg cc;\n"
        "static vt_pitch_state ps; static vt_range_cfg rc; static vt_fcw_state fs; static vt_model_cfg mc;\n"
        "static vt_model_ws mw; static vt_model_search se; static vt_model_result mr; static vt_model_params mp;\n"
        "int f(void) { vt_image_u8 img = {0}; int32_t o = 0; int n = 0;\n"
        + "".join(f"  n += (int){c};\n" for c in calls) + "  return n + (int)o + img.w; }\n")
    return subprocess.run([cc, "-std=c99", "-Werror=incompatible-pointer-types", "-I", str(ROOT / "include"),
                           "-c", str(src), "-o", str(tmp_path / "order.o")],
                          capture_output=True, text=True, timeout=60)


def test_state_first_order_compiles(tmp_path):
    r = _compile(_NEW_ORDER_CALLS, tmp_path)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("name", sorted(_OLD_ORDER_CALLS))
def test_old_cfg_first_order_fails_to_compile(name, tmp_path):
    r = _compile([_OLD_ORDER_CALLS[name]], tmp_path)
    assert r.returncode != 0 and "incompatible" in r.stderr, r.stderr
