/* vehtrack/acf.h -- a dense first stage for vehicle detection over the whole road:
 * aggregated channel features (Dollar et al.'s ACF, in gray: smoothed intensity,
 * normalised gradient magnitude and 6 orientation channels, summed over 4x4 px
 * cells) on a quarter-octave pyramid, every window of every level inside the
 * flat-road band (IVVI paper sec. 4/5's road restriction) scored by a boosted tree
 * ensemble with a soft cascade. It stands where the GIST paper's sliding windows +
 * classifier (sec. III) stand, and its boxes go on through the same second stage,
 * box regression and NMS (fulldet.h). Issue 8; tools/train_acf.py trains the model,
 * pyvehtrack/reference/acf.py is the float oracle.
 *
 * Arithmetic (all integer, exact; levels and channels do not depend on the model):
 *   Level k (0..VT_ACF_MAX_SCALES-1): r = VT_ACF_SCALE_Q16[k] / 65536 = 2^(k/4) rounded
 *   to Q16 (input px per level px). Size lw = floor(w * 65536 / r_q16), lh likewise.
 *   Level pixel (x, y) = the area mean of input [x r, (x + 1) r) x [y r, (y + 1) r)
 *   (weights in Q16 of an input px, exact in int64), rounded half up
 *   (vt_acf_resample). Level 0 is the input itself.
 *   Channels of an image L (w x h; borders: L(x, y) at clamped x, y):
 *     g(x, y)  = sum_{i,j in -1..1} k_i k_j L(x + i, y + j), k = (1 2 1)   0..4080
 *     gx = g(x+1, y) - g(x-1, y), gy = g(x, y+1) - g(x, y-1)  (g outside the image
 *     from the clamped L, so no second border rule)
 *     m = floor(sqrt(gx^2 + gy^2))                                        0..5770
 *     bin = floor(6 a / pi) (at most 5), a = atan2(gy, gx) mod pi, decided exactly
 *     by comparing gy and gx against tan 30 and tan 60 in Q32 (no integer gradient
 *     lies on a boundary, so this is the real-valued bin)
 *   Cells: cx 0..w/4-1, cy 0..h/4-1 (floor; the last w % 4 columns and h % 4 rows
 *   are not in a cell). Per cell the sums over its 16 px: G = sum g, M = sum m,
 *   O_b = sum of m over pixels of bin b. Normaliser N9 = sum of M over the 3x3 cells
 *   around (clamped to the grid); Q = floor(576 M / (N9 + 2880)) and
 *   floor(576 O_b / (N9 + 2880)) (64 x the cell's magnitude over its neighbourhood's
 *   mean per px plus 20 levels of 4080 = 0.005 of full scale, as Dollar's
 *   normalisation, but per cell). Then [1 2 1] x [1 2 1] smoothing over cells
 *   (clamped): S. Channel bytes: 0 = min(255, (S_G + 2048) >> 12) (the mean gray,
 *   0..255), 1 = min(255, (S_M + 8) >> 4) (64 x normalised magnitude, saturating
 *   at 3.98), 2..7 = min(255, (S_Ob + 8) >> 4) for b = 0..5.
 *   Window: win_cw x win_ch cells at cell (cx, cy), every cell position (a 4 level
 *   px step); its box is the window less `pad` cells on each side: level px
 *   [4 (cx + pad), 4 (cx + win_cw - pad)) x [4 (cy + pad), 4 (cy + win_ch - pad)),
 *   input px left = floor(lx0 r), right = floor(lx1 r) - 1 (top, bottom likewise),
 *   exact in int64.
 *   Score (Q16): bias + sum over trees of the leaf reached (int64, saturated to
 *   int32); a tree of depth d is a full binary tree, node n's children 2n+1 (left)
 *   and 2n+2 (right), right when the window's byte feat[n] > thr[n]; the leaves
 *   are nodes 2^d - 1 .. 2^(d+1) - 2. With reject: after tree t the window is
 *   dropped when the running sum < reject[t] (the soft cascade: most windows stop
 *   after a few trees).
 *   Band (per window row, exact int64): bottom row b, the level's box width
 *   W = floor(4 (win_cw - 2 pad) r) (a box's own width may differ by 1 px),
 *   d = b - horizon: b >= horizon - above_px, b < hood_y and
 *   veh_w_min_mm (d - slack_px) <= W height_mm <= veh_w_max_mm (d + slack_px).
 *   Columns: cfg.cols VT_ACF_COLS_ALL scans cx = 0 .. cw - win_cw; LEFT only cx = 0,
 *   RIGHT only cx = cw - win_cw (the pad cells then lie inside the frame: a LEFT box
 *   starts at floor(4 pad r), a RIGHT box ends less than (4 pad + lw % 4 + 1) r + 1 px
 *   before the frame's right edge).
 *
 * Cost: sizeof(vt_acf_ws) (printed by make bench) is the largest level's band of
 * level pixels, the channel bytes of a VT_MAX_WIDTH x VT_MAX_HEIGHT frame, a few
 * rows and the candidates. Work per frame: per level the band's resampling (input
 * px of the band), channels (about 60 operations per level px: 9 taps, a square
 * root, 2 compares), and up to depth compares + 1 add per tree per window. */
