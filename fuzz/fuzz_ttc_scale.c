/* fuzz-requires: vehtrack/ttc_scale.h
 * fuzz_ttc_scale.c -- the block-scale TTC (vehtrack/ttc_scale.h): a sequence of steps over
 * fuzzed views (a new size now and then), configurations mutated from the default, tracks
 * with any boxes (plausible ones mostly, so blocks are stored and matched; huge and
 * negative ones too), duplicate and FREE entries, output capacities and NULLs from the
 * bytes. After every step: the status is a vt_status, *n_out <= out_cap, and each output's
 * counts and flags are consistent (matched <= blocks <= grid^2, pairs <= matched choose 2,
 * TTC valid only with the scale valid and s > 1). */
#include "fuzz.h"
#include "vehtrack/ttc_scale.h"

#define FZ_TR (VT_TTC_TRACKS + 3)

static vt_ttc_state g_st;

static vt_box box(fz *f, const vt_image_u8 *img)
{
    vt_box b;
    int32_t w = img->w > 0 && img->w <= VT_MAX_WIDTH ? img->w : 64;
    int32_t h = img->h > 0 && img->h <= VT_MAX_HEIGHT ? img->h : 64;
    if (fz_u8(f) < 220) {
        b.left = fz_range(f, -8, w);
        b.top = fz_range(f, -8, h);
        b.right = b.left + fz_range(f, 0, 48);
        b.bottom = b.top + fz_range(f, 0, 48);
    } else {
        b.left = fz_raw_i32(f);
        b.top = fz_raw_i32(f);
        b.right = fz_raw_i32(f);
        b.bottom = fz_raw_i32(f);
    }
    return b;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    vt_ttc_cfg cfg;
    vt_track_out tr[FZ_TR];
    vt_ttc_out out[FZ_TR];
    vt_image_u8 img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    int32_t step, n_steps, i;
    fz_status(vt_ttc_init(&g_st));
    fz_status(vt_ttc_cfg_default(&cfg));
    if (fz_u8(&f) < 128) { /* small, fast settings most of the time */
        cfg.lag = 1 + (fz_u8(&f) & 1);
        cfg.grid = 2 + (fz_u8(&f) & 3);
        cfg.block = 4 + (fz_u8(&f) & 3);
        cfg.radius = 1 + (fz_u8(&f) & 3);
        cfg.min_texture = fz_u8(&f) & 3;
        cfg.min_pairs = 1;
        cfg.min_pair_px = 1;
    }
    if (fz_u8(&f) >= 240) {
        fz_mutate_i32s(&f, &cfg, sizeof cfg);
    }
    fz_status(vt_ttc_cfg_check(&cfg));
    n_steps = 1 + (fz_u8(&f) & 7);
    for (step = 0; step < n_steps; step++) {
        int32_t n_tr, out_cap, n_out = -1;
        uint8_t nulls = fz_u8(&f) & (fz_u8(&f) | 0xC0u);
        vt_status s;
        if (fz_u8(&f) == 0xFE) {
            img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT); /* a new frame size */
        }
        n_tr = fz_u8(&f) < 240 ? (fz_u8(&f) & 3) : fz_range(&f, -1, FZ_TR);
        for (i = 0; i < n_tr && i < FZ_TR; i++) {
            memset(&tr[i], 0, sizeof tr[i]);
            tr[i].id = fz_u8(&f) < 230 ? i + 1 : fz_edge(&f, 4);
            tr[i].state = fz_u8(&f) < 230 ? VT_TRACK_CONFIRMED : VT_TRACK_FREE;
            tr[i].box = box(&f, &img);
        }
        out_cap = fz_u8(&f) < 220 ? FZ_TR : fz_range(&f, -1, FZ_TR);
        s = vt_ttc_step((nulls & 1) ? NULL : &g_st, (nulls & 2) ? NULL : &cfg, (nulls & 4) ? NULL : &img,
                        (nulls & 8) ? NULL : tr, n_tr > FZ_TR ? FZ_TR : n_tr, (nulls & 16) ? NULL : out,
                        out_cap, (nulls & 32) ? NULL : &n_out);
        fz_status(s);
        if (s == VT_OK || s == VT_E_CAPACITY) {
            FZ_ASSERT(n_out >= 0 && n_out <= out_cap);
            for (i = 0; i < n_out; i++) {
                const vt_ttc_out *o = &out[i];
                FZ_ASSERT(o->id > 0);
                FZ_ASSERT(o->matched >= 0 && o->matched <= o->blocks && o->blocks <= cfg.grid * cfg.grid);
                FZ_ASSERT(o->pairs >= 0 && o->pairs <= o->matched * (o->matched - 1) / 2);
                FZ_ASSERT(!(o->flags & VT_TTC_VALID) || ((o->flags & VT_TTC_SCALE_VALID) &&
                                                         o->scale > VT_Q16_ONE && o->ttc > 0 &&
                                                         o->ttc <= cfg.ttc_max));
                FZ_ASSERT((o->flags & VT_TTC_SCALE_VALID) || o->scale == 0);
            }
        }
    }
    fz_close(&f);
    return 0;
}
