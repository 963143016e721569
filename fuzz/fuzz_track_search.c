/* fuzz_track_search.c -- the tracker's measurement (vehtrack/track_search.h,
 * thesis sec. 3.6.1): any image view, configuration, ROI (edges of int32
 * included) and side memory; a found box must lie inside the image. */
#include "fuzz.h"
#include "vehtrack/track_search.h"

static vt_track_search_ws g_ws;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    vt_image_u8 img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    vt_track_search_cfg cfg;
    vt_track_sides sides;
    vt_box roi, meas;
    int32_t found = -1;
    vt_status s;
    uint8_t nulls = fz_u8(&f) & (fz_u8(&f) | 0x80u); /* NULLs now and then */
    {
        static const vt_track_search_cfg def = VT_TRACK_SEARCH_CFG_DEFAULT;
        cfg = def;
    }
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    roi.left = fz_edge(&f, img.w);
    roi.top = fz_edge(&f, img.h);
    roi.right = fz_u8(&f) < 200 ? fz_near(&f, roi.left, -2, 64) : fz_edge(&f, img.w);
    roi.bottom = fz_u8(&f) < 200 ? fz_near(&f, roi.top, -2, 64) : fz_edge(&f, img.h);
    sides.have_prev = fz_u8(&f) & 1;
    sides.prev_left = fz_edge(&f, img.w);
    sides.prev_right = fz_edge(&f, img.w);
    sides.max_change_left = fz_edge(&f, 64);
    sides.max_change_right = fz_edge(&f, 64);
    fz_status(vt_track_search_cfg_check((nulls & 64) ? NULL : &cfg));
    s = vt_track_search((nulls & 8) ? NULL : &g_ws, (nulls & 4) ? NULL : &sides,
                        (nulls & 1) ? NULL : &cfg, &img, (nulls & 2) ? NULL : &roi,
                        (nulls & 16) ? NULL : &meas, (nulls & 32) ? NULL : &found);
    fz_status(s);
    if (s == VT_OK && found == 1) {
        FZ_ASSERT(meas.left >= 0 && meas.left <= meas.right && meas.right < img.w);
        FZ_ASSERT(meas.top <= meas.bottom && meas.bottom < img.h);
    }
    fz_close(&f);
    return 0;
}
