/* ub_repro.c -- the undefined behaviour of issue 11, reached through the public
 * API only. Built by tests/test_c_ub.py with clang -fsanitize=undefined
 * -fno-sanitize-recover=all (gcc 12's UBSan does not flag the negation), so
 * any UB aborts the run; it prints one line per case and exits 0 otherwise.
 *
 * The cases: vt_kf_predict saturating a covariance entry to INT64_MIN, which
 * vt__kf_symmetrise -> vt__mean64 -> vt__floor_shr64 then negated; reached
 * (1) directly (P = [[2^30, 2^29], [2^29, 2^30]], F = diag(-4, 4)), (2) through
 * vt_kf_init_cv with a large dt, (3) through vt_tracker_step with a default
 * config whose model.dt is 500 frames, and (4) vt__floor_shr64 itself at
 * INT64_MIN. */
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include "vehtrack/kalman.h"
#include "vehtrack/tracker.h"

static int g_fail;

static void expect(int ok, const char *what)
{
    printf("%s %s\n", ok ? "ok" : "FAIL", what);
    if (!ok) {
        g_fail = 1;
    }
}

/* P symmetric with a non-negative diagonal: what every predict must leave. */
static int p_valid(const vt_kf *kf)
{
    int32_t i, j;
    for (i = 0; i < kf->dim_x; i++) {
        if (kf->P[i][i] < 0) {
            return 0;
        }
        for (j = 0; j < kf->dim_x; j++) {
            if (kf->P[i][j] != kf->P[j][i]) {
                return 0;
            }
        }
    }
    return 1;
}

static void case_direct(void)
{
    vt_kf kf;
    int k;
    vt_kf_init(&kf, 2, 1);
    kf.P[0][0] = kf.P[1][1] = (vt_q32)1 << 62; /* 2^30 in Q31.32 */
    kf.P[0][1] = kf.P[1][0] = (vt_q32)1 << 61;
    kf.F[0][0] = -4 * VT_Q32_ONE;
    kf.F[1][1] = 4 * VT_Q32_ONE;
    for (k = 0; k < 3; k++) {
        expect(vt_kf_predict(&kf) == VT_OK && p_valid(&kf), "kf_predict F=diag(-4,4) P=2^30");
    }
    expect(kf.P[0][1] == INT64_MIN && kf.P[0][0] == INT64_MAX, "kf_predict saturates P, never wraps");
}

static void case_cv_large_dt(void)
{
    vt_kf_model_cfg cfg;
    vt_kf kf;
    int32_t dt, k;
    static const int32_t dts[] = {16 * 65536, 500 * 65536, 2000 * 65536, INT32_MAX};
    for (k = 0; k < (int32_t)(sizeof dts / sizeof dts[0]); k++) {
        int i;
        vt_status s;
        vt_kf_model_cfg_default(&cfg);
        dt = dts[k];
        cfg.dt = dt;
        s = vt_kf_init_cv(&kf, &cfg, 0, 0);
        for (i = 0; s == VT_OK && i < 20; i++) {
            vt_q16 z[2] = {0, 0};
            s = vt_kf_predict(&kf);
            if (s == VT_OK && !p_valid(&kf)) {
                s = VT_E_SINGULAR;
                break;
            }
            (void)vt_kf_update(&kf, z);
        }
        expect(s == VT_OK || s == VT_E_ARG, "kf_init_cv large dt: rejected or valid");
    }
}

static void case_tracker_dt500(void)
{
    static uint8_t px[64 * 64];
    vt_image_u8 img = {px, 64, 64, 64};
    static vt_tracker tr;
    vt_tracker_cfg cfg;
    vt_track_out out[VT_MAX_TRACKS];
    vt_box det = {20, 20, 40, 40};
    int32_t f, n = 0;
    vt_status s = VT_OK;
    memset(px, 128, sizeof px);
    vt_tracker_init(&tr);
    vt_tracker_cfg_default(&cfg);
    cfg.model.dt = 500 * 65536;
    for (f = 0; f < 6 && s >= 0; f++) {
        s = vt_tracker_step(&tr, &cfg, &img, f % 2 == 0, &det, 1, out, VT_MAX_TRACKS, &n);
    }
    expect(s >= 0 || s == VT_E_ARG, "tracker_step model.dt = 500 frames: rejected or defined");
}

int main(void)
{
    int64_t v;
    setvbuf(stdout, NULL, _IONBF, 0);
    v = vt__floor_shr64(INT64_MIN, 1);
    expect(v == INT64_MIN / 2, "floor_shr64(INT64_MIN, 1)");
    expect(vt__floor_shr64(INT64_MIN, 0) == INT64_MIN, "floor_shr64(INT64_MIN, 0)");
    expect(vt__floor_shr64(-3, 1) == -2 && vt__floor_shr64(-4, 2) == -1 && vt__floor_shr64(-5, 2) == -2,
           "floor_shr64 rounds towards -inf");
    case_direct();
    case_cv_large_dt();
    case_tracker_dt500();
    return g_fail;
}
