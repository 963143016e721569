/* fuzz-requires: vehtrack/windows.h
 * fuzz_windows.c -- the whole-road window grid and its scorers (vehtrack/windows.h,
 * fulldet.h; IVVI paper sec. III.A, thesis sec. 2.4.3): window rules and the minimal
 * camera from the bytes (every field mutated, sizes not increasing, levels past
 * the capacity), the camera road, the windows of any level of any frame size
 * into an exact-size output array (cap 0..n and past it; *n_out counts them all), row distances of any
 * row, and the HOG / MLP window scorers called directly with fuzzed level images,
 * bands (y0 > y1, rows out of the image) and windows (off the cell grid, another
 * size, outside the image). Every returned window lies in its level. */
#include "fuzz.h"
#include "vehtrack/classify.h"
#include "vehtrack/fulldet.h"
#include "vehtrack/windows.h"

static vt_road_area g_road;
static vt_hog_scorer g_hog_sc;
static vt_mlp_scorer g_mlp_sc;

static void camera(fz *f, vt_camera_min *cam, int32_t h)
{
    cam->fx_q4 = fz_u8(f) < 200 ? fz_range(f, 16, 16 * 2000) : fz_edge(f, 1 << 24);
    cam->horizon_y = fz_u8(f) < 200 ? fz_range(f, -h, h) : fz_edge(f, VT_MAX_HEIGHT);
    cam->height_mm = fz_u8(f) < 200 ? fz_range(f, 100, 3000) : fz_edge(f, 20000);
    cam->hood_y = fz_u8(f) < 200 ? fz_range(f, 1, 2 * h) : fz_edge(f, 2 * VT_MAX_HEIGHT);
}

static vt_window win(fz *f, int32_t lw, int32_t lh)
{
    vt_window w;
    lw = lw > 0 && lw <= VT_MAX_WIDTH ? lw : 64; /* a bad view's size: any grid will do */
    lh = lh > 0 && lh <= VT_MAX_HEIGHT ? lh : 64;
    w.level = fz_u8(f) < 220 ? fz_range(f, 0, VT_WIN_MAX_LEVELS - 1) : fz_edge(f, VT_WIN_MAX_LEVELS);
    if (fz_u8(f) < 200) {
        w.size = 8 * fz_range(f, 2, 6) + ((fz_u8(f) & 1) ? 0 : fz_range(f, -3, 3));
        w.x = 8 * fz_range(f, 0, lw / 8 + 1) + ((fz_u8(f) & 1) ? 0 : fz_range(f, -3, 3));
        w.y = 8 * fz_range(f, 0, lh / 8 + 1) + ((fz_u8(f) & 1) ? 0 : fz_range(f, -3, 3));
    } else {
        w.size = fz_edge(f, 64);
        w.x = fz_edge(f, lw);
        w.y = fz_edge(f, lh);
    }
    return w;
}

