/* vehtrack/vehicle_model.h -- the seven-parameter geometric vehicle model searched by a
 * genetic algorithm, coarse to fine on a Gaussian pyramid (IVVI paper, sec. 5-6,
 * Fig. 4-6, Table 1).
 *
 * The model (a rear view, input pixels): centre column x, bottom row y (where the
 * shadow meets the road), width w, height h, windshield position (the row of the
 * rear window's lower edge, % of h from the top), bumper position (% of h from the
 * bottom) and roof angle (the cabin's sides slant inward: the roof is narrower than
 * the body by `roof` % of w on each side). The road constrains it (paper Fig. 4b):
 * the width must be within width_tol_permille of the width expected at row y,
 * w_exp(y) = (y - horizon_row) * width_per_row (Q16), and the height within the
 * aspect range of w.
 *
 * Fitness (paper sec. 5, Fig. 5), an integer, larger is better:
 *   w_sym    * symmetry  (255 - mean |I(x - d) - I(x + d)| over VT_MODEL_SAMPLES rows
 *                         x VT_MODEL_SAMPLES offsets d inside the box)
 * + w_grad   * gradient  (mean |Sobel x| / 4 on the model's vertical and slanted edges,
 *                         |Sobel y| / 4 on its horizontal ones, VT_MODEL_SAMPLES points
 *                         per edge, 8 edges)
 * + w_dist   * distance  (mean of 255 (cap - min(D, cap)) / cap at the same points, D
 *                         the exact city-block distance to the nearest edge pixel,
 *                         |Sobel x| + |Sobel y| > edge_thresh)
 * + w_shadow * shadow    (the darkest part: the mean grey of the two rows ending at the
 *                         bottom, over VT_MODEL_SAMPLES columns, below both the mean of
 *                         the two rows under it (road) and the mean of the symmetry
 *                         samples (the vehicle); the smaller margin, clamped 0..255).
 * Every mean is a sum divided by its count, truncated; all terms are exact integers.
 *
 * Search: a GA per pyramid level, coarsest first (levels - 1 .. 0), with population
 * pop[mode][level] and generations gens[mode][level] (mode 0 detection, 1 tracking;
 * defaults = the paper's Table 1: 64/2, 64/2, 128/40 and 32/2, 32/2, 64/10 from the
 * coarsest to the finest level). Detection initialises uniformly inside the
 * constraints and the search rows; tracking initialises around a prediction, each
 * gene offset by a sum of three uniform draws in [-sigma, sigma] (standard deviation
 * sigma, never beyond 3 sigma). A finer level starts from the coarser level's
 * last generation: its best kept as is (elitism), the others jittered by +-2^(l+1)
 * px (+-5 % for the shape genes); individuals beyond the coarser population's size
 * start afresh (uniform or around the prediction). A generation: the elite,
 * then children of two binary-tournament parents, uniform crossover, per-gene
 * mutation with probability mut_permille / 1000, repaired into the constraints.
 * Random numbers: xorshift32 seeded with cfg.seed at every vt_model_fit (a zero
 * seed is replaced by 0x9E3779B9); a draw in [0, n) is (r * n) >> 32. The oracle
 * (pyvehtrack/reference/vehicle_model.py) draws the same numbers, so both produce
 * the same individuals.
 *
 * Cost: bounded by the config: sum over levels of pop * (gens + 1) fitness
 * evaluations, each reading (2 + 4 * 8 + 2) * VT_MODEL_SAMPLES pixels or less
 * (VT_MODEL_SAMPLES = 8: < 300 reads); with Table 1, 5,632 evaluations detecting and
 * 1,472 tracking. Per level: Sobel x/y and a two-pass distance transform of the ROI
 * at that level (about 25 operations per ROI pixel, summed over levels < 1.34 x the
 * ROI). Memory: sizeof(vt_model_ws) = 5.3 * VT_MODEL_MAX_ROI_PIXELS bytes (two
 * pyramid levels, gradients, distances) + the populations: 416,760 bytes at the
 * default 320x240 ROI. Stack: < 1 KB plus vt_pyr_down's row. Measured (`make
 * bench`, a 173x99 ROI in a 640x480 frame): detection 42.2 M instructions (5,588
 * evaluations, ~6.4 k each), tracking 8.8 M (882 evaluations). */
#ifndef VEHTRACK_VEHICLE_MODEL_H
#define VEHTRACK_VEHICLE_MODEL_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/fixed.h"
#include "vehtrack/image.h"
#include "vehtrack/status.h"
#include "vehtrack/verify.h"
#include "vehtrack/flow.h"

