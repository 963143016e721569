/* fuzz-requires: vehtrack/camera.h
 * fuzz_camera.c -- flat-road camera geometry, pitch, range filter, TTC and FCW
 * (vehtrack/camera.h; IVVI paper sec. IV, eqs. 1-6; NHTSA FCW test) and the
 * Kalman update with a per-measurement R (kalman.h, c/kalman_r.c): camera and
 * range configurations with fields mutated from the bytes (edge values), row and
 * box distances of any row / box and pitch, the pitch filter over a sequence of
 * vanishing rows, the vanishing row of a lane result whose every field is
 * fuzzed, the range stage over a sequence of frames of fuzzed tracks (ids
 * repeating, appearing and leaving, duplicates, FREE slots, more than capacity),
 * with or without block-scale TTCs of any value (vt_range_step_fused, any fusion
 * weight), the FCW state machine alone with vt_ttc_fuse beside it, and
 * vt_kf_update_r with any R. */
#include "fuzz.h"
#include "vehtrack/camera.h"
#include "vehtrack/kalman.h"

static vt_range_state g_range;
static vt_lane_result g_lanes;
static vt_kf g_kf;

static vt_q16 q16(fz *f, vt_q16 lo, vt_q16 hi)
{
    return fz_u8(f) < 200 ? fz_range(f, lo, hi) : fz_edge(f, hi);
}