#ifndef VEHTRACK_ACF_H
#define VEHTRACK_ACF_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/fulldet.h"
#include "vehtrack/image.h"
#include "vehtrack/status.h"
#include "vehtrack/windows.h"

#define VT_ACF_NCH 8
#define VT_ACF_SHRINK 4
#define VT_ACF_MAX_SCALES 16
#ifndef VT_ACF_MAX_TREES
#define VT_ACF_MAX_TREES 1024
#endif
#define VT_ACF_MAX_DEPTH 4
/* Window size in cells (incl. pad), at most. */
#define VT_ACF_MAX_WIN_CELLS 32
#ifndef VT_ACF_MAX_CAND
#define VT_ACF_MAX_CAND 4096
#endif
/* Models vt_acf_detect_n runs on one pyramid, at most. */
#define VT_ACF_MAX_MODELS 6
/* vt_acf_cfg.cols: which window columns a model scans. */
#define VT_ACF_COLS_ALL 0   /* every column                                              */
#define VT_ACF_COLS_LEFT 1  /* only cx = 0: vehicles cut by the frame's left edge        */
#define VT_ACF_COLS_RIGHT 2 /* only cx = cw - win_cw (cw = the level's cells across): cut
                               by the right edge                                          */
#if VT_ACF_MAX_TREES < 1 || VT_ACF_MAX_CAND < 1 || VT_ACF_MAX_CAND > VT_MAX_NMS_BOXES
#error "acf capacities out of range (see vehtrack/acf.h)"
#endif

/* r_q16 of level k: round(65536 * 2^(k/4)). */
#define VT_ACF_SCALE_Q16_INIT                                                               \
    {65536, 77936, 92682, 110218, 131072, 155872, 185364, 220436, 262144, 311744, 370728, \
     440872, 524288, 623487, 741455, 881744}

/* A tree ensemble over one window's channel bytes (const: may live in flash). */
typedef struct {
    int32_t win_cw;        /* window in cells incl. pad, 2 pad + 1 .. VT_ACF_MAX_WIN_CELLS */
    int32_t win_ch;
    int32_t pad;           /* context cells on each side, 0..4                        */
    int32_t n_trees;       /* 1..VT_ACF_MAX_TREES                                     */
    int32_t depth;         /* 1..VT_ACF_MAX_DEPTH                                      */
    const uint16_t *feat;  /* n_trees x (2^depth - 1): c win_ch win_cw + y win_cw + x */
    const uint8_t *thr;    /* n_trees x (2^depth - 1): right when byte > thr          */
    const int32_t *leaf;   /* n_trees x 2^depth, Q16, |leaf| <= 2^24                  */
    const int32_t *reject; /* NULL, or n_trees running-sum limits (Q16)               */
    int32_t bias_q16;      /* |bias| <= 2^30                                          */
} vt_acf_model;

