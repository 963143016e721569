/* vehtrack/shadow.h -- vehicle hypotheses from the shadow underneath vehicles
 * (thesis sec. 2.4.2.1): a bottom-up scan of the road area for shadow edges,
 * merged across rows, checked against the vehicle width expected from the lane
 * width, reduced to one bottom edge per vehicle.
 *
 * Cost: sizeof(vt_shadow_state) = 2*VT_MAX_WIDTH + 1028 + 12*(VT_MAX_SHADOW_ACTIVE
 * + VT_MAX_SHADOW_CAND) + 32 bytes (6.3 KB at the defaults); no frame buffer: the
 * Sobel d/dy is formed on the fly from three source rows and one int16 row of
 * vertical differences. Work per frame: one pass over the road area (about 6
 * adds and 2 compares per pixel), plus, in adaptive mode, a 256-bin histogram of
 * every stat_step-th road pixel in each direction, from which the median and the
 * median absolute deviation (MAD) follow exactly in O(256); merging is
 * O(runs x open groups), sorting and reducing O(VT_MAX_SHADOW_CAND^2).
 *
 * Which edge: the thesis scans bottom-up for "transitions from brighter gray
 * values to darker ones" -- from the lit road up into the dark shadow. With y
 * growing downward that is the lower border of the dark region: dark above,
 * bright below, where vt_sobel_y (positive where the image gets brighter going
 * down) is large and POSITIVE. That border is where the shadow meets the road,
 * the bottom of the vehicle when the sun is high. VT_SHADOW_DARK_ABOVE selects
 * it (the default). VT_SHADOW_DARK_BELOW selects the other border of the dark
 * region (bright vehicle body above, its shadow below: vt_sobel_y NEGATIVE),
 * which stays at the vehicle when a low sun casts the shadow toward the camera
 * and its lower border runs away from the vehicle (the drawback the thesis names
 * in sec. 4). Read top-down, DARK_ABOVE is "dark turns bright going down". */
#ifndef VEHTRACK_SHADOW_H
#define VEHTRACK_SHADOW_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/geometry.h" /* vt_hypothesis */
#include "vehtrack/image.h"
#include "vehtrack/road.h"
#include "vehtrack/status.h"

/* Threshold modes. */
#define VT_SHADOW_FIXED 0    /* the thesis: a hand-set gradient threshold */
#define VT_SHADOW_ADAPTIVE 1 /* dark relative to the road area's own statistics */
/* Edge polarities (see the header comment). */
#define VT_SHADOW_DARK_ABOVE 0 /* shadow above the lit road: sobel_y >= t */
#define VT_SHADOW_DARK_BELOW 1 /* body above its shadow: -sobel_y >= t */

/* Configuration (const: may live in flash). Fractions of at most one are permille
 * (1000 = 1.0); the scale factors that may exceed one (widths and heights relative
 * to a width, k) are Q8 (256 = 1.0).
 * Sobel values carry a gain of 4: a sharp step of d gray levels gives 4d. */
typedef struct {
    int32_t threshold_mode;    /* VT_SHADOW_FIXED or VT_SHADOW_ADAPTIVE */
    int32_t polarity;          /* VT_SHADOW_DARK_ABOVE or VT_SHADOW_DARK_BELOW */
    int32_t grad_threshold;    /* fixed: edge if s*sobel_y >= this, 1..1020 */
    int32_t adapt_k_q8;        /* adaptive: the dark side of the edge must be
                                  < median - k*MAD of the road, k in Q8, 0..4096 */
    int32_t adapt_grad_min;    /* adaptive: and s*sobel_y >= this, 1..1020 */
    int32_t stat_step;         /* adaptive: statistics on every n-th row/column, 1..64 */
    int32_t min_run;           /* shortest edge kept, px (thesis: 10-15), 1..4096 */
    int32_t max_gap;           /* non-edge pixels bridged inside a run, 0..255 */
    int32_t merge_rows;        /* rows within this are combined (thesis: 2), 0..255 */
    int32_t width_min_q8;      /* edge width >= this x lane width at its row, 0..65535 */
    int32_t width_max_q8;      /* edge width <= this x lane width, width_min_q8..65535 */
    int32_t reduce_overlap_permille; /* reduce: x overlap >= this/1000 x narrower width, 0..1000 */
    int32_t reduce_height_q8;  /* reduce: at most this x kept width above, 0..65535 */
    int32_t reduce_verified;   /* 0: every kept edge suppresses the edges above it (the
                                  thesis); 1: only one whose hypothesis passes
                                  verification does. vt_shadow_find cannot verify, so
                                  with 1 it skips the reduce step and returns every
                                  edge that passed the width test, nearest first;
                                  vt_detect verifies and reduces them. 0..1 */
} vt_shadow_cfg;

