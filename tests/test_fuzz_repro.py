"""Defects the libFuzzer harnesses of the new stages found (issue 11, item 1),
each reduced to a call through the public C API in tests/c/fuzz_repro.c and run
under clang's ASan + UBSan with every error fatal: the run must end with every
case `ok`, no `runtime error`, exit 0."""
from __future__ import annotations

from cbuild import ROOT, SAN, build, need, run


def test_fuzz_repro_under_clang_sanitizers():
    exe = build([ROOT / "tests" / "c" / "fuzz_repro.c"], need("clang"), ["-O1", *SAN], "fuzz_repro")
    r = run(exe)
    assert r.returncode == 0 and "runtime error" not in r.stderr, r.stdout + r.stderr[-3000:]
    assert "FAIL" not in r.stdout, r.stdout
    assert r.stdout.count("ok ") >= 5, r.stdout
