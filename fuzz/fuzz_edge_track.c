/* fuzz-requires: vehtrack/edge_track.h
 * fuzz_edge_track.c -- the GIST paper's edge-curve tracking measurement
 * (vehtrack/edge_track.h; GIST paper sec. III.B): the configuration mutated
 * from the bytes (checked as drawn; for the match itself radius and scale
 * steps are cut to 6 and 2 so one input stays fast -- the loops are the same at
 * any size), edge maps of any crop of a fuzzed view (outside, inverted, over
 * capacity, coordinates at the +-4 VT_MAX limit and past it), templates taken
 * from the map or written from the bytes (n past capacity, points anywhere,
 * boxes inverted), matches around any predicted displacement, and
 * vt_edge_scale on any value and scale. The workspace is marked empty before
 * each input so no state carries over. */
#include "fuzz.h"
#include "vehtrack/edge_track.h"

static vt_edge_ws g_ws;
static vt_edge_template g_tpl;

static vt_box box(fz *f, int32_t w, int32_t h)
{
    vt_box b;
    uint8_t k = fz_u8(f);
    if (k < 200) {
        return fz_box_near(f, w, h, 64, 64);
    }
    if (k < 230) { /* at and past the +-4 VT_MAX limits */
        b.left = fz_near(f, -4 * VT_MAX_WIDTH, -1, 1);
        b.top = fz_near(f, -4 * VT_MAX_HEIGHT, -1, 1);
        b.right = fz_near(f, 4 * VT_MAX_WIDTH, -1, 1);
        b.bottom = fz_near(f, 4 * VT_MAX_HEIGHT, -1, 1);
        return b;
    }
    return fz_box_edge(f, w, h);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t nulls = fz_u8(&f) & (fz_u8(&f) | 0xC0u);
    vt_edge_cfg cfg;
    vt_image_u8 img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    int32_t w = img.w > 0 && img.w <= VT_MAX_WIDTH ? img.w : 64;
    int32_t h = img.h > 0 && img.h <= VT_MAX_HEIGHT ? img.h : 48;
    int32_t i, n = -1;
    vt_box roi = box(&f, w, h);
    vt_status s;
    g_ws.w = g_ws.h = 0; /* no crop from an earlier input */
    fz_status(vt_edge_cfg_default((nulls & 128) ? NULL : &cfg));
    fz_status(vt_edge_cfg_default(&cfg));
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_edge_cfg_check(&cfg));
    if (cfg.radius > 6) {
        cfg.radius = cfg.radius % 7;
    }
    if (cfg.scale_steps > 2) {
        cfg.scale_steps = cfg.scale_steps % 3;
    }
    s = vt_edge_map((nulls & 8) ? NULL : &g_ws, (nulls & 2) ? NULL : &cfg, (nulls & 1) ? NULL : &img,
                    (nulls & 4) ? NULL : &roi);
    fz_status(s);
    if (s == VT_OK) {
        FZ_ASSERT(g_ws.w >= 1 && g_ws.h >= 1 && (int64_t)g_ws.w * g_ws.h <= VT_EDGE_MAX_PIXELS);
        FZ_ASSERT(g_ws.n_curve >= 0 && g_ws.n_curve <= g_ws.w * g_ws.h && g_ws.n_curves >= 0);
    }
    if (fz_u8(&f) < 160) { /* a template from the map */
        vt_box b = box(&f, w, h);
        s = vt_edge_template_set((nulls & 16) ? NULL : &g_ws, &b, (nulls & 32) ? NULL : &g_tpl,
                                 (fz_u8(&f) & 1) ? NULL : &n);
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT(g_tpl.n >= 0 && g_tpl.n <= VT_EDGE_MAX_POINTS);
        }
    } else { /* a template from the bytes */
        g_tpl.n = fz_u8(&f) < 220 ? fz_range(&f, 0, 40) : fz_edge(&f, VT_EDGE_MAX_POINTS);
        g_tpl.box = box(&f, w, h);
        for (i = 0; i < VT_EDGE_MAX_POINTS; i++) {
            g_tpl.x[i] = (int16_t)(i < 40 ? fz_range(&f, -4, w + 4) : (int32_t)(i * 37 % (w + 8)) - 4);
            g_tpl.y[i] = (int16_t)(i < 40 ? fz_range(&f, -4, h + 4) : (int32_t)(i * 53 % (h + 8)) - 4);
        }
    }
    {
        int32_t cx = fz_u8(&f) < 220 ? fz_range(&f, -8, 8) : fz_edge(&f, 8192);
        int32_t cy = fz_u8(&f) < 220 ? fz_range(&f, -8, 8) : fz_edge(&f, 8192);
        int32_t dx = 0, dy = 0, sc = 0, score = -1, found = -1;
        s = vt_edge_match((nulls & 16) ? NULL : &g_ws, (nulls & 2) ? NULL : &cfg, (nulls & 32) ? NULL : &g_tpl,
                          cx, cy, (nulls & 64) ? NULL : &dx, &dy, &sc, &score, &found);
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT(found == 0 || found == 1);
            if (g_tpl.n >= 1) {
                FZ_ASSERT(dx >= cx - cfg.radius && dx <= cx + cfg.radius && dy >= cy - cfg.radius &&
                          dy <= cy + cfg.radius);
                FZ_ASSERT(score >= 0 && score <= 1000 * VT_EDGE_MAX_POINTS);
            }
        }
    }
    {
        int32_t v = fz_u8(&f) < 200 ? fz_range(&f, -(1 << 20), 1 << 20) : fz_edge(&f, 1 << 20);
        int32_t sq = fz_u8(&f) < 200 ? fz_range(&f, 0, 512) : fz_raw_i32(&f), o = 0;
        fz_status(vt_edge_scale(v, sq, (nulls & 64) ? NULL : &o));
    }
    fz_close(&f);
    return 0;
}