static vt_box box(fz *f, int32_t w, int32_t h)
{
    return fz_u8(f) < 220 ? fz_box_near(f, w, h, 300, 200) : fz_box_edge(f, w, h);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t op = fz_u8(&f) % 6u, nulls = fz_u8(&f) & (fz_u8(&f) | 0xC0u);
    vt_camera_cfg cam;
    vt_range_cfg rc;
    vt_status s;
    int32_t i, step, n_steps;
    fz_status(vt_camera_cfg_default(&cam));
    fz_mutate_i32s(&f, &cam, sizeof cam);
    fz_status(vt_camera_cfg_check((nulls & 64) ? NULL : &cam));
    fz_status(vt_range_cfg_default(&rc));
    fz_mutate_i32s(&f, &rc, sizeof rc);
    fz_status(vt_range_cfg_check((nulls & 64) ? NULL : &rc));
    if (op == 0) { /* row and box distances */
        vt_q16 tp = q16(&f, -VT_Q16_ONE, VT_Q16_ONE), row = q16(&f, -100 * VT_Q16_ONE, 2000 * VT_Q16_ONE);
        vt_q16 d = -1;
        int32_t valid = -1;
        vt_box b = box(&f, 1242, 375);
        vt_distance out;
        s = vt_camera_row_distance((nulls & 1) ? NULL : &cam, tp, row, (nulls & 2) ? NULL : &d,
                                   (nulls & 4) ? NULL : &valid);
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT((valid == 0 || valid == 1) && d >= 0 && d <= VT_DIST_MAX_M * VT_Q16_ONE);
        }
        s = vt_camera_box_distance((nulls & 1) ? NULL : &cam, tp, (nulls & 8) ? NULL : &b,
                                   (nulls & 16) ? NULL : &out);
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT(out.distance >= 0 && out.dist_near >= 0 && out.dist_far >= 0 && out.sigma >= 0);
            FZ_ASSERT(out.dist_width >= 0 && (out.flags & ~31) == 0);
        }
    } else if (op == 1) { /* the pitch filter */
        vt_pitch_state st;
        s = vt_pitch_init(&st, (nulls & 1) ? NULL : &cam);
        fz_status(s);
        n_steps = 1 + (fz_u8(&f) & 15);
        for (step = 0; step < n_steps && s == VT_OK; step++) {
            int32_t vp_valid = fz_u8(&f) < 230 ? (fz_u8(&f) & 1) : fz_edge(&f, 1);
            vt_q16 vp_row = q16(&f, -400 * VT_Q16_ONE, 800 * VT_Q16_ONE);
            fz_status(vt_pitch_update((nulls & 2) ? NULL : &st, &cam, vp_valid, vp_row));
            FZ_ASSERT(st.flag >= VT_PITCH_NOMINAL && st.flag <= VT_PITCH_REJECTED && st.outliers >= 0 &&
                      st.measured >= 0);
            FZ_ASSERT(st.tan_pitch >= cam.tan_pitch_min && st.tan_pitch <= cam.tan_pitch_max);
        }
    } else if (op == 2) { /* vanishing row of a fuzzed lane result */
        vt_q16 vp = -1;
        int32_t valid = -1, k;
        memset(&g_lanes, 0, sizeof g_lanes);
        g_lanes.scale = fz_u8(&f) < 220 ? fz_range(&f, 1, VT_LANE_MAX_SCALE) : fz_edge(&f, VT_LANE_MAX_SCALE);
        g_lanes.w = fz_u8(&f) < 220 ? fz_range(&f, 1, 640) : fz_edge(&f, VT_MAX_WIDTH);
        g_lanes.h = fz_u8(&f) < 220 ? fz_range(&f, 1, 480) : fz_edge(&f, VT_MAX_HEIGHT);
        g_lanes.roi_top = fz_edge(&f, g_lanes.h);
        g_lanes.band_top = fz_edge(&f, g_lanes.h);
        for (k = 0; k < VT_LANE_SLOTS; k++) {
            vt_lane_line *ln = &g_lanes.lines[k];
            ln->state = fz_range(&f, -1, 3);
            ln->xb = fz_u8(&f) < 200 ? fz_range(&f, -640 * VT_Q16_ONE, 1280 * VT_Q16_ONE) : fz_raw_i32(&f);
            ln->slope = fz_u8(&f) < 200 ? fz_range(&f, -8 * VT_Q16_ONE, 8 * VT_Q16_ONE) : fz_raw_i32(&f);
            ln->n_verts = fz_edge(&f, VT_LANE_MAX_VERTS);
            ln->y_top = fz_edge(&f, g_lanes.h);
        }
        s = vt_lane_vanishing_row((nulls & 1) ? NULL : &g_lanes,
                                  fz_u8(&f) < 200 ? (int32_t)((int64_t)(g_lanes.h & 0xFFFF) * (g_lanes.scale & 7 ? g_lanes.scale & 7 : 8) + fz_range(&f, 0, 7)) : fz_edge(&f, 480),
                                  (nulls & 2) ? NULL : &vp, (nulls & 4) ? NULL : &valid);
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT(valid == 0 || valid == 1);
            FZ_ASSERT(valid || vp == 0);
        }
    } else if (op == 3) { /* the range stage over frames */
        vt_track_out tr[VT_MAX_TRACKS + 3];
        vt_range_out out[VT_MAX_TRACKS + 3];
        vt_q16 pts[VT_MAX_TRACKS + 3];
        fz_status(vt_range_init((nulls & 1) ? NULL : &g_range));
        fz_status(vt_range_init(&g_range));
        n_steps = 1 + (fz_u8(&f) & 31);
        for (step = 0; step < n_steps; step++) {
            int32_t n_tr = fz_u8(&f) < 230 ? fz_range(&f, 0, 4) : fz_edge(&f, VT_MAX_TRACKS + 3);
            int32_t cap = fz_u8(&f) < 220 ? VT_MAX_TRACKS + 3 : fz_range(&f, -1, VT_MAX_TRACKS + 3);
            int32_t n_out = -1;
            vt_q16 tp = q16(&f, -VT_Q16_ONE / 8, VT_Q16_ONE / 8);
            vt_q16 ego = q16(&f, 0, 40 * VT_Q16_ONE);
            int32_t fused = fz_u8(&f) & 1;
            int32_t w = fz_u8(&f) < 230 ? fz_range(&f, 0, 1000) : fz_edge(&f, 1000);
            if (n_tr > VT_MAX_TRACKS + 3) {
                n_tr = VT_MAX_TRACKS + 3;
            }
            for (i = 0; i < n_tr && i < VT_MAX_TRACKS + 3; i++) {
                tr[i].id = fz_u8(&f) < 230 ? fz_range(&f, 1, 6) : fz_edge(&f, 6);
                tr[i].state = fz_u8(&f) < 230 ? fz_range(&f, 1, 3) : fz_edge(&f, 3);
                tr[i].box = box(&f, 1242, 375);
                tr[i].vx = fz_raw_i32(&f) >> (fz_u8(&f) & 31);
                tr[i].vy = fz_raw_i32(&f) >> (fz_u8(&f) & 31);
                pts[i] = fz_u8(&f) < 200 ? q16(&f, -VT_Q16_ONE, 20 * VT_Q16_ONE) : fz_raw_i32(&f);
            }
            if (fused) {
                s = vt_range_step_fused((nulls & 2) ? NULL : &g_range, (nulls & 4) ? NULL : &rc,
                                        (nulls & 8) ? NULL : &cam, tp, ego, (nulls & 16) ? NULL : tr, n_tr,
                                        (nulls & 1) ? NULL : pts, w, (nulls & 32) ? NULL : out, cap, &n_out);
            } else {
                s = vt_range_step((nulls & 2) ? NULL : &g_range, (nulls & 4) ? NULL : &rc,
                                  (nulls & 8) ? NULL : &cam, tp, ego, (nulls & 16) ? NULL : tr, n_tr,
                                  (nulls & 32) ? NULL : out, cap, &n_out);
            }
            fz_status(s);
            if (s == VT_OK || s == VT_E_CAPACITY) {
                FZ_ASSERT(n_out >= 0);
                for (i = 0; i < n_out && i < cap; i++) {
                    FZ_ASSERT(out[i].id >= 1 && (out[i].fcw & ~7) == 0 && out[i].lead_class >= 0 &&
                              out[i].lead_class <= VT_LEAD_DECEL);
                    FZ_ASSERT(!(out[i].flags & VT_RANGE_TTC_DIST_VALID) || out[i].ttc_dist >= 0);
                    /* a warning starts only on a frame whose condition holds: in the ego path */
                    FZ_ASSERT(!(out[i].fcw & VT_FCW_ONSET) || (out[i].flags & VT_RANGE_IN_PATH));
                }
            }
        }
    } else if (op == 4) { /* the FCW state machine alone */
        vt_fcw_state st;
        memset(&st, 0, sizeof st);
        st.since_end = fz_u8(&f) < 200 ? INT32_MAX : fz_range(&f, 0, 200); /* a state vt_range_step makes */
        n_steps = 1 + (fz_u8(&f) & 63);
        for (step = 0; step < n_steps; step++) {
            int32_t out = -1, ttc_valid = fz_u8(&f) < 230 ? (fz_u8(&f) & 1) : fz_edge(&f, 1);
            int32_t closing = fz_u8(&f) < 230 ? (fz_u8(&f) & 1) : fz_edge(&f, 1);
            int32_t lead = fz_u8(&f) < 230 ? fz_range(&f, 0, 3) : fz_edge(&f, 3);
            vt_q16 ttc = q16(&f, -VT_Q16_ONE, 5 * VT_Q16_ONE);
            vt_q16 pts = fz_u8(&f) < 200 ? q16(&f, -VT_Q16_ONE, 5 * VT_Q16_ONE) : fz_raw_i32(&f), fu = 7;
            int32_t w = fz_u8(&f) < 230 ? fz_range(&f, 0, 1000) : fz_edge(&f, 1000);
            s = vt_ttc_fuse(pts, ttc, w, (nulls & 8) ? NULL : &fu);
            fz_status(s);
            if (s == VT_OK) { /* the known one, or between the two */
                FZ_ASSERT(pts < 0 ? fu == (ttc < 0 ? -1 : ttc)
                                  : (ttc < 0 ? fu == pts
                                             : fu >= (pts < ttc ? pts : ttc) && fu <= (pts < ttc ? ttc : pts)));
            } else {
                FZ_ASSERT(fu == 7);
            }
            s = vt_fcw_step((nulls & 2) ? NULL : &st, (nulls & 1) ? NULL : &rc, ttc_valid, ttc, closing, lead,
                            (nulls & 4) ? NULL : &out);
            fz_status(s);
            if (s == VT_OK) {
                FZ_ASSERT((out & ~7) == 0 && st.below >= 0 && st.above >= 0 && st.since_end >= 0 &&
                          st.warnings >= 0 && (st.warning == 0 || st.warning == 1));
            }
        }
    } else { /* the Kalman update with a per-measurement R */
        vt_kf_model_cfg mc;
        vt_q16 z[VT_KF_MAX_Z];
        vt_q32 r[VT_KF_MAX_Z * VT_KF_MAX_Z];
        int32_t m, diag;
        fz_status(vt_kf_model_cfg_default(&mc));
        fz_status(vt_kf_init_cv(&g_kf, &mc, fz_raw_i32(&f), fz_raw_i32(&f)));
        g_kf.dim_z = fz_u8(&f) < 230 ? g_kf.dim_z : fz_edge(&f, VT_KF_MAX_Z);
        m = g_kf.dim_z > 0 && g_kf.dim_z <= VT_KF_MAX_Z ? g_kf.dim_z : VT_KF_MAX_Z;
        for (i = 0; i < m; i++) {
            z[i] = fz_u8(&f) < 200 ? fz_range(&f, -1000 * VT_Q16_ONE, 1000 * VT_Q16_ONE) : fz_raw_i32(&f);
        }
        for (i = 0; i < m * m; i++) {
            uint8_t k = fz_u8(&f);
            r[i] = k < 100 ? (i % (m + 1) == 0 ? (vt_q32)fz_range(&f, 0, 1 << 30) << 8 : 0)
                           : (k < 200 ? (vt_q32)fz_raw_i32(&f) : (vt_q32)((uint64_t)fz_u32(&f) << 32 | fz_u32(&f)));
        }
        diag = fz_u8(&f) < 100;
        if (diag) { /* a diagonal R: positive semi-definite for sure */
            int32_t a, b;
            for (a = 0; a < m; a++) {
                for (b = 0; b < m; b++) {
                    r[a * m + b] = a == b ? (r[a * m + b] < 0 ? -(r[a * m + b] + 1) : r[a * m + b]) : 0;
                }
            }
        } else if (fz_u8(&f) < 200) { /* mostly symmetric, so the update runs */
            int32_t a, b;
            for (a = 0; a < m; a++) {
                for (b = 0; b < a; b++) {
                    r[a * m + b] = r[b * m + a];
                }
            }
        }
        s = vt_kf_update_r((nulls & 1) ? NULL : &g_kf, (nulls & 2) ? NULL : z, (nulls & 4) ? NULL : r);
        fz_status(s);
        if (s == VT_OK && diag) {
            /* Only for a PSD R: the check accepts any symmetric R with a
             * non-negative diagonal, and a non-PSD one can make a variance
             * negative (kalman.h states R must be PSD). */
            for (i = 0; i < g_kf.dim_x; i++) {
                FZ_ASSERT(g_kf.P[i][i] >= 0);
            }
        }
    }
    fz_close(&f);
    return 0;
}
