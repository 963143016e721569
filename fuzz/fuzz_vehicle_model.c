/* fuzz-requires: vehtrack/vehicle_model.h
 * fuzz_vehicle_model.c -- the seven-parameter vehicle model searched by a genetic
 * algorithm (vehtrack/vehicle_model.h; thesis sec. 2.6, Table 1): every field of
 * the configuration from the bytes (checked as drawn), then, for the search
 * itself, populations and generations cut to at most 12 x 3 per level so one
 * input stays fast (the check already saw the drawn values; the GA's loops are
 * the same at any size); the road constraint from two fuzzed rows, expected
 * widths of any row, a search ROI (out of the frame, inverted, empty, over
 * capacity) or one made from a fuzzed flow hypothesis, tracking mode with
 * fuzzed predictions and sigmas, prepare + fitness of any parameter set at any
 * level, and the fit. After a fit: the best box follows from the best
 * parameters as documented and the population within capacity. */
#include "fuzz.h"
#include "vehtrack/vehicle_model.h"

static vt_model_ws g_ws;

static void params(fz *f, vt_model_params *p, int32_t w, int32_t h)
{
    if (fz_u8(f) < 200) {
        p->x = fz_range(f, -4, w + 4);
        p->y = fz_range(f, -4, h + 4);
        p->w = fz_range(f, 0, w + 4);
        p->h = fz_range(f, 0, h + 4);
        p->wind = fz_range(f, 0, 100);
        p->bump = fz_range(f, 0, 100);
        p->roof = fz_range(f, 0, 50);
    } else {
        p->x = fz_edge(f, w);
        p->y = fz_edge(f, h);
        p->w = fz_edge(f, w);
        p->h = fz_edge(f, h);
        p->wind = fz_edge(f, 100);
        p->bump = fz_edge(f, 100);
        p->roof = fz_edge(f, 100);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t op, nulls = fz_u8(&f) & (fz_u8(&f) | 0xE0u);
    vt_model_cfg cfg;
    vt_model_search se;
    vt_model_result res;
    vt_image_u8 img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    int32_t w = img.w > 0 && img.w <= VT_MAX_WIDTH ? img.w : 64;
    int32_t h = img.h > 0 && img.h <= VT_MAX_HEIGHT ? img.h : 48;
    int32_t i, j, ew = -1;
    vt_status s;
    fz_status(vt_model_cfg_default(&cfg));
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_model_cfg_check((nulls & 128) ? NULL : &cfg));
    for (i = 0; i < 2; i++) { /* population x generations bounded for speed */
        for (j = 0; j < VT_MODEL_LEVELS; j++) {
            if (cfg.pop[i][j] > 12) {
                cfg.pop[i][j] = 2 + cfg.pop[i][j] % 11;
            }
            if (cfg.gens[i][j] > 3) {
                cfg.gens[i][j] = cfg.gens[i][j] % 4;
            }
        }
    }
    if (fz_u8(&f) < 128) { /* the road from two rows */
        int32_t y0 = fz_u8(&f) < 200 ? fz_range(&f, -h, h) : fz_edge(&f, h);
        int32_t y1 = fz_u8(&f) < 200 ? fz_range(&f, -h, h) : fz_edge(&f, h);
        int32_t w0 = fz_u8(&f) < 200 ? fz_range(&f, 0, w) : fz_edge(&f, VT_MAX_WIDTH);
        int32_t w1 = fz_u8(&f) < 200 ? fz_range(&f, 0, w) : fz_edge(&f, VT_MAX_WIDTH);
        vt_model_cfg keep = cfg;
        s = vt_model_cfg_road((nulls & 1) ? NULL : &cfg, y0, w0, y1, w1);
        fz_status(s);
        if (s != VT_OK) {
            cfg = keep;
        }
    }
    s = vt_model_expected_width((nulls & 1) ? NULL : &cfg, fz_u8(&f) < 200 ? fz_range(&f, -h, 2 * h) : fz_raw_i32(&f),
                                (nulls & 2) ? NULL : &ew);
    fz_status(s);
    if (s == VT_OK) {
        FZ_ASSERT(ew >= 0 && ew <= VT_MAX_WIDTH);
    }
    op = fz_u8(&f);
    memset(&se, 0, sizeof se);
    if (op & 1) { /* from a flow hypothesis */
        vt_flow_hyp hy;
        memset(&hy, 0, sizeof hy);
        hy.box.left = fz_u8(&f) < 200 ? fz_range(&f, -4, w) : fz_edge(&f, w);
        hy.box.top = fz_u8(&f) < 200 ? fz_range(&f, -4, h) : fz_edge(&f, h);
        hy.box.right = fz_u8(&f) < 200 ? fz_near(&f, hy.box.left, -1, 40) : fz_edge(&f, w);
        hy.box.bottom = fz_u8(&f) < 200 ? fz_near(&f, hy.box.top, -1, 40) : fz_edge(&f, h);
        hy.cy = fz_u8(&f) < 200 ? fz_range(&f, hy.box.top < 0 ? 0 : hy.box.top, h) : fz_edge(&f, h);
        hy.side = fz_range(&f, 0, 3);
        hy.kind = fz_range(&f, 0, 3);
        s = vt_model_search_from_flow((nulls & 1) ? NULL : &cfg, (nulls & 4) ? NULL : &hy,
                                      (nulls & 8) ? NULL : &se);
        fz_status(s);
    } else {
        se.roi.left = fz_u8(&f) < 200 ? fz_range(&f, -8, w) : fz_edge(&f, w);
        se.roi.top = fz_u8(&f) < 200 ? fz_range(&f, -8, h) : fz_edge(&f, h);
        se.roi.right = fz_u8(&f) < 200 ? fz_near(&f, se.roi.left, -1, 80) : fz_edge(&f, w);
        se.roi.bottom = fz_u8(&f) < 200 ? fz_near(&f, se.roi.top, -1, 60) : fz_edge(&f, h);
        se.y_min = fz_u8(&f) < 200 ? fz_range(&f, -4, h + 4) : fz_edge(&f, h);
        se.y_max = fz_u8(&f) < 200 ? fz_near(&f, se.y_min, -2, 40) : fz_edge(&f, h);
        se.tracking = fz_u8(&f) < 128 ? 0 : fz_edge(&f, 1);
        params(&f, &se.pred, w, h);
        params(&f, &se.sigma, 8, 8);
    }
    if (op & 2) { /* one fitness at one level */
        int32_t level = fz_u8(&f) < 220 ? fz_range(&f, 0, VT_MODEL_LEVELS - 1) : fz_edge(&f, VT_MODEL_LEVELS);
        int32_t fit = 0;
        vt_model_params p;
        params(&f, &p, w, h);
        fz_status(vt_model_prepare((nulls & 32) ? NULL : &g_ws, &cfg, (nulls & 16) ? NULL : &img, &se, level));
        fz_status(vt_model_fitness((nulls & 32) ? NULL : &g_ws, &cfg, &img, &se, level,
                                   (nulls & 64) ? NULL : &p, &fit));
    }
    s = vt_model_fit((nulls & 32) ? NULL : &g_ws, (nulls & 1) ? NULL : &cfg, (nulls & 16) ? NULL : &img,
                     (nulls & 8) ? NULL : &se, (nulls & 64) ? NULL : &res);
    fz_status(s);
    if (s == VT_OK) {
        const vt_model_params *b = &res.best;
        FZ_ASSERT(b->w >= 1 && b->h >= 1 && res.evaluations > 0);
        FZ_ASSERT(res.box.left == b->x - b->w / 2 && res.box.right == res.box.left + b->w - 1);
        FZ_ASSERT(res.box.bottom == b->y && res.box.top == b->y - b->h + 1);
        FZ_ASSERT(g_ws.n >= 1 && g_ws.n <= VT_MODEL_MAX_POP && (g_ws.cur == 0 || g_ws.cur == 1));
    }
    fz_close(&f);
    return 0;
}