/* Largest search ROI (input pixels, width x height). */
#ifndef VT_MODEL_MAX_ROI_PIXELS
#define VT_MODEL_MAX_ROI_PIXELS (320 * 240)
#endif
/* Largest population of any level. */
#ifndef VT_MODEL_MAX_POP
#define VT_MODEL_MAX_POP 128
#endif
/* Pyramid levels of the search (the paper: minimum, medium, maximum resolution). */
#define VT_MODEL_LEVELS 3
/* Sample points per model edge / symmetry rows and offsets / shadow columns. */
#define VT_MODEL_SAMPLES 8
#if VT_MODEL_MAX_ROI_PIXELS < 64 || VT_MODEL_MAX_POP < 2 || VT_MODEL_MAX_POP > 4096
#error "vehicle model capacities out of range (see vehtrack/vehicle_model.h)"
#endif

/* The seven parameters, input pixels / percent. */
typedef struct {
    int32_t x;      /* centre column                                   */
    int32_t y;      /* bottom row                                      */
    int32_t w;      /* width, px                                       */
    int32_t h;      /* height, px                                      */
    int32_t wind;   /* windshield lower edge, % of h from the top      */
    int32_t bump;   /* bumper line, % of h from the bottom             */
    int32_t roof;   /* roof inset per side, % of w (the roof angle)    */
} vt_model_params;

typedef struct {
    int32_t levels;                       /* 1..3 pyramid levels searched            */
    int32_t pop[2][VT_MODEL_LEVELS];      /* [mode][level], level 0 = full resolution */
    int32_t gens[2][VT_MODEL_LEVELS];     /* mode 0 detection, 1 tracking             */
    uint32_t seed;                        /* xorshift32 seed                          */
    int32_t mut_permille;                 /* per-gene mutation probability, 0..1000   */
    int32_t w_sym, w_grad, w_dist, w_shadow; /* fitness weights, 0..64                */
    int32_t edge_thresh;                  /* |gx| + |gy| above this: an edge pixel    */
    int32_t dist_cap;                     /* distance cap, px at the level, 1..64     */
    int32_t horizon_row;                  /* w_exp(y) = (y - horizon_row) *           */
    vt_q16 width_per_row;                 /*           width_per_row, Q16 px per row  */
    int32_t width_tol_permille;           /* w within w_exp +- this permille, 0..900  */
    int32_t aspect_min_permille;          /* h within w * [min, max] / 1000, 100..4000 */
    int32_t aspect_max_permille;          /* (the products truncate toward zero)      */
    int32_t wind_min, wind_max;           /* windshield range, % of h                 */
    int32_t bump_min, bump_max;           /* bumper range, % of h                     */
    int32_t roof_max;                     /* roof inset 0..roof_max, % of w           */
} vt_model_cfg;

/* Table 1 of the paper (levels: finest, medium, coarsest) and typical car shapes.
 * Weights: symmetry 1, gradient 2, distance 0, shadow 4, chosen on the tuning
 * seeds 0-4 of tools/eval_model_synth.py: the distance-to-edge term (weight 1)
 * lowered detection there from 60 % to 38 % of the boxes with IoU >= 0.5 (the
 * road's own texture puts edges everywhere), so it is computed but off by default.
 * The road constraint is a placeholder (horizon at row 0, 1 px of width per row,
 * +-30 %): set horizon_row and width_per_row for your camera (vt_model_cfg_road). */
#define VT_MODEL_CFG_DEFAULT                  \
    {                                         \
        .levels = 3,                          \
        .pop = {{128, 64, 64}, {64, 32, 32}}, \
        .gens = {{40, 2, 2}, {10, 2, 2}},     \
        .seed = 0x2545F491u,                  \
        .mut_permille = 150,                  \
        .w_sym = 1,                           \
        .w_grad = 2,                          \
        .w_dist = 0,                          \
        .w_shadow = 4,                        \
        .edge_thresh = 160,                   \
        .dist_cap = 6,                        \
        .horizon_row = 0,                     \
        .width_per_row = (vt_q16)65536,       \
        .width_tol_permille = 300,            \
        .aspect_min_permille = 600,           \
        .aspect_max_permille = 1100,          \
        .wind_min = 25,                       \
        .wind_max = 60,                       \
        .bump_min = 10,                       \
        .bump_max = 35,                       \
        .roof_max = 25,                       \
    }

/* The search: the ROI (input pixels, inclusive; clipped to the frame) the model
 * must lie in, the rows its bottom may take (y_min..y_max; e.g. from a flow blob:
 * its lowest row to its centre of gravity, paper sec. 6), and for tracking a
 * prediction with per-gene standard deviations (px for x, y, w, h; % for the rest). */
typedef struct {
    vt_box roi;
    int32_t y_min, y_max;
    int32_t tracking;         /* 0 detection (uniform start), 1 tracking          */
    vt_model_params pred;     /* tracking only                                    */
    vt_model_params sigma;    /* tracking only, each >= 0                          */
} vt_model_search;

/* Workspace: the ROI's pyramid levels 1 and 2 (level 0 is read from the frame),
 * gradients and distances of the level being searched, two populations. */
