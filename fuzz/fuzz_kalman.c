/* fuzz_kalman.c -- the Kalman filter and its two motion models
 * (vehtrack/kalman.h; thesis sec. 3.4.4-3.5, GIST paper sec. III.B.2). The
 * filter struct is public, so any dims and any matrix entries (INT64_MIN/MAX
 * included) are fair inputs: predict and update must stay defined (issue 11:
 * a covariance saturated to INT64_MIN was negated). For the models, a
 * configuration that vt_kf_model_cfg_check accepts must keep P symmetric with
 * a non-negative diagonal through predict/update/coast sequences. */
#include "fuzz.h"
#include "vehtrack/kalman.h"

static int64_t val64(fz *f)
{
    uint8_t k = fz_u8(f);
    uint64_t u;
    switch (k & 7u) {
    case 0: return 0;
    case 1: return VT_Q32_ONE;
    case 2: return -VT_Q32_ONE;
    case 3: return INT64_MIN;
    case 4: return INT64_MAX;
    case 5: return (int64_t)fz_raw_i32(f) * 65536; /* a Q15.16 value in Q31.32 */
    default:
        u = (uint64_t)fz_u32(f) | ((uint64_t)fz_u32(f) << 32);
        return u <= (uint64_t)INT64_MAX ? (int64_t)u : -(int64_t)(~u) - 1;
    }
}

/* P symmetric, diagonal >= 0 up to the few LSB of rounding kalman.h allows. */
static int p_ok(const vt_kf *kf)
{
    int32_t i, j;
    for (i = 0; i < kf->dim_x; i++) {
        if (kf->P[i][i] < -16) {
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

static void raw_filter(fz *f)
{
    vt_kf kf;
    vt_q16 z[VT_KF_MAX_Z];
    int32_t i, j, k, n;
    vt_status s = vt_kf_init(fz_u8(f) == 0xFF ? NULL : &kf, fz_edge(f, VT_KF_MAX_X), fz_edge(f, VT_KF_MAX_Z));
    fz_status(s);
    if (s != VT_OK) {
        return;
    }
    /* Overwrite some entries of x, P, F, Q, H, R with anything. */
    n = fz_u8(f) & 31;
    for (k = 0; k < n; k++) {
        uint8_t m = fz_u8(f) % 6u;
        i = fz_range(f, 0, VT_KF_MAX_X - 1);
        j = fz_range(f, 0, VT_KF_MAX_X - 1);
        switch (m) {
        case 0: kf.x[i] = fz_edge(f, VT_Q16_ONE); break;
        case 1: kf.P[i][j] = val64(f); break;
        case 2: kf.F[i][j] = val64(f); break;
        case 3: kf.Q[i][j] = val64(f); break;
        case 4: kf.H[i % VT_KF_MAX_Z][j] = val64(f); break;
        default: kf.R[i % VT_KF_MAX_Z][j % VT_KF_MAX_Z] = val64(f); break;
        }
    }
    if (fz_u8(f) == 0xFE) {
        kf.dim_x = fz_edge(f, VT_KF_MAX_X);
        kf.dim_z = fz_edge(f, VT_KF_MAX_Z);
    }
    n = 1 + (fz_u8(f) & 7);
    for (k = 0; k < n; k++) {
        for (i = 0; i < VT_KF_MAX_Z; i++) {
            z[i] = fz_edge(f, VT_Q16_ONE * 64);
        }
        s = vt_kf_predict(&kf);
        fz_status(s);
        if (s == VT_OK) {
            /* predict always leaves P exactly symmetric, whatever it started as */
            for (i = 0; i < kf.dim_x; i++) {
                for (j = 0; j < kf.dim_x; j++) {
                    FZ_ASSERT(kf.P[i][j] == kf.P[j][i]);
                }
            }
        }
        fz_status(vt_kf_update(&kf, fz_u8(f) == 0xFF ? NULL : z));
    }
}

static void model(fz *f)
{
    vt_kf_model_cfg cfg;
    vt_kf kf;
    vt_q32 var = 0;
    vt_status s;
    int32_t k, n, coast;
    fz_status(vt_kf_model_cfg_default(&cfg));
    fz_mutate_i32s(f, &cfg, sizeof cfg);
    fz_status(vt_kf_accel_var(cfg.accel_x, cfg.p_max, cfg.p_zero, fz_u8(f) == 0xFF ? NULL : &var));
    s = vt_kf_model_cfg_check(&cfg);
    fz_status(s);
    if (fz_u8(f) & 1) {
        fz_status(vt_kf_init_cv(&kf, &cfg, fz_edge(f, VT_Q16_ONE * 640), fz_edge(f, VT_Q16_ONE * 480)));
        FZ_ASSERT((vt_kf_init_cv(&kf, &cfg, 0, 0) == VT_OK) == (s == VT_OK));
    } else {
        fz_status(vt_kf_init_bottom_edge(&kf, &cfg, fz_edge(f, VT_Q16_ONE * 640),
                                         fz_edge(f, VT_Q16_ONE * 480), fz_edge(f, VT_Q16_ONE * 640)));
        FZ_ASSERT((vt_kf_init_bottom_edge(&kf, &cfg, 0, 0, VT_Q16_ONE * 10) == VT_OK) == (s == VT_OK));
    }
    if (s != VT_OK) {
        return;
    }
    n = 1 + (fz_u8(f) & 63);
    coast = fz_u8(f) & 31;
    for (k = 0; k < n; k++) {
        vt_q16 z[VT_KF_MAX_Z];
        int32_t i;
        FZ_ASSERT(vt_kf_predict(&kf) == VT_OK);
        FZ_ASSERT(p_ok(&kf));
        if (coast == 0 || k % (coast + 1) == 0) {
            for (i = 0; i < VT_KF_MAX_Z; i++) {
                z[i] = fz_range(f, -VT_Q16_ONE * 64, VT_Q16_ONE * 1024);
            }
            fz_status(vt_kf_update(&kf, z));
            FZ_ASSERT(p_ok(&kf));
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    if (fz_u8(&f) & 1) {
        raw_filter(&f);
    } else {
        model(&f);
    }
    fz_close(&f);
    return 0;
}
