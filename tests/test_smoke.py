import numpy as np

import pyvehtrack as vt


def test_import_and_version():
    assert vt.MAX_WIDTH >= 640
    a = np.arange(12, dtype=np.uint8).reshape(3, 4)
    assert vt.image.sobel_x(a).dtype == np.int16
