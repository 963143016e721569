"""The `make bench` machinery in quick mode: bench/bench.py, bench/callgrind.py and
bench/callgrind_main.c. No timing thresholds anywhere (a benchmark is not a test):
these check that every primitive gets a row with sane, positive figures, that the
callgrind parser reads what callgrind_annotate reads, and that the callgrind driver
did the same work on the same data as the cffi run (equal output digests)."""
from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DATA = Path(__file__).resolve().parent / "data"
PRIMITIVES = ["filter_h101", "sobel_x", "sobel_y", "pyr_down", "integral", "box_sum", "ncc",
              "sad", "sincos"]
PER_PIXEL = ["filter_h101", "sobel_x", "sobel_y", "pyr_down", "integral", "ncc", "sad"]


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"vt_bench_{name}", ROOT / "bench" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


callgrind = _load("callgrind")
bench = _load("bench")


# ---------------------------------------------------------------- the parser
# tests/data/callgrind_tiny.out: callgrind 3.19 on bench/callgrind_main (-O2) over a
# 24x16 frame, --toggle-collect='bench_run_*', --dump-instr=no. The expected inclusive
# counts are what `callgrind_annotate --inclusive=yes` printed for that file.
ANNOTATE_INCLUSIVE = {
    "bench_run_ncc": 10396, "bench_run_sad": 10083, "bench_run_sobel_x": 9673,
    "bench_run_sobel_y": 9654, "bench_run_pyr_down": 7590, "bench_run_integral": 3873,
    "bench_run_filter_h101": 2842, "bench_run_box_sum": 735, "bench_run_sincos": 322,
}


def test_parser_matches_callgrind_annotate_on_a_captured_file():
    prof = callgrind.parse(DATA / "callgrind_tiny.out")
    assert prof.events == ["Ir"]
    assert prof.total() == 55168
    for fn, ir in ANNOTATE_INCLUSIVE.items():
        assert prof.inclusive(fn) == ir, fn
        # The same figure from the call sites into fn.
        assert prof.inclusive_from_callers(fn) == ir, fn
        assert prof.calls_in[fn] == 1, fn
    # The stage ran vt_box_sum once per box (box_sum:10 on the command line).
    assert prof.calls_in["vt_box_sum"] == 10
    assert prof.inclusive("vt_box_sum") == prof.self_of("vt_box_sum") == 550
    with pytest.raises(KeyError):
        prof.inclusive("no_such_function")


def test_parser_on_a_hand_written_file():
    # Two events, two position columns (--dump-instr=yes), compressed and plain names,
    # relative (+n, -n) and repeated (*) positions, a callee defined in cfn= first.
    text = """# callgrind format
version: 1
positions: instr line
events: Ir Dr
summary: 1000 200

ob=(1) /bin/x
fl=(1) x.c
fn=(1) main
0x10 5 3 1
+4 +1 2
cfl=(1)
cfn=(2) leaf
calls=2 0x40 20
+2 * 400 90
fn=(2)
0x40 20 300 80
+8 -1 100 10
fn=other
0x80 30 7
cfn=leaf
calls=1 0x40 20
* * 100 20
"""
    prof = callgrind.parse_text(text)
    assert prof.events == ["Ir", "Dr"]
    assert prof.total("Dr") == 200
    assert prof.self_of("main") == 5 and prof.self_of("main", "Dr") == 1
    assert prof.inclusive("main") == 405 and prof.inclusive("main", "Dr") == 91
    assert prof.self_of("leaf") == 400 and prof.calls_in["leaf"] == 3
    assert prof.inclusive_from_callers("leaf") == 500
    assert prof.inclusive("other") == 107 and prof.inclusive("other", "Dr") == 20
    with pytest.raises(ValueError):
        callgrind.parse_text("events: Ir\nfn=(9)\n1 1\n")  # (9) never defined
    with pytest.raises(ValueError):
        callgrind.parse_text("fn=x\n1 1\n")  # no events: line


# ---------------------------------------------------------------- the bench, quick
def _build_driver(tmp: Path) -> Path | None:
    cc = shutil.which(os.environ.get("CC", "cc"))
    if cc is None or shutil.which("valgrind") is None:
        return None
    exe = tmp / "callgrind_main"
    srcs = sorted(str(p) for p in (ROOT / "c").glob("*.c"))
    subprocess.run([cc, "-std=c99", "-O1", "-Wl,-z,now", f"-I{ROOT / 'include'}", *srcs,
                    str(ROOT / "bench" / "callgrind_main.c"), "-o", str(exe)], check=True,
                   timeout=120, env=bench.tool_env())
    return exe


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bench")
    driver = _build_driver(tmp)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    cmd = [sys.executable, str(ROOT / "bench" / "bench.py"), "--quick", "--workdir", str(tmp),
           "--out", str(tmp / "results")]
    if driver is not None:
        cmd += ["--driver", str(driver)]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    result = json.loads((tmp / "results.json").read_text())
    return result, (tmp / "results.md").read_text(), res.stdout, driver


def test_every_primitive_has_sane_timings(quick_run):
    result, md, stdout, _ = quick_run
    rows = {r["stage"]: r for r in result["rows"]}
    assert set(PRIMITIVES) <= set(rows)
    for name in PRIMITIVES:
        r = rows[name]
        assert r["c_us"] > 0 and r["ref_us"] > 0 and r["ratio"] > 0, r
        assert r["reps_c"] == 1 and r["reps_ref"] == 1  # quick mode: one timed repeat
        assert r["units"] >= 1
        assert f"| {name} |" in md
    assert md == stdout  # the table printed is the table written
    for key in ("date", "cpu", "compiler"):
        assert result["machine"][key] and result["machine"][key] != "unknown"
    assert all(v > 0 for v in result["cffi_overhead_us"].values())


