"""Build and run small C drivers (tests/c/*.c) against the core, without Python
in the loop: the UB repro, the determinism matrix and the soak run use it.

`build(driver, cc, flags)` compiles the driver with every c/*.c into a cache dir
keyed by the sources' content and the command, so a second call is free; `run()`
executes it with an environment free of the sanitizer runtime that
`make check SAN=1` preloads into this Python process (a binary carries its own).
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CORE = sorted((ROOT / "c").glob("*.c"))
HEADERS = sorted((ROOT / "include" / "vehtrack").glob("*.h")) + sorted((ROOT / "c").glob("*.h")) \
    + sorted((ROOT / "c" / "tables").glob("*.h"))
CACHE = ROOT / "build" / "cdrivers"
SETUP_HINT = "run `make setup` (apt-get install clang libclang-rt-14-dev gcc-multilib)"

# clang's UBSan flags the signed negations gcc 12's does not; UB is fatal.
SAN = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", "-g"]


def clean_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items()
            if k not in ("LD_PRELOAD", "ASAN_OPTIONS", "UBSAN_OPTIONS")}


def need(tool: str) -> str:
    path = shutil.which(tool)
    if path is None:
        pytest.fail(f"{tool} not found: {SETUP_HINT}", pytrace=False)
    return path


def build(sources: list[Path], cc: str, flags: list[str], name: str, extra_inc: list[Path] = ()) -> Path:
    """Compile `sources` + the core with `cc flags`; returns the executable."""
    cmd_tail = ["-std=c99", "-Wall", "-Wextra", "-Werror", *flags, f"-I{ROOT / 'include'}",
                *[f"-I{p}" for p in extra_inc]]
    h = hashlib.sha256(" ".join([cc, *cmd_tail]).encode())
    for f in [*sources, *CORE, *HEADERS]:
        h.update(f.read_bytes())
    out = CACHE / f"{name}-{h.hexdigest()[:16]}"
    if out.exists():
        return out
    CACHE.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    cmd = [cc, *cmd_tail, *map(str, sources), *map(str, CORE), "-o", str(tmp)]
    r = subprocess.run(cmd, capture_output=True, text=True, env=clean_env())
    if r.returncode != 0:
        raise AssertionError(f"build failed: {' '.join(cmd)}\n{r.stderr[-4000:]}")
    tmp.replace(out)
    return out


def run(exe: Path, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    env = clean_env()
    env["ASAN_OPTIONS"] = "detect_leaks=0:abort_on_error=0"
    env["UBSAN_OPTIONS"] = "print_stacktrace=1:halt_on_error=1"
    return subprocess.run([str(exe), *args], capture_output=True, text=True, env=env, timeout=timeout)
