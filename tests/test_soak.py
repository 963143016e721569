"""Soak (issue 11, item 7), the short version CI runs: tests/c/soak.c drives
the tracker over synthetic frames (vehicles appearing, leaving, occluded,
overlapping, more vehicles than slots) with no Python in the loop and checks
every frame: live tracks bounded, ids never reused or wrapped, counters
saturating, P symmetric with non-negative diagonal and 2x2 minors. Then the
counters are moved next to INT32_MAX and must saturate. `make soak` runs the
long version (SOAK_FRAMES, default 1,000,000).

Here: 4,000 frames under clang's ASan + UBSan (UB fatal), the same with one
track slot (-DVT_MAX_TRACKS=1, the smallest CI configuration), and a second
seed at -O2. tests/c/soak_pipeline.c does the same for the whole pipeline
(vt_pipeline_step / _step_dets: lanes, shadow detection, tracker, camera, the
flow stage and its hand-over), with cars passed by the ego car and overtaking
ones: 1,500 frames under the sanitizers (both configurations) and 5,000 at -O2."""
from __future__ import annotations

import shutil
import subprocess

import pytest

from cbuild import ROOT, SAN, build, clean_env, need, run

SOAK = [ROOT / "tests" / "c" / "soak.c"]
SOAK_PIPE = [ROOT / "tests" / "c" / "soak_pipeline.c"]


@pytest.mark.parametrize("defs", [[], ["-DVT_MAX_TRACKS=1"]], ids=["default", "one-slot"])
def test_soak_short_under_sanitizers(defs):
    exe = build(SOAK, need("clang"), ["-O1", *SAN, *defs], "soak-san" + "".join(defs))
    r = run(exe, "4000", "7", timeout=300)
    assert r.returncode == 0 and "SOAK OK" in r.stdout, r.stdout + r.stderr[-3000:]
    assert "runtime error" not in r.stderr


def test_soak_other_seed_optimised():
    exe = build(SOAK, shutil.which("cc") or need("gcc"), ["-O2"], "soak-O2")
    r = run(exe, "20000", "12345", timeout=300)
    assert r.returncode == 0 and "SOAK OK" in r.stdout, r.stdout + r.stderr[-3000:]


@pytest.mark.parametrize("defs", [[], ["-DVT_MAX_TRACKS=1"]], ids=["default", "one-slot"])
def test_soak_pipeline_short_under_sanitizers(defs):
    exe = build(SOAK_PIPE, need("clang"), ["-O1", *SAN, *defs], "soakp-san" + "".join(defs))
    r = run(exe, "1500", "7", timeout=300)
    assert r.returncode == 0 and "SOAK OK" in r.stdout, r.stdout + r.stderr[-3000:]
    assert "runtime error" not in r.stderr


def test_soak_pipeline_other_seed_optimised():
    exe = build(SOAK_PIPE, shutil.which("cc") or need("gcc"), ["-O2"], "soakp-O2")
    r = run(exe, "5000", "12345", timeout=300)
    assert r.returncode == 0 and "SOAK OK" in r.stdout, r.stdout + r.stderr[-3000:]
    # the scene reaches what it is there for: full slots and hand-overs
    assert "peak live" in r.stdout and "frames with a hand-over 0," not in r.stdout, r.stdout


def test_soak_detects_a_broken_invariant(tmp_path):
    """The checker can fail: a core whose tracker hands out an id twice
    (next_id not advanced) must be caught as reuse."""
    src = (ROOT / "c" / "tracker.c").read_text()
    broken = src.replace("tr->next_id += 1;", "tr->next_id += 0;")
    assert broken != src, "the mutation no longer applies: update this test"
    bad = tmp_path / "c"
    bad.mkdir()
    for f in (ROOT / "c").iterdir():
        if f.is_file():
            (bad / f.name).write_text(broken if f.name == "tracker.c" else f.read_text())
    if (ROOT / "c" / "tables").is_dir():
        shutil.copytree(ROOT / "c" / "tables", bad / "tables")
    exe = tmp_path / "soak-broken"
    cmd = [shutil.which("cc") or need("gcc"), "-std=c99", "-O1", f"-I{ROOT / 'include'}", f"-I{bad}",
           *map(str, SOAK), *map(str, sorted(bad.glob("*.c"))), "-o", str(exe)]
    subprocess.run(cmd, check=True, env=clean_env())
    r = run(exe, "2000", "7")
    assert r.returncode == 1 and ("id reused" in r.stdout or "duplicate id" in r.stdout), r.stdout
