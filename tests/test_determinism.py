"""Determinism matrix (issue 11, item 6): the same end-to-end run gives the same
bits under every compiler, optimisation level, word size and core.

The run is firmware_demo/main.c itself: its checksums of every primitive on a
real frame, then lanes -> detection -> tracking over three real KITTI frames
(road areas, boxes, tracks with Q16 velocities, and their FNV-1a digests). On
the host it is linked with tests/c/board_host.c (stdio instead of semihosting)
and built, without Python, under gcc -O0, gcc -O3, clang -O2,
clang -O3 -march=native and gcc -m32 -O2; on ARM it is the Cortex-M3 and
Cortex-M7 images under QEMU (`make firmware-run`). Every `checksum` line and
every pipeline line must be identical across all of them: no tolerance, as the
core is integer-only. (Lines that measure the machine -- insns, ram, stack,
sizeof -- legitimately differ and are not compared.)
"""
from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from cbuild import ROOT, build, clean_env, need, run
from test_firmware import _require_tools, parse_run

FW = ROOT / "firmware_demo"
SOURCES = [FW / "main.c", ROOT / "tests" / "c" / "board_host.c"]
COMMON = ["-DFW_CORE_NAME=\"host\"", f"-I{FW}"]
MATRIX = {
    "gcc -O0": ("gcc", ["-O0"]),
    "gcc -O3": ("gcc", ["-O3"]),
    "clang -O2": ("clang", ["-O2"]),
    "clang -O3 -march=native": ("clang", ["-O3", "-march=native"]),
    "gcc -m32 -O2": ("gcc", ["-m32", "-O2"]),
}
COMPARED = re.compile(r"(checksum|clip|road|boxes|box|tracks|track) ")


def digest_lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if COMPARED.match(ln)]


def _multilib_ok() -> bool:
    probe = subprocess.run(["gcc", "-m32", "-x", "c", "-", "-o", "/dev/null"], input="int main(void){return 0;}",
                           capture_output=True, text=True, env=clean_env())
    return probe.returncode == 0


@pytest.fixture(scope="module")
def qemu_lines():
    _require_tools()
    proc = subprocess.run(["make", "--no-print-directory", "firmware-run"], cwd=ROOT,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=900, env=clean_env())
    assert proc.returncode == 0, proc.stdout[-4000:]
    out = {}
    for core, info in parse_run(proc.stdout).items():
        assert info["done"], f"{core} did not finish"
        out[core] = [f"checksum {n} 0x{v:08x}" for n, v in info["checksums"]] + info["pipeline"]
    assert set(out) == {"cortex-m3", "cortex-m7"}, sorted(out)
    return out


@pytest.fixture(scope="module")
def host_lines():
    out = {}
    for name, (cc, flags) in MATRIX.items():
        need(cc)
        if "-m32" in flags and not _multilib_ok():
            pytest.skip("gcc -m32 cannot link: install gcc-multilib (make setup)")
        exe = build(SOURCES, shutil.which(cc), [*flags, *COMMON], "fwhost-" + re.sub(r"\W+", "_", name))
        r = run(exe)
        assert r.returncode == 0 and r.stdout.rstrip().endswith("done"), f"{name}: {r.stderr[-2000:]}"
        out[name] = r.stdout
    return out


def test_host_matrix_is_bit_identical(host_lines):
    ref_name = "gcc -O0"
    ref = digest_lines(host_lines[ref_name])
    # The run must exercise the whole pipeline, or equal digests would prove little.
    assert any(ln.startswith("box ") for ln in ref) and any(ln.startswith("track ") for ln in ref)
    assert sum(ln.startswith("checksum ") for ln in ref) >= 18
    for name, text in host_lines.items():
        assert digest_lines(text) == ref, f"{name} differs from {ref_name}"


def test_arm_images_match_the_host(host_lines, qemu_lines):
    ref = digest_lines(host_lines["gcc -O0"])
    for core, lines in qemu_lines.items():
        # QEMU prints the pipeline lines and checksums interleaved as the host
        # does; compare as sets of ordered sub-sequences.
        assert [ln for ln in ref if ln.startswith("checksum ")] == \
            [ln for ln in lines if ln.startswith("checksum ")], core
        assert [ln for ln in ref if not ln.startswith("checksum ")] == \
            [ln for ln in lines if not ln.startswith("checksum ")], core


def test_word_size_really_differs():
    """The -m32 build is a 32-bit build (pointers of 4 bytes), so the matrix
    covers a second ABI and not the same binary twice."""
    if not _multilib_ok():
        pytest.skip("gcc -m32 cannot link: install gcc-multilib (make setup)")
    exe = build(SOURCES, shutil.which("gcc"), ["-m32", "-O2", *COMMON], "fwhost-gcc_m32_O2")
    r = run(exe)
    sizes = dict(re.findall(r"^sizeof (\S+) (\d+)$", r.stdout, re.M))
    assert sizes["vt_image_u8"] == "16", sizes  # 4-byte pointer + 3 int32
