/* fuzz_tracker.c -- the multi-vehicle tracker (vehtrack/tracker.h, thesis ch. 3):
 * a sequence of steps over one fuzzed view (or a new one per step), with
 * configurations, detections (any boxes, n_dets at and past its limit), output
 * capacities, horizons (the scale check) and NULLs from the bytes. After every step: the status is a
 * vt_status, *n_out <= out_cap, reported ids are > 0 and distinct, and no id
 * seen before with another track comes back. */
#include "fuzz.h"
#include "vehtrack/tracker.h"

#define FZ_DETS 260 /* past the tracker's 256 per frame */

static vt_tracker g_tr;
static vt_edge_ws g_edge_ws; /* attached at every run, so a fuzzed measurement = edges runs */
static vt_box g_dets[FZ_DETS];

static vt_box det(fz *f, const vt_image_u8 *img)
{
    vt_box b;
    if (fz_u8(f) < 220) { /* a plausible box, so tracks start and live */
        int32_t w = img->w > 0 && img->w <= VT_MAX_WIDTH ? img->w : 64;
        int32_t h = img->h > 0 && img->h <= VT_MAX_HEIGHT ? img->h : 64;
        b.left = fz_range(f, -4, w);
        b.top = fz_range(f, -4, h);
        b.right = b.left + fz_range(f, 0, 40);
        b.bottom = b.top + fz_range(f, 0, 40);
    } else {
        b.left = fz_edge(f, img->w);
        b.top = fz_edge(f, img->h);
        b.right = fz_edge(f, img->w);
        b.bottom = fz_edge(f, img->h);
    }
    return b;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    vt_tracker_cfg cfg;
    vt_track_out out[VT_MAX_TRACKS + 2];
    vt_image_u8 img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    int32_t step, n_steps, i, j;
    fz_status(vt_tracker_init(&g_tr));
    fz_status(vt_tracker_set_edge_ws(&g_tr, &g_edge_ws));
    fz_status(vt_tracker_cfg_default(&cfg));
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_tracker_cfg_check(&cfg));
    n_steps = 1 + (fz_u8(&f) & 15);
    for (step = 0; step < n_steps; step++) {
        int32_t n_dets, out_cap, n_out = -1, det_frame;
        uint8_t nulls = fz_u8(&f) & (fz_u8(&f) | 0xC0u);
        vt_status s;
        if (fz_u8(&f) == 0xFE) {
            img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT); /* a new frame size */
        }
        det_frame = fz_u8(&f) & 1;
        n_dets = fz_u8(&f) < 240 ? (fz_u8(&f) & 7) : fz_edge(&f, 256);
        for (j = 0; j < n_dets && j < FZ_DETS; j++) {
            g_dets[j] = det(&f, &img);
        }
        if (fz_u8(&f) < 64) { /* the scale check's horizon: in range, at its edges, or bad */
            int32_t h = img.h > 0 && img.h <= VT_MAX_HEIGHT ? img.h : 64; /* a fuzzed view's h may be anything */
            int32_t known = g_tr.horizon_known, row = fz_u8(&f) < 200 ? fz_range(&f, -8, h + 8)
                                                                     : fz_edge(&f, 4 * VT_MAX_HEIGHT);
            vt_status hs = vt_tracker_set_horizon((fz_u8(&f) == 0xFF) ? NULL : &g_tr, fz_u8(&f) & 1, row);
            fz_status(hs);
            FZ_ASSERT(hs == VT_OK || g_tr.horizon_known == known);
        }
        out_cap = fz_u8(&f) < 220 ? VT_MAX_TRACKS : fz_range(&f, -1, VT_MAX_TRACKS + 2);
        s = vt_tracker_step((nulls & 1) ? NULL : &g_tr, (nulls & 2) ? NULL : &cfg,
                            (nulls & 4) ? NULL : &img, det_frame,
                            (nulls & 8) ? NULL : g_dets, n_dets > FZ_DETS ? FZ_DETS : n_dets,
                            (nulls & 16) ? NULL : out, out_cap, (nulls & 32) ? NULL : &n_out);
        fz_status(s);
        if (s == VT_OK || s == VT_E_CAPACITY) {
            FZ_ASSERT(n_out >= 0 && n_out <= out_cap);
            for (i = 0; i < n_out; i++) {
                FZ_ASSERT(out[i].id > 0 && out[i].id < g_tr.next_id);
                FZ_ASSERT(out[i].state >= VT_TRACK_TENTATIVE && out[i].state <= VT_TRACK_COASTING);
                for (j = 0; j < i; j++) {
                    FZ_ASSERT(out[i].id != out[j].id);
                }
            }
        }
        if (fz_u8(&f) < 32) { /* end a track now (the pipeline's hand-over), or try a bad id */
            int32_t id = (s == VT_OK && n_out > 0 && fz_u8(&f) < 200) ? out[fz_range(&f, 0, n_out - 1)].id
                                                                        : fz_edge(&f, g_tr.next_id);
            vt_status ds = vt_tracker_drop((fz_u8(&f) == 0xFF) ? NULL : &g_tr, id);
            fz_status(ds);
            if (ds == VT_OK) {
                for (i = 0; i < VT_MAX_TRACKS; i++) {
                    FZ_ASSERT(g_tr.tracks[i].state == VT_TRACK_FREE || g_tr.tracks[i].id != id);
                }
            }
        }
    }
    fz_close(&f);
    return 0;
}
