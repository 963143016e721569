/* vehtrack/detect.h -- vehicle detection in one frame given its road area
 * (thesis sec. 2.4.2): shadow hypotheses (shadow.h), then vertical-edge
 * verification (verify.h). The road area comes from the lane stage, called by
 * the caller or by the pipeline.
 *
 * Cost: sizeof(vt_detect_state) = sizeof(vt_shadow_state) + sizeof(vt_verify_state)
 * + 12*VT_MAX_SHADOW_CAND (18.3 KB at the defaults); sizeof(vt_detect_result) = 8 + 12*VT_MAX_HYPOTHESES
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
    vt_hypothesis cand[VT_MAX_SHADOW_CAND]; /* shadow.reduce_verified: the unreduced edges */
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
 * out->n_hyp and out->n_boxes are 0 (if out is not NULL).
 *
 * cfg->shadow.reduce_verified = 1 (issue 8 item 5, not in the thesis): the shadow
 * edges are walked nearest first and each one not suppressed by a VERIFIED edge
 * below it becomes a hypothesis and is verified at once; only if it passes does it
 * suppress the edges above it. A codec hardens the soft lower border of a shadow
 * into a step under the car; with the thesis's rule (0) that false edge wins and
 * hides the car's own edge above it, and then fails verification. out->hyp holds
 * the hypotheses examined; edges past VT_MAX_HYPOTHESES are not verified and are
 * counted in st->shadow.n_dropped. Verification is per hypothesis and depends on
 * nothing else, so a box is the one vt_verify gives for that hypothesis. */
vt_status vt_detect(vt_detect_state *st, const vt_detect_cfg *cfg, const vt_image_u8 *img,
                    const vt_road_area *road, vt_detect_result *out);

#endif /* VEHTRACK_DETECT_H */