def test_sizeof_lists_every_struct_cffi_knows(quick_run):
    result, md, _, _ = quick_run
    from pyvehtrack import ffi
    listed = {s["type"]: s["sizeof"] for s in result["sizeof"]}
    structs = [n for n in ffi.list_types()[0] if ffi.typeof(n).kind == "struct"]
    assert "vt_image_u8" in structs and "vt_road_area" in structs
    for n in structs:
        assert listed[n] == ffi.sizeof(n)
        assert f"| {n} | {ffi.sizeof(n):,} |" in md


def test_callgrind_columns_and_digests(quick_run):
    result, _, _, driver = quick_run
    if driver is None:
        pytest.skip("needs a C compiler and valgrind")
    rows = {r["stage"]: r for r in result["rows"]}
    for name in PRIMITIVES:
        r = rows[name]
        assert r["ir"] > 0 and r["ir_per_item"] > 0, r
        if name in PER_PIXEL:
            assert r["ir_per_px"] > 0, r
        # The driver's outputs under callgrind equal the cffi run's: same C, same data.
        assert r["digest_match"] is True, r


def test_driver_and_python_registries_agree(quick_run):
    driver = quick_run[3]
    if driver is None:
        pytest.skip("needs a C compiler and valgrind")
    in_driver = bench.driver_stages(driver)
    in_python = {s.name for s in bench.REGISTRY if s.driver}
    assert in_python <= in_driver
    assert set(PRIMITIVES) <= in_python


def test_digest_fold():
    # sum((uint32)v[i] * (i + 1)) mod 2^32, negative values taken mod 2^32.
    assert bench.digest([3, -1, 2]) == (3 * 1 + (2**32 - 1) * 2 + 2 * 3) % 2**32
    assert bench.digest([]) == 0


def test_python_callgrind_counts_a_driverless_stage(tmp_path):
    """A stage without a callgrind_main.c entry gets its instruction count from this
    script under callgrind, collecting inside cffi's wrappers of the library's functions
    (--python-callgrind on). The stage taken, track_frame_edges, nests library calls (the
    tracker step calls the edge-curve measurement, the Kalman filter, ...): its count must
    equal the cffi wrappers' inclusive cost in a run that collects everything, as each
    toggled instruction lies inside a wrapper and every wrapper's callees are counted. The
    old toggle on the library's own names (vt_*) switched collection off inside each nested
    call and counted a small part. Tolerance: 1% (the two runs differ only by where the
    collection switches at the wrappers' entry and exit, a handful of instructions a call;
    the interpreter's own work is outside both)."""
    driver = _build_driver(tmp_path)
    if driver is None:
        pytest.skip("needs a C compiler and valgrind")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    res = subprocess.run([sys.executable, str(ROOT / "bench" / "bench.py"), "--quick", "--stages",
                          "track_frame_edges", "--python-callgrind", "on", "--driver", str(driver),
                          "--workdir", str(tmp_path), "--out", str(tmp_path / "results")],
                         env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    (row,) = json.loads((tmp_path / "results.json").read_text())["rows"]
    assert row["stage"] == "track_frame_edges" and row["ir"] > 10_000 and row["ir_per_px"] > 0, row
    assert "Python under callgrind" in row["note"]
    full = tmp_path / "full.out"
    subprocess.run(["valgrind", "--tool=callgrind", "-q", f"--callgrind-out-file={full}", "--dump-instr=no",
                    sys.executable, str(ROOT / "bench" / "bench.py"), "--cg-one", "track_frame_edges", "--cg-size",
                    row["size"], "--quick"], check=True, capture_output=True, timeout=600, env=env)
    prof = callgrind.parse(full)
    wrappers = [f for f in prof.functions() if f.startswith("_cffi_f_vt_")]
    inclusive = sum(prof.inclusive(f) for f in wrappers)
    # most of the tracker step lies in the library functions it calls: the case the old toggle lost
    (step,) = [f for f in prof.functions() if f == "vt_tracker_step" or f.startswith("vt_tracker_step ")]
    assert prof.inclusive(step) > 3 * prof.self_of(step)
    assert abs(row["ir"] - inclusive) <= 0.01 * inclusive, (row["ir"], inclusive)


def test_cnn_file_stage_is_counted_in_the_callgrind_subprocess(tmp_path):
    """`--cnn-file` benches a CNN file from outside pyvehtrack/models (a training run's
    output) as stage cnn_file_detect; its callgrind column comes from a re-run of bench.py
    in a subprocess, which must register the stage too (through VT_BENCH_CNN_FILE): a
    non-empty instruction count shows it did. A missing file is refused by name."""
    driver = _build_driver(tmp_path)
    if driver is None:
        pytest.skip("needs a C compiler and valgrind")
    env = {k: v for k, v in os.environ.items() if k != "VT_BENCH_CNN_FILE"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    model = ROOT / "pyvehtrack" / "models" / "cnn_gray_l0_e240.npz"
    res = subprocess.run([sys.executable, str(ROOT / "bench" / "bench.py"), "--quick", "--stages",
                          "cnn_file_detect", "--cnn-file", str(model), "--python-callgrind", "on",
                          "--driver", str(driver), "--workdir", str(tmp_path), "--out", str(tmp_path / "results")],
                         env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    (row,) = json.loads((tmp_path / "results.json").read_text())["rows"]
    assert row["stage"] == "cnn_file_detect" and row["ir"] > 10_000, row
    assert str(model) in row["note"]
    bad = subprocess.run([sys.executable, str(ROOT / "bench" / "bench.py"), "--quick", "--stages",
                          "cnn_file_detect", "--cnn-file", str(tmp_path / "missing.npz")],
                         env=env, capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "missing.npz: no such file" in bad.stderr