typedef struct {
    int32_t first_scale;       /* first level, 0..VT_ACF_MAX_SCALES-1                 */
    int32_t n_scales;          /* 1..VT_ACF_MAX_SCALES - first_scale                  */
    int32_t veh_w_min_mm;      /* box width band at its bottom row (with slack_px of
                                  horizon error); 100..veh_w_max_mm                    */
    int32_t veh_w_max_mm;      /* ..20000 (side views are as wide as a car is long)  */
    int32_t slack_px;          /* 0..VT_MAX_HEIGHT                                    */
    int32_t above_px;          /* bottoms from horizon - above_px, 0..VT_MAX_HEIGHT   */
    int32_t score_min;         /* a window is a candidate when score >= this (Q16)    */
    int32_t nms_iou_permille;  /* vt_nms IoU limit, 0..1000                           */
    int32_t nms_contain_permille; /* vt_nms containment limit (a box mostly inside a
                                  higher-scoring one: a part box, or a flat window on a
                                  car's bottom), 0..1000; 1000: no containment test    */
    int32_t cols;              /* VT_ACF_COLS_*: every window column, or only the one at
                                  the left / right edge of each level (a model of the
                                  part of a vehicle the frame's edge leaves in view)    */
} vt_acf_cfg;

/* Defaults (issue 8's prototype on 'val'): levels 0..14 (boxes 32 .. 362 px wide),
 * widths 0.6 .. 2.2 x the 1.8 m camera height with 20 px of horizon slack, score
 * >= 0, NMS at IoU 0.3. */
#define VT_ACF_CFG_DEFAULT                                                              \
    {                                                                                   \
        .first_scale = 0, .n_scales = 15, .veh_w_min_mm = 1080, .veh_w_max_mm = 3960,   \
        .slack_px = 20, .above_px = 5, .score_min = 0, .nms_iou_permille = 300,         \
        .nms_contain_permille = 1000, .cols = VT_ACF_COLS_ALL,                          \
    }

/* Scratch of vt_acf_detect (static or caller-owned; no pointers kept between calls). */
typedef struct {
    uint8_t lvl[(VT_MAX_WIDTH) * (VT_MAX_HEIGHT)];
    uint32_t hrow[VT_MAX_WIDTH];
    uint64_t acc[VT_MAX_WIDTH];
    uint16_t grow[6][(VT_MAX_WIDTH) + 2];
    uint16_t vrow[VT_MAX_WIDTH]; /* the vertical [1 2 1] pass of one row */
    uint32_t raw[4][VT_ACF_NCH][(VT_MAX_WIDTH) / 4];
    uint32_t nrm[4][VT_ACF_NCH][(VT_MAX_WIDTH) / 4];
    uint8_t ch[VT_ACF_NCH * ((VT_MAX_HEIGHT) / 4) * ((VT_MAX_WIDTH) / 4)];
    int32_t off[VT_ACF_MAX_TREES * 15];
    vt_scored_box cand[VT_ACF_MAX_CAND];
} vt_acf_ws;

/* *cfg = VT_ACF_CFG_DEFAULT. */
vt_status vt_acf_cfg_default(vt_acf_cfg *cfg);

/* VT_OK if every field is in its range (above), else VT_E_ARG. */
vt_status vt_acf_cfg_check(const vt_acf_cfg *cfg);

/* VT_OK if the sizes are in range, the arrays are not NULL, every feat < 8 win_cw
 * win_ch and every leaf and the bias in range; else VT_E_ARG. Cost: one pass. */
vt_status vt_acf_model_check(const vt_acf_model *m);

/* *r_q16 = level k's input px per level px (Q16); VT_E_ARG for k outside 0..15. */
vt_status vt_acf_scale_q16(int32_t k, int32_t *r_q16);

