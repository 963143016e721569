/* fuzz_detect.c -- vehicle detection (vehtrack/shadow.h, verify.h, detect.h;
 * thesis sec. 2.4.2): shadow hypotheses in a road area, vertical-edge
 * verification of any hypotheses, and the two together. The road area is
 * caller-owned, so every field comes from the bytes (rows out of the frame,
 * crossed boundaries, height not the frame's); capacities and NULLs too. A
 * returned box or hypothesis count never exceeds the capacity given. */
#include "fuzz.h"
#include "vehtrack/detect.h"

static vt_detect_state g_st;
static vt_road_area g_road;
static vt_detect_result g_out;
static vt_hypothesis g_hyp[VT_MAX_HYPOTHESES + 4];
static vt_box g_box[VT_MAX_BOXES + 4];

static void road(fz *f, const vt_image_u8 *img)
{
    int32_t y, h = img->h > 0 && img->h <= VT_MAX_HEIGHT ? img->h : 1;
    int32_t w = img->w > 0 && img->w <= VT_MAX_WIDTH ? img->w : 1;
    uint8_t plausible = fz_u8(f) < 200;
    g_road.valid = plausible ? 1 : fz_edge(f, 1);
    g_road.height = plausible ? h : fz_edge(f, h);
    g_road.y_top = plausible ? fz_range(f, 0, h - 1) : fz_edge(f, h);
    g_road.y_bottom = plausible ? fz_range(f, g_road.y_top, h - 1) : fz_edge(f, h);
    for (y = 0; y < VT_MAX_HEIGHT; y++) {
        if (plausible) {
            g_road.x_left[y] = (int16_t)(w / 4);
            g_road.x_right[y] = (int16_t)(w - 1 - w / 4);
            g_road.lane_width[y] = (int16_t)(w / 2);
        } else {
            g_road.x_left[y] = (int16_t)fz_raw_i32(f);
            g_road.x_right[y] = (int16_t)fz_raw_i32(f);
            g_road.lane_width[y] = (int16_t)fz_raw_i32(f);
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    vt_detect_cfg cfg;
    vt_image_u8 img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    uint8_t op = fz_u8(&f) % 3u, nulls = fz_u8(&f) & (fz_u8(&f) | 0xE0u);
    int32_t n = -1, cap, i;
    vt_status s;
    fz_status(vt_detect_cfg_default(&cfg));
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_detect_cfg_check((nulls & 64) ? NULL : &cfg));
    road(&f, &img);
    if (op == 0) {
        cap = fz_u8(&f) < 220 ? VT_MAX_HYPOTHESES : fz_range(&f, -1, VT_MAX_HYPOTHESES + 4);
        s = vt_shadow_find((nulls & 1) ? NULL : &g_st.shadow, (nulls & 2) ? NULL : &cfg.shadow, &img,
                           (nulls & 4) ? NULL : &g_road, (nulls & 8) ? NULL : g_hyp, cap,
                           (nulls & 16) ? NULL : &n);
        fz_status(s);
        if (s == VT_OK || s == VT_E_CAPACITY) {
            FZ_ASSERT(n >= 0 && n <= cap);
        }
    } else if (op == 1) {
        int32_t n_hyp = fz_u8(&f) < 230 ? (fz_u8(&f) & 7) : fz_edge(&f, VT_MAX_HYPOTHESES);
        int32_t hh = img.h > 0 && img.h <= VT_MAX_HEIGHT ? img.h : 64;
        int32_t ww = img.w > 0 && img.w <= VT_MAX_WIDTH ? img.w : 64;
        for (i = 0; i < VT_MAX_HYPOTHESES + 4; i++) {
            if (fz_u8(&f) < 220) {
                g_hyp[i].row = fz_range(&f, -2, hh + 2);
                g_hyp[i].x_start = fz_range(&f, -2, ww + 2);
                g_hyp[i].x_end = fz_near(&f, g_hyp[i].x_start, -2, 64);
            } else {
                g_hyp[i].row = fz_edge(&f, img.h);
                g_hyp[i].x_start = fz_edge(&f, img.w);
                g_hyp[i].x_end = fz_edge(&f, img.w);
            }
        }
        cap = fz_u8(&f) < 220 ? VT_MAX_BOXES : fz_range(&f, -1, VT_MAX_BOXES + 4);
        if (n_hyp > VT_MAX_HYPOTHESES + 4) {
            n_hyp = VT_MAX_HYPOTHESES + 4;
        }
        s = vt_verify((nulls & 1) ? NULL : &g_st.verify, (nulls & 2) ? NULL : &cfg.verify, &img,
                      (nulls & 4) ? NULL : g_hyp, n_hyp, (nulls & 8) ? NULL : g_box, cap,
                      (nulls & 16) ? NULL : &n);
        fz_status(s);
        if (s == VT_OK || s == VT_E_CAPACITY) {
            FZ_ASSERT(n >= 0 && n <= cap);
            for (i = 0; i < n; i++) {
                FZ_ASSERT(g_box[i].left <= g_box[i].right && g_box[i].top <= g_box[i].bottom);
            }
        }
    } else {
        s = vt_detect((nulls & 1) ? NULL : &g_st, (nulls & 2) ? NULL : &cfg, &img,
                      (nulls & 4) ? NULL : &g_road, (nulls & 8) ? NULL : &g_out);
        fz_status(s);
        if (s == VT_OK || s == VT_E_CAPACITY) {
            FZ_ASSERT(g_out.n_hyp >= 0 && g_out.n_hyp <= VT_MAX_HYPOTHESES);
            FZ_ASSERT(g_out.n_boxes >= 0 && g_out.n_boxes <= VT_MAX_BOXES);
        }
    }
    fz_close(&f);
    return 0;
}
