/* fuzz-requires: vehtrack/hood.h
 * fuzz_hood.c -- the hood finder (vehtrack/hood.h; issue 8 item 4, hood rows excluded):
 * its settings from the bytes (every field mutated, past its domain sometimes), any
 * frame (1 px to the maxima, padded strides, NULL pixels) and NULL arguments. A found
 * hood lies in the searched band; the counts are bounded by the sampled columns; on an
 * error the result says "none". */
#include "fuzz.h"
#include "vehtrack/hood.h"

static vt_hood_state g_st;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t nulls = fz_u8(&f) & (fz_u8(&f) | 0xF0u);
    vt_hood_cfg cfg;
    vt_hood_result res;
    vt_image_u8 img;
    vt_status s;
    fz_status(vt_hood_cfg_default(&cfg));
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_hood_cfg_check((nulls & 1) ? NULL : &cfg));
    img = fz_image_u8_small(&f, 96, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    res.found = 7;
    s = vt_hood_find((nulls & 2) ? NULL : &g_st, (nulls & 4) ? NULL : &cfg, (nulls & 8) ? NULL : &img,
                     (nulls & 16) ? NULL : &res);
    fz_status(s);
    if (!(nulls & 16)) {
        if (s != VT_OK) {
            FZ_ASSERT(res.found == 0 && res.row == -1 && res.n_cols == 0 && res.n_strong == 0 &&
                      res.path_end == -1);
        } else {
            int32_t y0 = (int32_t)(((int64_t)img.h * cfg.band_top_permille) / 1000);
            y0 = y0 < 1 ? 1 : y0;
            FZ_ASSERT(res.found == 0 || res.found == 1);
            FZ_ASSERT(res.n_strong >= 0 && res.n_strong <= res.n_cols && res.n_cols <= img.w);
            if (res.found) {
                FZ_ASSERT(res.row >= y0 && res.row <= img.h - 2 && res.n_strong > 0);
                FZ_ASSERT(res.path_end >= y0 && res.path_end <= img.h - 2);
            } else {
                FZ_ASSERT(res.row == -1);
            }
        }
    }
    fz_close(&f);
    return 0;
}
