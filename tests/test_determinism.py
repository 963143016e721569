"""Determinism matrix (issue 11, item 6): the same end-to-end run gives the same
bits under every compiler, optimisation level, word size and core.

The run is firmware_demo/main.c itself: its checksums of every primitive on a
real frame, then lanes -> detection -> tracking over five real KITTI frames
(road areas, boxes, tracks with Q16 velocities, and their FNV-1a digests), and
again with every source (classifier, flow, block TTC, the GA vehicle model), then
the CNN detector's boxes on a synthetic frame (`cnn` / `cnn_box` lines). On
the host it is linked with tests/c/board_host.c (stdio instead of semihosting)
and built, without Python, with the images' capacity flags (`make firmware-caps`)
under gcc -O0, gcc -O3, clang -O2,
clang -O3 -march=native and gcc -m32 -O2; on ARM it is the Cortex-M3 and
Cortex-M7 images under QEMU (`make firmware-run`). Every `checksum` line and
every pipeline line must be identical across all of them: no tolerance, as the
core is integer-only. (Lines that measure the machine -- insns, ram, stack,
sizeof -- legitimately differ and are not compared.)

The second run, tests/c/determinism_stages.c, covers the stages main.c does not
run: classifier decisions on every window of a band (HOG blocks, SVM scores,
GIST descriptors, MLP scores), whole-road detection boxes (fulldet with the HOG
scorer), flow vectors of every cell and the overtaking / hand-over hypotheses,
the GA's best model and last generation (detection, then tracking), and camera
distances, the pitch filter and the range stage's distance / rate / TTC / FCW.
Each is one FNV-1a digest line `stage NAME 0x...`; they must be identical under
the same host matrix and on Cortex-M3 / M7 images of the same driver under QEMU
(built here with the firmware's flags, link script and board). gcc -O3 builds
with -Wall -Wextra -Werror, so -Wmaybe-uninitialized is an error there.
"""
from __future__ import annotations

import hashlib
import re
import shutil
import subprocess

import pytest

from cbuild import ROOT, build, clean_env, need, run
from test_firmware import _require_tools, fw_caps, parse_run

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
COMPARED = re.compile(r"(checksum|clip|road|boxes|box|model|tracks|track|cnn|cnn_box) ")


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
        out[core] = [f"checksum {n} 0x{v:08x}" for n, v in info["checksums"]] + info["pipeline"] + info["cnn"]
    assert set(out) == {"cortex-m3", "cortex-m7"}, sorted(out)
    return out


@pytest.fixture(scope="module")
def caps():
    """The images' capacity flags (firmware.mk's FW_CAPS, FW_DEFS): the host builds of
    main.c use the same, or their lines would be compared across configurations."""
    return fw_caps()


@pytest.fixture(scope="module")
def host_lines(caps):
    out = {}
    for name, (cc, flags) in MATRIX.items():
        need(cc)
        if "-m32" in flags and not _multilib_ok():
            pytest.skip("gcc -m32 cannot link: install gcc-multilib (make setup)")
        exe = build(SOURCES, shutil.which(cc), [*flags, *COMMON, *caps], "fwhost-" + re.sub(r"\W+", "_", name))
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


def test_word_size_really_differs(caps):
    """The -m32 build is a 32-bit build (pointers of 4 bytes), so the matrix
    covers a second ABI and not the same binary twice."""
    if not _multilib_ok():
        pytest.skip("gcc -m32 cannot link: install gcc-multilib (make setup)")
    exe = build(SOURCES, shutil.which("gcc"), ["-m32", "-O2", *COMMON, *caps], "fwhost-gcc_m32_O2")
    r = run(exe)
    sizes = dict(re.findall(r"^sizeof (\S+) (\d+)$", r.stdout, re.M))
    assert sizes["vt_image_u8"] == "16", sizes  # 4-byte pointer + 3 int32


# ------------------------------------------------------------ the new stages
STAGES_SOURCES = [ROOT / "tests" / "c" / "determinism_stages.c", ROOT / "tests" / "c" / "board_host.c"]
# The clip's size as the capacities: the states then fit the boards' 4 MB of RAM.
STAGES_DEFS = ["-DVT_MAX_WIDTH=640", "-DVT_MAX_HEIGHT=256"]
STAGE_LINE = re.compile(r"^stage (\w+) (0x[0-9a-f]{8})$", re.M)
STAGE_NAMES = {"classify", "fulldet", "flow", "model", "camera"}
# firmware_demo/firmware.mk's flags: the Makefile's STRICT set, -O2, the cores.
FW_STRICT = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-Wshadow", "-Wstrict-prototypes",
             "-Wmissing-prototypes", "-Wcast-qual", "-Wdouble-promotion", "-Wfloat-equal"]
FW_CORES = {
    "cortex-m3": (["-mcpu=cortex-m3", "-mthumb", "-mfloat-abi=soft"], "mps2-an385"),
    "cortex-m7": (["-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard"], "mps2-an500"),
}