/* Rows y0 .. y0 + dst->h - 1 of src's level at r_q16 (65536 .. 16 x 65536) into
 * dst (dst->w columns from 0): the area means above; ws: scratch. Errors: NULLs -> VT_E_ARG;
 * src as vt_image_u8_check; r_q16 out of range -> VT_E_ARG; dst->w < 1, dst->h <
 * 1, y0 < 0, or the rows or columns past the level (lw, lh above) -> VT_E_SIZE. */
vt_status vt_acf_resample(vt_acf_ws *ws, const vt_image_u8 *src, int32_t r_q16, int32_t y0,
                          vt_image_u8_mut *dst);

/* The channel bytes of cell rows cy0 .. cy0 + n_cy - 1 of img (channels of the
 * whole image, above) into out[c][cy - cy0][cx] (c 0..7, cx 0..img->w/4 - 1),
 * 8 n_cy (img->w / 4) bytes. ws: scratch. Errors: NULL ws, img or out ->
 * VT_E_ARG; img as vt_image_u8_check; img->w or img->h < 4, cy0 < 0, n_cy < 1,
 * cy0 + n_cy > img->h / 4 -> VT_E_SIZE; out_cap smaller than needed ->
 * VT_E_CAPACITY. */
vt_status vt_acf_channels(vt_acf_ws *ws, const vt_image_u8 *img, int32_t cy0, int32_t n_cy,
                          uint8_t *out, int32_t out_cap);

/* The model's score (Q16, reject ignored: the full sum) of the window at cell
 * (cx, cy) of channel planes ch[c][row][col] with `rows` rows and `cols` columns
 * per plane. Errors: NULLs -> VT_E_ARG; m as vt_acf_model_check; rows or cols < 1,
 * or the window past the planes -> VT_E_SIZE. */
vt_status vt_acf_score(const vt_acf_model *m, const uint8_t *ch, int32_t rows, int32_t cols,
                       int32_t cx, int32_t cy, int32_t *score);

/* Detect vehicles in one gray frame: every window of levels first_scale ..
 * first_scale + n_scales - 1 inside the band (above; cam's horizon, hood and
 * height) scored by m with its soft cascade; windows scoring >= score_min are
 * candidates (source VT_SRC_WINDOW; past VT_ACF_MAX_CAND the lowest-scoring one is
 * replaced, counted in n_cand_dropped), thinned by vt_nms (nms_iou_permille,
 * nms_contain_permille); res gets the first VT_MAX_BOXES, highest score first.
 * res->n_windows counts windows scored, n_window_hits those over score_min,
 * n_shadow 0. Levels smaller than a window are skipped. Errors: NULLs -> VT_E_ARG;
 * m, cfg, cam, img as their checks. On error res->n_boxes is 0. */
vt_status vt_acf_detect(vt_acf_ws *ws, const vt_acf_model *m, const vt_acf_cfg *cfg,
                        const vt_camera_min *cam, const vt_image_u8 *img,
                        vt_fulldet_result *res);

/* vt_acf_detect for n models on one pyramid (e.g. a rear-view window and a flat
 * side-view window): each level is resampled and its channels computed once, for the
 * union of the models' band rows (a cell row's channels do not depend on which rows
 * are computed); model i scans its windows with cfg[i]'s levels, band and score_min;
 * all candidates share the cap and one vt_nms at cfg[0]'s NMS limits (highest
 * score first, whichever model scored it). n = 1 is vt_acf_detect. Errors: NULL ws,
 * m, cfg or res, n outside 1..VT_ACF_MAX_MODELS -> VT_E_ARG; each m[i], cfg[i], cam,
 * img as their checks. On error res->n_boxes is 0. */
vt_status vt_acf_detect_n(vt_acf_ws *ws, int32_t n, const vt_acf_model *const *m,
                          const vt_acf_cfg *const *cfg, const vt_camera_min *cam,
                          const vt_image_u8 *img, vt_fulldet_result *res);

#endif /* VEHTRACK_ACF_H */
