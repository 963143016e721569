/* fuzz-requires: vehtrack/flow.h
 * fuzz_flow.c -- the motion stage for overtaking vehicles (vehtrack/flow.h;
 * thesis sec. 2.5, IVVI paper sec. III.C): a sequence of vt_flow_step calls,
 * the first a first frame, with a new view (another size, stride < w, NULL px)
 * between calls when the bytes say so, the configuration mutated between calls
 * (level changes restart), resets, and hand-over tracks seeded from fuzzed boxes
 * and unseeded by fuzzed ids. Frames are kept small (views of fz.h) so a run of
 * up to 4 steps stays fast. After each step: a vt_status, the hypotheses within
 * capacity, boxes ordered, ids positive and below the next id, counters >= 0;
 * on error *out is zeroed. */
#include "fuzz.h"
#include "vehtrack/flow.h"

static vt_flow_state g_st;
static vt_flow_result g_out;

static vt_box box(fz *f, const vt_image_u8 *img)
{
    int32_t w = img->w > 0 && img->w <= VT_MAX_WIDTH ? img->w : 64;
    int32_t h = img->h > 0 && img->h <= VT_MAX_HEIGHT ? img->h : 48;
    return fz_u8(f) < 220 ? fz_box_near(f, w, h, 40, 40) : fz_box_edge(f, w, h);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    vt_flow_cfg cfg;
    vt_image_u8 img;
    int32_t step, n_steps, i, ids[4] = {0, 0, 0, 0}, n_ids = 0;
    fz_status(vt_flow_init(&g_st));
    fz_status(vt_flow_cfg_default(&cfg));
    if (fz_u8(&f) < 160) { /* level 0 and small cells: small frames still have cells */
        cfg.level = fz_range(&f, 0, 1);
        cfg.cell = fz_range(&f, 2, 8);
        cfg.strip_permille = fz_range(&f, 100, 500);
        cfg.sides = fz_range(&f, 1, 3);
    }
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_flow_cfg_check(&cfg));
    /* The search window cut to +-3 px and cells to 8 px once checked: the same loops, a quarter
     * of the cost (speed: the harness aims at >= 5,000 inputs/s). */
    cfg.search_x = cfg.search_x > 3 ? cfg.search_x % 4 : cfg.search_x;
    cfg.search_y = cfg.search_y > 3 ? cfg.search_y % 4 : cfg.search_y;
    cfg.cell = cfg.cell > 8 ? 2 + cfg.cell % 7 : cfg.cell; /* the SAD costs cell^2 */
    img = fz_image_u8_small(&f, 32, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    n_steps = 1 + (fz_u8(&f) & 3);
    for (step = 0; step < n_steps; step++) {
        uint8_t act = fz_u8(&f), nulls = fz_u8(&f) & (fz_u8(&f) | 0xF0u);
        vt_status s;
        if (act == 0xFE) {
            img = fz_image_u8_small(&f, 32, VT_MAX_WIDTH, VT_MAX_HEIGHT); /* another frame size */
        } else if (act == 0xFD) {
            fz_mutate_i32s(&f, &cfg, sizeof cfg);
        } else if (act == 0xFC) {
            fz_status(vt_flow_reset((nulls & 1) ? NULL : &g_st));
        } else if (act == 0xFB) {
            fz_status(vt_flow_init(&g_st));
            n_ids = 0;
        } else if (act >= 0xF0) { /* fill the frame anew: motion */
            if (img.px != NULL && img.w > 0 && img.h > 0 && img.w <= VT_MAX_WIDTH &&
                img.h <= VT_MAX_HEIGHT && img.stride >= img.w) { /* a view fz_geom allocated */
                fz_fill(&f, (uint8_t *)(uintptr_t)img.px, img.w, img.h, img.stride);
            }
        }
        s = vt_flow_step((nulls & 2) ? NULL : &g_st, (nulls & 4) ? NULL : &cfg, (nulls & 8) ? NULL : &img,
                         (nulls & 16) ? NULL : &g_out);
        fz_status(s);
        if (!(nulls & 16)) {
            if (s != VT_OK) {
                FZ_ASSERT(g_out.n == 0 && g_out.ready == 0);
            } else {
                FZ_ASSERT(g_out.n >= 0 && g_out.n <= VT_FLOW_MAX_HYPS && g_out.dropped >= 0);
                FZ_ASSERT(g_out.cells_total >= 0 && g_out.cells_computed >= 0 &&
                          g_out.cells_computed <= g_out.cells_total &&
                          g_out.cells_accepted <= g_out.cells_computed);
                for (i = 0; i < g_out.n; i++) {
                    const vt_flow_hyp *h = &g_out.hyp[i];
                    FZ_ASSERT(h->box.left <= h->box.right && h->box.top <= h->box.bottom);
                    /* flow.h: an overtaking blob has id 0, a hand-over track its seed's id
                     * (the first version asserted id > 0 for both; fuzz-long found a blob). */
                    FZ_ASSERT(h->kind == VT_FLOW_KIND_OVERTAKING || h->kind == VT_FLOW_KIND_HANDOVER);
                    FZ_ASSERT(h->kind == VT_FLOW_KIND_OVERTAKING ? h->id == 0
                                                                  : h->id > 0 && h->id < g_st.next_id);
                    FZ_ASSERT(h->age >= 1);
                }
            }
        }
        if (fz_u8(&f) < 64) { /* hand a vehicle over */
            vt_box b = box(&f, &img);
            int32_t id = -1;
            uint8_t how = fz_u8(&f);
            if (how & 1) { /* with the frame: its previous level image over the box */
                s = vt_flow_seed_frame((nulls & 32) ? NULL : &g_st, (nulls & 64) ? NULL : &cfg,
                                       (how & 2) ? NULL : &img, &b, (nulls & 128) ? NULL : &id);
            } else {
                s = vt_flow_seed((nulls & 32) ? NULL : &g_st, (nulls & 64) ? NULL : &cfg, &b,
                                 (nulls & 128) ? NULL : &id);
            }
            fz_status(s);
            if (s == VT_OK && n_ids < 4) {
                FZ_ASSERT(id > 0);
                ids[n_ids++] = id;
            }
        }
        if (fz_u8(&f) < 32) { /* stop one: a known id, or any value */
            int32_t id = (n_ids > 0 && fz_u8(&f) < 200) ? ids[fz_range(&f, 0, n_ids - 1)] : fz_edge(&f, 8);
            fz_status(vt_flow_unseed((nulls & 32) ? NULL : &g_st, id));
        }
    }
    fz_close(&f);
    return 0;
}