/* Defaults: the thesis's values where it gives them (the DARK_ABOVE edge,
 * min_run 12 within its 10-15 px, rows within 2 px merged). It gives no
 * threshold; the adaptive mode with k = 0.375, a gradient floor of 8 (a 2-level
 * step) and the width band 0.3..1.0 lane widths were chosen on the 78 KITTI
 * frames of tools/eval_kitti_lead.py, so that figure is not an unseen-data
 * figure. grad_threshold 48 (a 12-level step) is for the fixed mode.
 * reduce_verified is off (the thesis's reduce): on KITTI frames 0-38 through mp4v
 * it finds 3 more lead cars and loses none on PNG, but on the held-out frames
 * 39-77 it gains none, and the ego-lane detector's precision on tusimple TEST
 * falls by more than a point (README "Compression"). */
#define VT_SHADOW_CFG_DEFAULT                 \
    {                                         \
        .threshold_mode = VT_SHADOW_ADAPTIVE, \
        .polarity = VT_SHADOW_DARK_ABOVE,     \
        .grad_threshold = 48,                 \
        .adapt_k_q8 = 96,                     \
        .adapt_grad_min = 8,                  \
        .stat_step = 2,                       \
        .min_run = 12,                        \
        .max_gap = 2,                         \
        .merge_rows = 2,                      \
        .width_min_q8 = 77,                   \
        .width_max_q8 = 256,                  \
        .reduce_overlap_permille = 500,       \
        .reduce_height_q8 = 256,              \
        .reduce_verified = 0,                 \
    }

/* A group of shadow edges being merged (rows bottom..last, last <= bottom). */
typedef struct {
    int16_t bottom;
    int16_t last;
    int16_t x_start;
    int16_t x_end;
    int32_t id; /* creation order, the final tie-break */
} vt_shadow_group;

/* Scratch and diagnostics of one vt_shadow_find call; the caller owns it (static
 * memory on firmware). No content carries over between calls. */
typedef struct {
    int16_t dy[VT_MAX_WIDTH + 2];  /* row of vertical differences below-above,
                                      one replicated column each side */
    uint32_t hist[256];            /* road intensity histogram (adaptive mode) */
    vt_shadow_group active[VT_MAX_SHADOW_ACTIVE];
    vt_shadow_group cand[VT_MAX_SHADOW_CAND];
    int32_t n_active;
    int32_t n_cand;
    /* diagnostics of the last call */
    int32_t median;      /* adaptive: road median and MAD, gray levels */
    int32_t mad;
    int32_t dark_limit;  /* adaptive: a pixel is dark if < this */
    int32_t n_samples;   /* adaptive: road pixels in the histogram */
    int32_t n_runs;      /* runs >= min_run */
    int32_t n_dropped;   /* runs, groups, hypotheses lost to capacities */
} vt_shadow_state;

/* Fill *cfg with VT_SHADOW_CFG_DEFAULT (for bindings that cannot expand macros). */
vt_status vt_shadow_cfg_default(vt_shadow_cfg *cfg);

/* VT_OK if every field is in its domain, else VT_E_ARG. */
vt_status vt_shadow_cfg_check(const vt_shadow_cfg *cfg);

/* Hypotheses in the road area of `img`, nearest (bottom-most) first; at most
 * `cap` are written to out[0..cap-1] and their number to *n_out (hypotheses past
 * cap are counted in st->n_dropped). out may be NULL when cap is 0.
 * The road area must have been made for this image (road->height == img->h,
 * else VT_E_SIZE); its columns are clamped to the image and rows outside it are
 * ignored. A road with valid == 0, an empty road, or (adaptive mode) no sampled
 * road pixel gives zero hypotheses and VT_OK. Rows whose lane_width <= 0 accept
 * no edge. On any error *n_out (if not NULL) is 0. */
vt_status vt_shadow_find(vt_shadow_state *st, const vt_shadow_cfg *cfg, const vt_image_u8 *img,
                         const vt_road_area *road, vt_hypothesis *out, int32_t cap,
                         int32_t *n_out);

#endif /* VEHTRACK_SHADOW_H */
