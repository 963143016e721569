/* fuzz_lane.c -- the lane stage (vehtrack/lane.h, thesis sec. 2.4.1): a
 * configuration mutated from the defaults (check, then detect whatever it
 * says), up to three frames through the lane tracker (sizes may change between
 * frames: a change of working geometry resets it), the road area, and
 * vt_lane_line_x on the lines found and on fuzzed lines (any vertices). */
#include "fuzz.h"
#include "vehtrack/lane.h"

static vt_lane_state g_st;
static vt_lane_result g_res;
static vt_road_area g_road;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    vt_lane_cfg cfg;
    vt_image_u8 img;
    int32_t k, n, i;
    vt_status s;
    fz_status(vt_lane_cfg_default(&cfg));
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_lane_cfg_check(fz_u8(&f) == 0xFF ? NULL : &cfg));
    fz_status(vt_lane_reset(&g_st));
    img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    n = 1 + (fz_u8(&f) % 3);
    for (k = 0; k < n; k++) {
        uint8_t nulls = fz_u8(&f) & (fz_u8(&f) | 0xF0u);
        if (k > 0 && fz_u8(&f) > 200) {
            img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
        }
        s = vt_lane_detect((nulls & 2) ? NULL : &g_st, (nulls & 1) ? NULL : &cfg, &img,
                           (nulls & 4) ? NULL : &g_res, (nulls & 8) ? NULL : &g_road);
        fz_status(s);
        if (s == VT_OK) {
            for (i = 0; i < VT_LANE_SLOTS; i++) {
                vt_q16 x = 0;
                fz_status(vt_lane_line_x(&g_res.lines[i], fz_edge(&f, VT_Q16_ONE * 480), &x));
            }
            if (!(nulls & 8) && g_road.valid) {
                FZ_ASSERT(g_road.y_top >= 0 && g_road.y_top <= g_road.y_bottom && g_road.y_bottom < img.h);
            }
        }
    }
    {
        /* A line struct from the bytes: vertices anywhere, n_verts at its edges. */
        vt_lane_line line;
        vt_q16 x = 0;
        memset(&line, 0, sizeof line);
        line.state = fz_edge(&f, 3);
        line.n_verts = fz_edge(&f, VT_LANE_MAX_VERTS);
        for (i = 0; i < VT_LANE_MAX_VERTS; i++) {
            line.vy[i] = fz_u8(&f) < 200 ? i * 8 : fz_edge(&f, 480);
            line.vx[i] = fz_edge(&f, VT_Q16_ONE * 640);
        }
        fz_status(vt_lane_line_x(fz_u8(&f) == 0xFF ? NULL : &line, fz_edge(&f, VT_Q16_ONE * 480),
                                 fz_u8(&f) == 0xFF ? NULL : &x));
    }
    fz_close(&f);
    return 0;
}