def stage_digests(text: str) -> dict[str, str]:
    return dict(STAGE_LINE.findall(text))


@pytest.fixture(scope="module")
def stages_host():
    out = {}
    for name, (cc, flags) in MATRIX.items():
        need(cc)
        if "-m32" in flags and not _multilib_ok():
            pytest.skip("gcc -m32 cannot link: install gcc-multilib (make setup)")
        exe = build(STAGES_SOURCES, shutil.which(cc), [*flags, *STAGES_DEFS, f"-I{FW}"],
                    "stages-" + re.sub(r"\W+", "_", name))
        r = run(exe)
        assert r.returncode == 0 and r.stdout.rstrip().endswith("done"), f"{name}: {r.stdout[-2000:]}{r.stderr[-2000:]}"
        out[name] = r.stdout
    return out


def _arm_image(core: str) -> "Path":
    arch, _ = FW_CORES[core]
    cc = "arm-none-eabi-gcc"
    srcs = [*sorted((ROOT / "c").glob("*.c")), ROOT / "tests" / "c" / "determinism_stages.c"]
    deps = [*srcs, FW / "board.c", FW / "board.h", FW / "link.ld", FW / "clip_data.h",
            *sorted((ROOT / "include" / "vehtrack").glob("*.h")), *sorted((ROOT / "c").glob("*.h")),
            *sorted((ROOT / "c" / "tables").glob("*.h"))]
    h = hashlib.sha256(" ".join([core, *arch, *FW_STRICT, *STAGES_DEFS]).encode())
    for f in deps:
        h.update(f.read_bytes())
    out_dir = ROOT / "build" / "cdrivers" / f"stages-{core}-{h.hexdigest()[:16]}"
    elf = out_dir / "stages.elf"
    if elf.exists():
        return elf
    out_dir.mkdir(parents=True, exist_ok=True)
    env = clean_env()
    common = [*FW_STRICT, "-O2", "-ffunction-sections", "-fdata-sections", *arch]
    for src in srcs:
        subprocess.run([cc, *common, *STAGES_DEFS, f"-I{ROOT / 'include'}", f"-I{FW}", "-c", str(src),
                        "-o", str(out_dir / (src.stem + ".o"))], check=True, env=env, capture_output=True)
    subprocess.run([cc, *common, "-ffreestanding", "-fno-tree-loop-distribute-patterns", f"-I{FW}", "-c",
                    str(FW / "board.c"), "-o", str(out_dir / "fw_board.o")], check=True, env=env,
                   capture_output=True)
    subprocess.run([cc, *arch, "-nostdlib", "-nostartfiles", "-T", str(FW / "link.ld"), "-Wl,--gc-sections",
                    "-o", str(elf), *map(str, sorted(out_dir.glob("*.o"))), "-lgcc"], check=True, env=env,
                   capture_output=True)
    return elf


@pytest.fixture(scope="module")
def stages_arm():
    _require_tools()
    out = {}
    for core, (_, board) in FW_CORES.items():
        elf = _arm_image(core)
        r = subprocess.run(["timeout", "300", "qemu-system-arm", "-M", board, "-nographic", "-monitor", "none",
                            "-semihosting-config", "enable=on,target=native", "-kernel", str(elf)],
                           stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           timeout=320, env=clean_env())
        assert r.returncode == 0 and r.stdout.rstrip().endswith("done"), f"{core}: {r.stdout[-3000:]}"
        out[core] = r.stdout
    return out


def test_stages_host_matrix_is_bit_identical(stages_host):
    ref_name = "gcc -O0"
    ref = stage_digests(stages_host[ref_name])
    assert set(ref) == STAGE_NAMES, ref
    # The stages must have done something, or equal digests would prove little.
    text = stages_host[ref_name]
    fd = re.search(r"^fulldet (\d+) (\d+) (\d+) (\d+)$", text, re.M)
    assert fd and int(fd.group(1)) > 0 and int(fd.group(2)) > 100, text
    cw = re.search(r"^classify_windows (\d+) (\d+) (\d+)", text, re.M)
    assert cw and int(cw.group(1)) * int(cw.group(2)) > 100, text
    fl = re.search(r"^flow (\d+) (\d+)", text, re.M)
    assert fl and int(fl.group(2)) > 0, text  # some cells found a vector
    fcw = re.search(r"^camera_fcw (-?\d+)", text, re.M)
    assert fcw and int(fcw.group(1)) >= 0, text  # the approaching car raised a warning
    for name, out in stages_host.items():
        assert stage_digests(out) == ref, f"{name} differs from {ref_name}"


def test_stages_arm_images_match_the_host(stages_host, stages_arm):
    ref = stage_digests(stages_host["gcc -O0"])
    for core, text in stages_arm.items():
        assert stage_digests(text) == ref, core
