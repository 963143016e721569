/* vehtrack/detect.h -- vehicle detection in one frame given its road area
 * (thesis sec. 2.4.2): shadow hypotheses (shadow.h), then vertical-edge
 * verification (verify.h). The road area comes from the lane stage, called by
 * the caller or by the pipeline.
 *
 * Cost: sizeof(vt_detect_state) = sizeof(vt_shadow_state) + sizeof(vt_verify_state)
 * (17.5 KB at the defaults); sizeof(vt_detect_result) = 8 + 12*VT_MAX_HYPOTHESES
 * + 16*VT_MAX_BOXES bytes. Work: the two stages' (see their headers). */
#ifndef VEHTRACK_DETECT_H
#define VEHTRACK_DETECT_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/image.h"
#include "vehtrack/road.h"
#include "vehtrack/shadow.h"
#include "vehtrack/status.h"
#include "vehtrack/verify.h"

typedef struct {
    vt_shadow_cfg shadow;
    vt_verify_cfg verify;
} vt_detect_cfg;

#define VT_DETECT_CFG_DEFAULT            \
    {                                    \
        .shadow = VT_SHADOW_CFG_DEFAULT, \
        .verify = VT_VERIFY_CFG_DEFAULT, \
    }

typedef struct {
    vt_shadow_state shadow;
    vt_verify_state verify;
} vt_detect_state;

/* What one frame gave: the hypotheses (nearest first) and the verified boxes. */
typedef struct {
    int32_t n_hyp;
    vt_hypothesis hyp[VT_MAX_HYPOTHESES];
    int32_t n_boxes;
    vt_box box[VT_MAX_BOXES];
} vt_detect_result;

/* Fill *cfg with VT_DETECT_CFG_DEFAULT. */
vt_status vt_detect_cfg_default(vt_detect_cfg *cfg);

/* VT_OK if both stages' configurations pass vt_shadow_cfg_check and
 * vt_verify_cfg_check; their status otherwise, VT_E_ARG for NULL. */
vt_status vt_detect_cfg_check(const vt_detect_cfg *cfg);

/* Shadow hypotheses (at most VT_MAX_HYPOTHESES) in `road`, verified into boxes
 * (at most VT_MAX_BOXES). Errors as vt_shadow_find and vt_verify; on any error
 * out->n_hyp and out->n_boxes are 0 (if out is not NULL). */
vt_status vt_detect(vt_detect_state *st, const vt_detect_cfg *cfg, const vt_image_u8 *img,
                    const vt_road_area *road, vt_detect_result *out);

#endif /* VEHTRACK_DETECT_H */
