/* detect.c -- vehicle detection in one frame (thesis sec. 2.4.2, fig. 4.1):
 * shadow hypotheses in the road area, then their verification by vertical
 * edges. The stages stay callable on their own; this only composes them. */
#include <stddef.h>

#include "vehtrack/detect.h"
#include "internal.h"

vt_status vt_detect_cfg_default(vt_detect_cfg *cfg)
{
    static const vt_detect_cfg def = VT_DETECT_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_detect_cfg_check(const vt_detect_cfg *cfg)
{
    vt_status s;
    if (cfg == NULL) {
        return VT_E_ARG;
    }
    s = vt_shadow_cfg_check(&cfg->shadow);
    return s != VT_OK ? s : vt_verify_cfg_check(&cfg->verify);
}

/* The verify-aware reduce (detect.h): cand[0..n_cand-1] bottom-up as
 * vt_shadow_find returns them with reduce_verified. ok[i] says whether
 * out->hyp[i] verified; only those suppress. */
static vt_status vt__detect_reduce_verified(vt_detect_state *st, const vt_detect_cfg *cfg,
                                            const vt_image_u8 *img, int32_t n_cand,
                                            vt_detect_result *out)
{
    unsigned char ok[VT_MAX_HYPOTHESES];
    int32_t i, j;
    for (i = 0; i < n_cand; ++i) {
        const vt_hypothesis *c = &st->cand[i];
        int supp = 0;
        vt_box box;
        int32_t nv = 0;
        vt_status s;
        for (j = 0; j < out->n_hyp && !supp; ++j) {
            const vt_hypothesis *k = &out->hyp[j];
            supp = ok[j] && vt__shadow_suppresses(&cfg->shadow, k->row, k->x_start, k->x_end,
                                                  c->row, c->x_start, c->x_end);
        }
        if (supp) {
            continue;
        }
        if (out->n_hyp >= VT_MAX_HYPOTHESES) {
            ++st->shadow.n_dropped;
            continue;
        }
        s = vt_verify(&st->verify, &cfg->verify, img, c, 1, &box, 1, &nv);
        if (s != VT_OK) {
            return s;
        }
        ok[out->n_hyp] = (unsigned char)(nv > 0);
        out->hyp[out->n_hyp++] = *c;
        if (nv > 0 && out->n_boxes < VT_MAX_BOXES) {
            out->box[out->n_boxes++] = box;
        }
    }
    return VT_OK;
}

vt_status vt_detect(vt_detect_state *st, const vt_detect_cfg *cfg, const vt_image_u8 *img,
                    const vt_road_area *road, vt_detect_result *out)
{
    vt_status s;
    if (out == NULL) {
        return VT_E_ARG;
    }
    out->n_hyp = 0;
    out->n_boxes = 0;
    if (st == NULL || cfg == NULL) {
        return VT_E_ARG;
    }
    /* Both configurations are checked before any work, so a bad verify
     * configuration cannot leave hypotheses without boxes. */
    s = vt_verify_cfg_check(&cfg->verify);
    if (s != VT_OK) {
        return s;
    }
    if (cfg->shadow.reduce_verified) {
        int32_t n_cand = 0;
        s = vt_shadow_find(&st->shadow, &cfg->shadow, img, road, st->cand, VT_MAX_SHADOW_CAND,
                           &n_cand);
        if (s == VT_OK) {
            s = vt__detect_reduce_verified(st, cfg, img, n_cand, out);
        }
        if (s != VT_OK) {
            out->n_hyp = 0;
            out->n_boxes = 0;
        }
        return s;
    }
    s = vt_shadow_find(&st->shadow, &cfg->shadow, img, road, out->hyp, VT_MAX_HYPOTHESES,
                       &out->n_hyp);
    if (s != VT_OK) {
        return s;
    }
    s = vt_verify(&st->verify, &cfg->verify, img, out->hyp, out->n_hyp, out->box, VT_MAX_BOXES,
                  &out->n_boxes);
    if (s != VT_OK) {
        out->n_hyp = 0;
    }
    return s;
}
