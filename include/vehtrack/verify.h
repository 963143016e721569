/* vehtrack/verify.h -- hypothesis verification by vertical edges (thesis sec.
 * 2.4.2.2): a region of interest above each shadow bottom edge, the horizontal
 * projection of its vertical edges searched from the left and from the right for
 * the vehicle's two sides, the top from an aspect ratio.
 *
 * Cost: sizeof(vt_verify_state) = 6*VT_MAX_WIDTH bytes (11.3 KB at 1920); no
 * frame buffer: the horizontal derivative is formed on the fly from three source
 * rows through one row of vertical [1 2 1] sums. Work per hypothesis: about 7
 * adds and 3 compares per ROI pixel (ROI = (edge + 12) x edge/2 at the defaults).
 *
 * Compressed video (issue 8 item 5; not in the thesis): a codec (MPEG-4 part 2,
 * H.264, JPEG) quantises the high frequencies away, so a vehicle's side -- a
 * step of ten or so gray levels on a dark car -- is spread over 2-3 columns and
 * its Sobel peak falls below the threshold on many rows, while the step itself
 * and the contour's continuity survive. Two tolerances answer that, each off at
 * 0 (the thesis's verification, and what an initialiser that omits them gets):
 * vedge_reach measures the step over a wider baseline (vsum[x+1+r] -
 * vsum[x-1-r], so a ramp up to 2+2r px wide keeps its full height), and
 * vedge_hyst_permille counts a pixel a little below the threshold when its
 * vertical run of such pixels in the same column holds one at or above it
 * (hysteresis along the side, as Canny's). */
#ifndef VEHTRACK_VERIFY_H
#define VEHTRACK_VERIFY_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/geometry.h" /* vt_box, vt_hypothesis; included here so older includers keep them */
#include "vehtrack/image.h"
#include "vehtrack/shadow.h"
#include "vehtrack/status.h"

/* Configuration (const: may live in flash). Fractions of at most one are permille
 * (1000 = 1.0); the scale factors that may exceed one (widths, heights, aspect,
 * contrast) are Q8 (256 = 1.0). */
typedef struct {
    int32_t widen_px;         /* ROI = edge widened by widen_px + widen_q8 x edge length */
    int32_t widen_q8;         /* on each side (thesis: 6 px and 0), 0..4096 and 0..1024 */
    int32_t roi_height_q8;    /* ROI height = this x edge length (thesis: 1/2), 1..4096 */
    int32_t vedge_threshold;  /* |sobel_x| >= this is a vertical edge pixel, 1..1020 */
    int32_t side_min_frac_permille; /* a side's column needs edges on >= this/1000 x ROI rows, 0..1000 */
    int32_t side_min_px;      /* and on >= this many rows, 0..4096 */
    int32_t side_contrast_q8; /* and >= this x the ROI's mean column count, 0..4096
                                 (a side stands out; texture and noise do not) */
    int32_t min_width_q8;     /* sides >= this x edge length apart (right-left+1), 0..4096 */
    int32_t aspect_q8;        /* box height = width x this (thesis: 1.0 = 256), 1..4096 */
    int32_t vedge_reach;      /* derivative vsum[x+1+r] - vsum[x-1-r] (thesis: Sobel, 0), 0..3;
                                 gain 4 per gray level of a step within the baseline */
    int32_t vedge_hyst_permille; /* weak threshold = vedge_threshold - floor(vedge_threshold
                                 x this / 1000), at least 1; a weak pixel counts if its
                                 vertical run of weak pixels holds a strong one
                                 (thesis: 0, none), 0..1000 */
} vt_verify_cfg;

/* Defaults: the thesis's 6 px, half-length ROI and aspect 1; widen_q8 = 0.1
 * (the shadow between the wheels is narrower than the body), the edge threshold
 * 40 and the side fractions were chosen on the KITTI frames of
 * tools/eval_kitti_lead.py. The codec tolerance (reach 1, hysteresis 200: chosen
 * on frames 0-38 written as mp4v / JPEG) is off by default: on the held-out
 * frames 39-77 it found no more lead cars through mp4v and cost tracking IoU and
 * the ego-lane detector's precision on tusimple TEST (README "Compression"). */
#define VT_VERIFY_CFG_DEFAULT    \
    {                            \
        .widen_px = 6,           \
        .widen_q8 = 26,          \
        .roi_height_q8 = 128,    \
        .vedge_threshold = 40,   \
        .side_min_frac_permille = 250, \
        .side_min_px = 3,        \
        .side_contrast_q8 = 384, \
        .min_width_q8 = 128,     \
        .aspect_q8 = 256,        \
        .vedge_reach = 0,        \
        .vedge_hyst_permille = 0, \
    }


/* Row scratch; the caller owns it. No content carries over between calls. */
typedef struct {
    uint16_t vsum[VT_MAX_WIDTH]; /* vertical [1 2 1] sums of one ROI row */
    uint16_t proj[VT_MAX_WIDTH]; /* vertical-edge count per ROI column */
    uint16_t run[VT_MAX_WIDTH];  /* hysteresis per ROI column: weak pixels of the
                                    current run not yet counted, or 0xFFFF once the
                                    run holds a strong pixel (rows < 0xFFFF) */
} vt_verify_state;

/* Fill *cfg with VT_VERIFY_CFG_DEFAULT. */
vt_status vt_verify_cfg_default(vt_verify_cfg *cfg);

/* VT_OK if every field is in its domain, else VT_E_ARG. */
vt_status vt_verify_cfg_check(const vt_verify_cfg *cfg);

/* Verify n_hyp hypotheses (n_hyp >= 0; hyp may be NULL when n_hyp is 0); the
 * boxes of those that pass are written in hypothesis order to out[0..cap-1]
 * (out may be NULL when cap is 0; boxes past cap are not written) and their
 * number to *n_out. Every hypothesis must lie in the image
 * (0 <= x_start <= x_end < w, 0 <= row < h), else VT_E_ARG and nothing is
 * verified. On any error *n_out (if not NULL) is 0. */
vt_status vt_verify(vt_verify_state *st, const vt_verify_cfg *cfg, const vt_image_u8 *img,
                    const vt_hypothesis *hyp, int32_t n_hyp, vt_box *out, int32_t cap,
                    int32_t *n_out);

#endif /* VEHTRACK_VERIFY_H */