/* On error *n_out is 0; on success a count. */
static int n_out_ok(vt_status s, int32_t n)
{
    FZ_ASSERT(s == VT_OK ? n >= 0 : n == 0 || n == -1);
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t op = fz_u8(&f) % 3u, nulls = fz_u8(&f) & (fz_u8(&f) | 0xC0u);
    vt_win_cfg cfg;
    vt_camera_min cam;
    vt_status s;
    int32_t w, h, i, n = -1;
    fz_status(vt_win_cfg_default(&cfg));
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_win_cfg_check((nulls & 64) ? NULL : &cfg));
    w = fz_u8(&f) < 220 ? fz_range(&f, 1, 160) : fz_edge(&f, VT_MAX_WIDTH);
    h = fz_u8(&f) < 220 ? fz_range(&f, 1, 120) : fz_edge(&f, VT_MAX_HEIGHT);
    camera(&f, &cam, h > 0 && h <= VT_MAX_HEIGHT ? h : 100);
    fz_status(vt_camera_min_check((nulls & 32) ? NULL : &cam));
    if (op == 0) { /* camera road, row distance */
        int32_t mm = -1, row = fz_u8(&f) < 200 ? fz_near(&f, h > 0 && h <= VT_MAX_HEIGHT ? 0 : 64, -2, 122) : fz_edge(&f, h);
        s = vt_road_from_camera((nulls & 1) ? NULL : &cfg, (nulls & 2) ? NULL : &cam, w, h,
                                (nulls & 4) ? NULL : &g_road);
        fz_status(s);
        if (s == VT_OK && g_road.valid) {
            FZ_ASSERT(g_road.y_top >= 0 && g_road.y_top <= g_road.y_bottom && g_road.y_bottom < h);
        }
        s = vt_camera_min_row_distance((nulls & 2) ? NULL : &cam, row, (nulls & 8) ? NULL : &mm);
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT(mm >= 0);
        }
    } else if (op == 1) { /* windows of one level */
        int32_t level = fz_u8(&f) < 220 ? fz_range(&f, 0, VT_WIN_MAX_LEVELS - 1) : fz_edge(&f, VT_WIN_MAX_LEVELS);
        int32_t cap = fz_u8(&f) < 128 ? fz_range(&f, 0, 64) : (fz_u8(&f) < 200 ? 4096 : fz_edge(&f, 4096));
        vt_window *out;
        if (cap > 4096) {
            cap = 4096; /* the array's size: a cap past it would be the harness lying */
        }
        out = (vt_window *)fz_alloc(&f, (size_t)(cap > 0 ? cap : 0) * sizeof(vt_window));
        if (fz_u8(&f) & 1) {
            fz_status(vt_road_from_camera(&cfg, &cam, w, h, &g_road));
        } else {
            fz_road(&f, &g_road, w, h);
        }
        s = vt_windows_level((nulls & 1) ? NULL : &cfg, (nulls & 2) ? NULL : &cam,
                             (nulls & 4) ? NULL : &g_road, w, h, level, (nulls & 8) ? NULL : out, cap,
                             (nulls & 16) ? NULL : &n);
        fz_status(s);
        if (n_out_ok(s, n) && s == VT_OK) {
            int32_t lw = w, lh = h, k;
            FZ_ASSERT(n >= 0); /* n may exceed cap: out holds the first cap */
            for (k = 0; k < level; k++) {
                lw = (lw + 1) / 2;
                lh = (lh + 1) / 2;
            }
            for (i = 0; i < n && i < cap; i++) {
                FZ_ASSERT(out[i].level == level && out[i].size >= 1 && out[i].x >= 0 && out[i].y >= 0);
                FZ_ASSERT(out[i].x + out[i].size <= lw + 1 && out[i].y + out[i].size <= lh + 1);
            }
        }
    } else { /* the scorers, called directly */
        vt_image_u8 img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
        int32_t score = 0, k, y0, y1;
        uint8_t which = fz_u8(&f);
        if (which & 1) {
            const vt_mlp_model *m = NULL;
            fz_status(vt_mlp_default_model(&m));
            fz_status(vt_mlp_scorer_init((nulls & 1) ? NULL : &g_mlp_sc, (which & 2) ? NULL : m));
            for (k = 0; k < 1 + (fz_u8(&f) & 3); k++) {
                vt_window wi = win(&f, img.w, img.h);
                fz_status(vt_mlp_scorer_score((nulls & 1) ? NULL : &g_mlp_sc, (nulls & 2) ? NULL : &img,
                                              (nulls & 4) ? NULL : &wi, (nulls & 8) ? NULL : &score));
            }
        } else {
            const vt_svm_model *m = NULL;
            fz_status(vt_svm_default_model(VT_DESC_HOG, &m));
            fz_status(vt_hog_scorer_init((nulls & 1) ? NULL : &g_hog_sc, (which & 2) ? NULL : m));
            y0 = fz_u8(&f) < 200 ? fz_range(&f, -1, img.h) : fz_edge(&f, img.h);
            y1 = fz_u8(&f) < 200 ? fz_near(&f, y0, -2, 64) : fz_edge(&f, img.h);
            fz_status(vt_hog_scorer_level((nulls & 1) ? NULL : &g_hog_sc, (nulls & 2) ? NULL : &img,
                                          fz_range(&f, -1, VT_WIN_MAX_LEVELS), y0, y1));
            for (k = 0; k < 1 + (fz_u8(&f) & 3); k++) {
                vt_window wi = win(&f, img.w, img.h);
                fz_status(vt_hog_scorer_score((nulls & 1) ? NULL : &g_hog_sc, (nulls & 2) ? NULL : &img,
                                              (nulls & 4) ? NULL : &wi, (nulls & 8) ? NULL : &score));
            }
        }
    }
    fz_close(&f);
    return 0;
}
