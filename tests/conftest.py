"""Shared test helpers: guard-byte buffers, padded views and hypothesis settings."""
from __future__ import annotations

import os

import numpy as np
from hypothesis import HealthCheck, settings

# Derandomized by default, so CI and every developer draw the same examples and a red
# run is reproducible; VT_HYP_RANDOM=1 explores fresh examples (the way the known
# C-vs-oracle rounding cascades in the README's "Known gaps" were found).
settings.register_profile(
    "default", deadline=None, max_examples=int(os.environ.get("VT_HYP_EXAMPLES", "150")),
    derandomize=os.environ.get("VT_HYP_RANDOM", "0") != "1", print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.load_profile("default")

GUARD_U8 = 0xA5


class Guarded:
    """An output array of shape (h, w) living inside a larger buffer: `pad` extra
    columns per row (so the row stride exceeds w) and `rows` extra rows, all filled
    with a sentinel. `intact()` says whether anything outside the view was written."""

    def __init__(self, h: int, w: int, dtype, pad: int = 3, rows: int = 2):
        info = np.iinfo(dtype)
        self.sentinel = np.array(GUARD_U8, dtype=np.int64).clip(info.min, info.max).astype(dtype)
        if np.dtype(dtype).itemsize > 1:
            self.sentinel = np.array(info.max - 7, dtype=dtype)
        self.buf = np.full((h + rows, w + pad), self.sentinel, dtype=dtype)
        self.view = self.buf[:h, :w]

    def intact(self) -> bool:
        h, w = self.view.shape
        return bool((self.buf[:h, w:] == self.sentinel).all() and (self.buf[h:, :] == self.sentinel).all())


def padded_copy(img: np.ndarray, pad: int, fill: int = 77) -> np.ndarray:
    """The same pixels in a view whose row stride is w + pad; the padding holds
    `fill`, which a correct primitive never reads."""
    h, w = img.shape
    big = np.full((h, w + pad), fill, dtype=img.dtype)
    big[:, :w] = img
    return big[:, :w]


# Modules whose tests do not depend on how the cffi extension was built: they build and
# run their own C drivers (with their own sanitizers), the ARM images, or are Python and
# subprocess work (HTML report in Chromium, Dask batch, CLI registry). `make test` runs
# them once, in the first suite; its sanitizer and small-configuration runs set
# VT_SECONDARY_RUN=1 and leave them out, so CI's time goes to what those builds change.
BUILD_INDEPENDENT = {"test_soak", "test_c_ub", "test_determinism", "test_bench", "test_tables",
                     "test_batch", "test_report", "test_house", "test_calibrate", "test_firmware"}


def pytest_collection_modifyitems(config, items):
    if os.environ.get("VT_SECONDARY_RUN") != "1":
        return
    keep, drop = [], []
    for it in items:
        (drop if it.module.__name__.rsplit(".", 1)[-1] in BUILD_INDEPENDENT else keep).append(it)
    if drop:
        config.hook.pytest_deselected(items=drop)
        items[:] = keep
