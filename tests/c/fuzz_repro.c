/* fuzz_repro.c -- each defect the libFuzzer harnesses of the new stages found
 * (fuzz/fuzz_{classify,windows,fulldet,flow,vehicle_model,camera,edge_track}.c),
 * reduced to a call through the public API. Built by tests/test_fuzz_repro.py
 * with clang -fsanitize=address,undefined -fno-sanitize-recover=all, so UB or an
 * out-of-bounds access aborts the run; prints one line per case, exits 0 else. */
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include "vehtrack/camera.h"
#include "vehtrack/classify.h"
#include "vehtrack/fulldet.h"
#include "vehtrack/vehicle_model.h"
#include "vehtrack/windows.h"

static int g_fail;

static void expect(int ok, const char *what)
{
    printf("%s %s\n", ok ? "ok" : "FAIL", what);
    if (!ok) {
        g_fail = 1;
    }
}

static uint8_t g_px[48 * 48];
static vt_hog_scorer g_hog_sc;
static vt_mlp_scorer g_mlp_sc;

/* A window whose x (or y) is near INT32_MAX: the scorers' bounds check computed
 * win->x + win->size, a signed overflow, before rejecting it. */
static void scorer_window_overflow(void)
{
    vt_image_u8 img = {g_px, 48, 48, 48};
    const vt_svm_model *svm = NULL;
    const vt_mlp_model *mlp = NULL;
    vt_window w = {0, 8, INT32_MAX, 0};
    int32_t score = 1;
    expect(vt_svm_default_model(VT_DESC_HOG, &svm) == VT_OK && vt_hog_scorer_init(&g_hog_sc, svm) == VT_OK,
           "hog scorer init");
    expect(vt_hog_scorer_score(&g_hog_sc, &img, &w, &score) == VT_E_ARG && score == 0,
           "hog scorer: x = INT32_MAX is VT_E_ARG");
    w.x = 0;
    w.y = INT32_MAX - 3;
    expect(vt_hog_scorer_score(&g_hog_sc, &img, &w, &score) == VT_E_ARG, "hog scorer: y near INT32_MAX");
    w.y = 0;
    w.size = INT32_MAX;
    expect(vt_hog_scorer_score(&g_hog_sc, &img, &w, &score) == VT_E_ARG, "hog scorer: size INT32_MAX");
    if (vt_mlp_default_model(&mlp) == VT_OK) {
        expect(vt_mlp_scorer_init(&g_mlp_sc, mlp) == VT_OK, "mlp scorer init");
        w.size = 8;
        w.x = INT32_MAX;
        expect(vt_mlp_scorer_score(&g_mlp_sc, &img, &w, &score) == VT_E_ARG,
               "mlp scorer: x = INT32_MAX is VT_E_ARG");
    }
}

static vt_model_ws g_model_ws;

/* vt_model_fitness accepted level = -1 after a failed vt_model_prepare (which
 * marks the workspace with level -1 but kept the last image): the fitness then
 * shifted by a negative amount (UB) on a stale image. */
static void model_fitness_level_minus_one(void)
{
    vt_image_u8 img = {g_px, 48, 48, 48};
    vt_model_cfg cfg;
    vt_model_search se;
    vt_model_params p = {24, 40, 20, 16, 30, 20, 10};
    int32_t fit = 1, i;
    for (i = 0; i < 48 * 48; i++) {
        g_px[i] = (uint8_t)(i * 7);
    }
    memset(&se, 0, sizeof se);
    se.roi.left = 0;
    se.roi.top = 0;
    se.roi.right = 47;
    se.roi.bottom = 47;
    se.y_min = 10;
    se.y_max = 47;
    expect(vt_model_cfg_default(&cfg) == VT_OK && vt_model_prepare(&g_model_ws, &cfg, &img, &se, 0) == VT_OK,
           "model prepare level 0");
    expect(vt_model_prepare(&g_model_ws, &cfg, NULL, &se, 0) == VT_E_ARG, "model prepare NULL frame");
    expect(vt_model_fitness(&g_model_ws, &cfg, &img, &se, -1, &p, &fit) == VT_E_ARG && fit == 0,
           "model fitness at level -1 is VT_E_ARG");
    expect(vt_model_fitness(&g_model_ws, &cfg, &img, &se, 0, &p, &fit) == VT_E_ARG,
           "model fitness after a failed prepare is VT_E_ARG");
}

static vt_range_state g_range;

/* vt_range_step: a filtered distance of ~20 m with a range rate of -3/65536 m/s
 * gives d / -rate = 4e5 s, past int32 in Q16; the quotient was converted to
 * int32 before the comparison with ttc_max, so it wrapped to a negative TTC that
 * was reported valid (and a negative TTC is under every FCW threshold). The
 * sequence is fuzz_camera's (a track jumping between two boxes). */
static void range_ttc_wraps(void)
{
    static const vt_box boxes[5] = {{962, 135, 1166, 143}, {962, 135, 1166, 143}, {962, 135, 1166, 143},
                                    {15, 29, 219, 37}, {962, 135, 1166, 143}};
    static const int32_t states[5] = {2, 2, 3, 2, 2};
    vt_camera_cfg cam;
    vt_range_cfg rc;
    vt_range_out out[4];
    int32_t f, n = 0, bad = 0, seen_rate = 0;
    expect(vt_camera_cfg_default(&cam) == VT_OK && vt_range_cfg_default(&rc) == VT_OK, "range cfgs");
    cam.tan_pitch = -1;
    cam.width_tol_permille = 1460;
    rc.stopped_speed = 65535;
    expect(vt_range_init(&g_range) == VT_OK, "range init");
    for (f = 0; f < 5; f++) {
        vt_track_out t;
        t.id = 2;
        t.state = states[f];
        t.box = boxes[f];
        t.vx = f == 3 ? -89 : -1414;
        t.vy = f == 4 ? 15492 : -1414;
        expect(vt_range_step(&g_range, &rc, &cam, 8191, 2621439, &t, 1, out, 4, &n) == VT_OK && n == 1,
               "range step");
        seen_rate |= out[0].rate < 0 && out[0].rate > -16;
        if ((out[0].flags & VT_RANGE_TTC_DIST_VALID) && out[0].ttc_dist < 0) {
            bad = 1;
        }
    }
    expect(seen_rate, "range: a tiny closing rate is reached");
    expect(!bad, "range: a valid distance TTC is never negative");
}

int main(void)
{
    range_ttc_wraps();
    scorer_window_overflow();
    model_fitness_level_minus_one();
    return g_fail;
}
