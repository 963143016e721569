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