typedef struct {
    uint8_t lvl1[VT_MODEL_MAX_ROI_PIXELS / 4 + 256];
    uint8_t lvl2[VT_MODEL_MAX_ROI_PIXELS / 16 + 256];
    int16_t gx[VT_MODEL_MAX_ROI_PIXELS];
    int16_t gy[VT_MODEL_MAX_ROI_PIXELS];
    uint8_t dist[VT_MODEL_MAX_ROI_PIXELS];
    vt_model_params pop[2 * VT_MODEL_MAX_POP]; /* population c at [c * VT_MODEL_MAX_POP] */
    int32_t fit[2 * VT_MODEL_MAX_POP];
    int32_t cur;              /* which population holds the last generation       */
    int32_t n;                /* its size                                         */
    uint32_t rng;             /* the generator's state after the search           */
    /* The level vt_model_prepare made ready (-1: none): its image, ROI origin
     * (input px) and size; fitness reads these. */
    int32_t level;
    int32_t ox, oy, rw, rh;   /* ROI clipped to the frame, input px               */
    int32_t lw, lh, istride;
    const uint8_t *img;
} vt_model_ws;

typedef struct {
    vt_model_params best;
    int32_t fitness;
    int32_t evaluations;      /* fitness evaluations done (the cost)             */
    vt_box box;               /* best as a box: left = x - w / 2, right = left + w - 1,
                                 bottom = y, top = y - h + 1                      */
} vt_model_result;

/* Fill *cfg with VT_MODEL_CFG_DEFAULT. */
vt_status vt_model_cfg_default(vt_model_cfg *cfg);

/* VT_E_ARG unless every field is in range: populations 2..VT_MODEL_MAX_POP,
 * generations 0..1000, weights 0..64, percent ranges ordered. */
vt_status vt_model_cfg_check(const vt_model_cfg *cfg);

/* Set the road constraint from two rows and the vehicle widths expected there
 * (e.g. a lane-width measurement scaled by 1.8 m / 3.5 m): horizon_row and
 * width_per_row = (w1 - w0) / (y1 - y0) in Q16, rounded half away from zero.
 * VT_E_ARG unless y0 != y1, widths 1..VT_MAX_WIDTH and the slope is positive. */
vt_status vt_model_cfg_road(vt_model_cfg *cfg, int32_t y0, int32_t w0, int32_t y1, int32_t w1);

/* Expected vehicle width at row y: max(0, (y - horizon_row) * width_per_row) in
 * px, rounded half up, saturated to VT_MAX_WIDTH. */
vt_status vt_model_expected_width(const vt_model_cfg *cfg, int32_t y, int32_t *w);

/* The fitness of one parameter set at pyramid `level` of the search's ROI,
 * after vt_model_prepare(level) (for tests and for scoring a tracker's box). */
vt_status vt_model_prepare(vt_model_ws *ws, const vt_model_cfg *cfg,
                           const vt_image_u8 *frame, const vt_model_search *search, int32_t level);
vt_status vt_model_fitness(vt_model_ws *ws, const vt_model_cfg *cfg,
                           const vt_image_u8 *frame, const vt_model_search *search, int32_t level,
                           const vt_model_params *p, int32_t *fitness);

/* Fit the model: the GA, coarse to fine. VT_E_ARG for NULLs, a bad cfg or search
 * (tracking with a negative sigma, y_min > y_max); VT_E_SIZE for a bad frame or an
 * ROI that misses the frame or is smaller than 8x8; VT_E_CAPACITY for an ROI over
 * VT_MODEL_MAX_ROI_PIXELS or a population over VT_MODEL_MAX_POP; VT_E_SINGULAR
 * when no model fits the constraints inside the ROI (e.g. the expected width
 * exceeds it). ws->pop[ws->cur * VT_MODEL_MAX_POP + i], i < ws->n, holds the last
 * generation and ws->fit the same way its fitnesses. */
vt_status vt_model_fit(vt_model_ws *ws, const vt_model_cfg *cfg,
                       const vt_image_u8 *frame, const vt_model_search *search, vt_model_result *out);

/* A detection search from a flow hypothesis (paper sec. 6: the overtaking
 * module's blob limits the model's y between the blob's lowest row and its
 * centre of gravity). The blob covers only the moving, textured part of the
 * vehicle, so the ROI is sized by the road instead: with W the expected width at
 * the blob's lowest row (at least the blob's width), columns from left - W to
 * right + W, rows from bottom - W * aspect_max_permille / 1000 - W / 4 to
 * bottom + W / 4; y_min = h->cy, y_max = bottom + W / 8 (the flat band under the
 * car gives no vectors, so the true bottom can lie a little below the blob).
 * vt_model_fit clips the ROI to the frame. VT_E_ARG for NULLs, a bad cfg or an
 * empty box. */
vt_status vt_model_search_from_flow(const vt_model_cfg *cfg, const vt_flow_hyp *h,
                                    vt_model_search *search);

#endif /* VEHTRACK_VEHICLE_MODEL_H */
