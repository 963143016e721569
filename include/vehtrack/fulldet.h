/* vehtrack/fulldet.h -- vehicle detection over the whole road: shadow hypotheses
 * over the road area (thesis sec. 2.4.2.1) verified by vertical edges (sec.
 * 2.4.2.2), and sliding windows on a Gaussian pyramid bounded by flat-road
 * geometry (IVVI paper sec. 4/5, windows.h) scored by a window classifier (GIST
 * paper sec. III); the boxes of both sources merged by non-maximum suppression.
 *
 * The classifier is reached through vt_window_scorer (two function pointers and
 * the caller's context), so this stage does not depend on one descriptor or model
 * kind: the classify stage provides the functions, a test may provide its own.
 * Without a scorer the window source finds nothing and the shadow boxes keep the
 * score cfg->shadow_score.
 *
 * Cost: sizeof(vt_fulldet_state) = the pyramid levels 1.. of a VT_MAX_WIDTH x
 * VT_MAX_HEIGHT frame (~1/3 of a frame: 691 KB at 1920x1080), VT_FULLDET_MAX_WINDOWS
 * windows (16 B each), VT_FULLDET_MAX_CAND candidate boxes (24 B each) and
 * vt_detect_state. Work per frame: the pyramid (25 multiply-adds per level pixel,
 * levels 1..last level with a window), the shadow scan of the road area, one
 * scorer call per window (plus one vt_verify per accepted window when edge_check
 * is set), NMS O(candidates^2).
 * Measured (make bench, -O2, one 1280x720 frame, on a shared 2-CPU machine with a
 * load average of 12.8, so read them as upper bounds): 53 ms for shadow + 864 HOG
 * 32x32 windows; 12.7 ms shadow alone over the camera road, 21.6 ms with each
 * shadow box classified; vt_hog_prepare of a 1280 x 48 band is 5.9 ms of it per
 * level. sizeof(vt_fulldet_state) = 814,356 bytes, vt_hog_scorer 361,096,
 * vt_fulldet_result 796 at the defaults. */
#ifndef VEHTRACK_FULLDET_H
#define VEHTRACK_FULLDET_H

#include <stdint.h>
#include "vehtrack/classify.h"
#include "vehtrack/config.h"
#include "vehtrack/detect.h"
#include "vehtrack/image.h"
#include "vehtrack/road.h"
#include "vehtrack/status.h"
#include "vehtrack/windows.h"

/* Windows handled per pyramid level; more are counted in n_windows_dropped. */
#ifndef VT_FULLDET_MAX_WINDOWS
#define VT_FULLDET_MAX_WINDOWS 4096
#endif
/* Candidate boxes before NMS; past this the lowest-scoring one is replaced. */
#ifndef VT_FULLDET_MAX_CAND
#define VT_FULLDET_MAX_CAND 1024
#endif
#if VT_FULLDET_MAX_WINDOWS < 1 || VT_FULLDET_MAX_CAND < 1 || VT_FULLDET_MAX_CAND > VT_MAX_NMS_BOXES || \
    VT_MAX_BOXES > VT_MAX_NMS_BOXES
#error "fulldet capacities out of range (see vehtrack/fulldet.h)"
#endif
/* Bytes of pyramid levels 1..VT_WIN_MAX_LEVELS-1 of the largest frame: each level
 * is at most (W/2^l + 1) x (H/2^l + 1). */
#define VT_FULLDET_PYR_BYTES                                                                 \
    ((VT_MAX_WIDTH) * (VT_MAX_HEIGHT) / 3 + ((VT_MAX_WIDTH) + (VT_MAX_HEIGHT) + 1) * (VT_WIN_MAX_LEVELS) + 16)

/* The classifier as this stage sees it. `level` (may be NULL) is called once per
 * pyramid level with sliding windows, before they are scored, with the level
 * image and the band of level rows y0..y1 they cover (so a descriptor can
 * precompute its filter responses there); a classified shadow box's window is
 * scored without a `level` call (the scorer handles a window outside its band); `score` (required) gives the decision
 * value of one window of that level image, in the classifier's own fixed-point
 * scale (>= 0: vehicle). A negative status from either stops the frame and is
 * returned. ctx is the caller's (model and scratch). */
typedef struct {
    vt_status (*level)(void *ctx, const vt_image_u8 *level_img, int32_t level, int32_t y0,
                       int32_t y1);
    vt_status (*score)(void *ctx, const vt_image_u8 *level_img, const vt_window *win,
                       int32_t *score);
    void *ctx;
} vt_window_scorer;

/* Hypothesis sources (bits of vt_fulldet_cfg.sources). */
#define VT_FULLDET_SHADOW 1
#define VT_FULLDET_WINDOWS 2

typedef struct {
    int32_t sources;          /* VT_FULLDET_SHADOW | VT_FULLDET_WINDOWS, 1..3          */
    vt_win_cfg win;           /* window rules (windows.h)                              */
    vt_detect_cfg det;        /* shadow + vertical-edge verification (detect.h)       */
    int32_t window_score_min; /* a window is a vehicle when score >= this              */
    int32_t edge_check;       /* 1: an accepted window must also pass vt_verify on its
                                 bottom edge (vertical edges at its sides), 0: not     */
    int32_t shadow_classify;  /* 1 (with a scorer): a shadow box is kept only if the
                                 window nearest to it scores >= shadow_score_min       */
    int32_t shadow_score_min;
    int32_t shadow_score;     /* score of a shadow box when it is not classified       */
    int32_t nms_iou_permille; /* vt_nms limits, permille, 0..1000 (301 and 699 are
                                 the nearest permille to the Q8 77 / 256 and 179 / 256
                                 of before issue 10)                                   */
    int32_t nms_contain_permille;
    int32_t box_height_q8;    /* a window's box keeps its bottom row and width; its
                                 height is max(1, width * this >> 8), 1..1024        */
    int32_t merge_iou_permille; /* 0: off; 1..1000: each box kept by NMS becomes the mean
                                 of every candidate (kept or not, itself included)
                                 whose IoU with it is >= this / 1000 (box refinement:
                                 the highest-scoring window is rarely the best
                                 aligned one; the mean of its neighbours is closer) */
    int32_t rerank_permille;  /* 0: off; 1..1000: weight of the second-stage model's score
                                 in the NMS ranking (vt_fulldet_rerank, run by the caller
                                 after vt_fulldet)                                     */
} vt_fulldet_cfg;

/* Defaults: both sources, windows as VT_WIN_CFG_DEFAULT, detection as
 * VT_DETECT_CFG_DEFAULT but boxes 3/4 as high as wide (verify aspect_q8 192), scores >= 0 (the SVM's own boundary), edges checked,
 * shadow boxes classified with the same boundary, NMS at IoU 0.3 and 0.7 of the
 * smaller box, window boxes 3/4 as high as wide (the median box of
 * tusimple-vehicles-dev TRAIN is 0.59 as high as wide: rear and side views). */
#define VT_FULLDET_CFG_DEFAULT               \
    {                                        \
        .sources = 3,                        \
        .win = VT_WIN_CFG_DEFAULT,           \
        .det = {                             \
            .shadow = VT_SHADOW_CFG_DEFAULT, \
            .verify = {                      \
                .widen_px = 6,               \
                .widen_q8 = 26,              \
                .roi_height_q8 = 128,        \
                .vedge_threshold = 40,       \
                .side_min_frac_permille = 250, \
                .side_min_px = 3,            \
                .side_contrast_q8 = 384,     \
                .min_width_q8 = 128,         \
                .aspect_q8 = 192,            \
            },                               \
        },                                   \
        .window_score_min = 0,               \
        .edge_check = 1,                     \
        .shadow_classify = 1,                \
        .shadow_score_min = 0,               \
        .shadow_score = 0,                   \
        .nms_iou_permille = 301,     \
        .nms_contain_permille = 699, \
        .box_height_q8 = 192,                \
        .merge_iou_permille = 0,             \
        .rerank_permille = 0,                \
    }

typedef struct {
    vt_detect_state det;
    vt_detect_result dres;
    vt_window win[VT_FULLDET_MAX_WINDOWS];
    vt_scored_box cand[VT_FULLDET_MAX_CAND];
    uint8_t pyr[VT_FULLDET_PYR_BYTES];
} vt_fulldet_state;

typedef struct {
    int32_t n_boxes;                 /* boxes after NMS, highest score first           */
    vt_scored_box box[VT_MAX_BOXES];
    int32_t n_windows;               /* windows generated (all levels)                 */
    int32_t n_windows_dropped;       /* past VT_FULLDET_MAX_WINDOWS, not scored        */
    int32_t n_window_hits;           /* windows scoring >= window_score_min            */
    int32_t n_shadow;                /* shadow boxes (verified by vertical edges)      */
    int32_t n_cand;                  /* candidates into NMS                            */
    int32_t n_cand_dropped;          /* candidates replaced for lack of room           */
} vt_fulldet_result;

/* *cfg = VT_FULLDET_CFG_DEFAULT. */
vt_status vt_fulldet_cfg_default(vt_fulldet_cfg *cfg);

/* VT_OK if sources is 1..3, the window, shadow and verify configurations pass
 * their checks, edge_check and shadow_classify are 0/1, the NMS and merge limits
 * are in 0..1000 (permille) and box_height_q8 in 1..1024; else that check's status
 * (VT_E_ARG / VT_E_CAPACITY). */
vt_status vt_fulldet_cfg_check(const vt_fulldet_cfg *cfg);

/* The merge step (merge_iou_permille > 0): box k of the NMS output is replaced by the
 * mean of the candidates c with inter * 1000 >= merge_iou_permille * union (inclusive
 * areas, exact in int64) against k's own box, each coordinate rounded half up:
 * floor((2 sum + n) / (2 n)); sums are exact in int64 (|coord| <= 2^24, n <=
 * VT_FULLDET_MAX_CAND). The score and source stay those of box k. */

/* Re-ranking (cfg->rerank_permille > 0; GIST paper sec. III's classifier as the judge of
 * alignment): NMS keeps the highest-scoring box of each cluster, and the window score
 * is a poor judge of alignment (a misaligned box on a vehicle often outscores the
 * aligned one, tools/recall_loss.py's 'nms' step). Called after vt_fulldet on the same
 * st, img and res (its candidates st->cand[0..res->n_cand-1], in any order), it scores
 * every candidate with the MLP m (normally the built-in HOG 64x64 MLP of
 * vt_fulldet_verify) on the square standing on its bottom row (columns left..right,
 * rows bottom - width + 1 .. bottom, cut at row 0; vt_classify_box_mlp's arithmetic),
 * replaces its score by key = score + floor(rerank_permille * v / 1000) (exact in
 * int64, saturated to int32), orders the candidates by key descending, then left, top,
 * right, bottom ascending (a total order, so the result does not depend on the order
 * vt_fulldet left them in), and redoes vt_fulldet's NMS and merge step with cfg's
 * limits: res->box gets the result (at most VT_MAX_BOXES), each box's score being its
 * key. rerank_permille 0: nothing changes. Errors: NULL argument -> VT_E_ARG; cfg, m and
 * img as their checks; res->n_cand outside 0..VT_FULLDET_MAX_CAND or a candidate box
 * outside img -> VT_E_ARG; the classifier's error (st->cand may then hold keys, res
 * is unchanged). Cost: one vt_classify_box_mlp per candidate (about 1.2 M instructions
 * with the built-in MLP; 10-30 candidates per 1280x720 frame) and the O(n^2) sort. */
vt_status vt_fulldet_rerank(vt_fulldet_state *st, vt_cls_box_ws *ws, const vt_mlp_model *m,
                            const vt_fulldet_cfg *cfg, const vt_image_u8 *img,
                            vt_fulldet_result *res);

/* Detect vehicles in one gray frame.
 *   road: the road area (lanes or vt_road_from_camera), made for img's height;
 *   cam:  the flat-road camera (windows.h);
 *   scorer: NULL, or a scorer whose `score` is not NULL.
 * Windows are taken level by level (windows.h order) and scored on the level
 * image (level 0 is img itself; level l+1 = vt_pyr_down of level l). A window's
 * box is its input-pixel box cut to box_height_q8 of its width (bottom row kept, clipped
 * to the frame); a shadow box is vt_verify's. Boxes past
 * VT_MAX_BOXES after NMS are not written (n_boxes is capped). Errors: NULL st,
 * cfg, cam, img, road or out -> VT_E_ARG; a bad cfg or cam as their checks; img
 * as vt_image_u8_check; a road for another height -> VT_E_SIZE; a scorer's error.
 * On error out->n_boxes is 0 (if out is not NULL). */
vt_status vt_fulldet(vt_fulldet_state *st, const vt_fulldet_cfg *cfg, const vt_camera_min *cam,
                     const vt_image_u8 *img, const vt_road_area *road,
                     const vt_window_scorer *scorer, vt_fulldet_result *out);

/* The classify stage's HOG + linear SVM as a vt_window_scorer: pass
 * {vt_hog_scorer_level, vt_hog_scorer_score, &sc}. level() prepares the HOG
 * blocks of the band (rows y0..y1, at most VT_CLS_MAX_H of them, columns from 0,
 * at most VT_CLS_MAX_W); score() reads a window of the model's size lying on the
 * band's 8 px cell grid from the prepared blocks (vt_hog_window_score: lookups
 * only), preparing the window alone when it lies outside the prepared band or
 * off its grid; any other window (another size, off the grid: the shadow boxes'
 * windows) is scored by vt_classify_box on its level-image box (resampled to the
 * model window, HOG on the crop alone). Scores are the model's Q16 decision
 * values. The model must be of kind VT_DESC_HOG (GIST models: vt_classify_box on
 * every window through the same path, slow). sizeof(vt_hog_scorer) is mostly
 * vt_hog_ws (263 KB at 1280 x 192) and vt_cls_box_ws. */
typedef struct {
    const vt_svm_model *model;
    const uint8_t *px;   /* level image the band was prepared from (NULL: none) */
    int32_t level;
    int32_t x0;          /* band origin in level px */
    int32_t y0;
    int32_t w;           /* band size */
    int32_t h;
    vt_hog_ws hog;
    vt_cls_box_ws box;
} vt_hog_scorer;

/* Point sc at model m (vt_svm_model_check must pass) and forget any band. */
vt_status vt_hog_scorer_init(vt_hog_scorer *sc, const vt_svm_model *m);

/* vt_window_scorer.level for ctx = a vt_hog_scorer *. */
vt_status vt_hog_scorer_level(void *ctx, const vt_image_u8 *level_img, int32_t level, int32_t y0,
                              int32_t y1);

/* vt_window_scorer.score for ctx = a vt_hog_scorer *. */
vt_status vt_hog_scorer_score(void *ctx, const vt_image_u8 *level_img, const vt_window *win,
                              int32_t *score);

/* The classify stage's HOG (or GIST) + MLP (vt_mlp_model) as a vt_window_scorer:
 * pass {NULL, vt_mlp_scorer_score, &sc}. Every window is scored by
 * vt_classify_box_mlp on its level-image box (resampled to the model window by
 * vt_resample_area, descriptor on the crop alone, as the trainer's crops), so the
 * scores are exactly those of the classify stage on the same box (its arithmetic:
 * classify.h, vt_mlp_model). No band sharing: each window costs its descriptor
 * (HOG 32x32: ~1e5 instructions) plus hidden x dim multiply-adds. Scores are the
 * MLP's Q16 logits. */
typedef struct {
    const vt_mlp_model *model;
    vt_cls_box_ws box;
} vt_mlp_scorer;

/* Point sc at model m (vt_mlp_model_check must pass). */
vt_status vt_mlp_scorer_init(vt_mlp_scorer *sc, const vt_mlp_model *m);

/* vt_window_scorer.score for ctx = a vt_mlp_scorer *. */
vt_status vt_mlp_scorer_score(void *ctx, const vt_image_u8 *level_img, const vt_window *win,
                              int32_t *score);

/* Second-stage verification of a result (a cascade: the window model proposes,
 * a stronger model decides): every box of res is scored by the MLP m on the
 * square standing on the box's bottom row (columns left..right, rows
 * bottom - width + 1 .. bottom, cut at row 0) through vt_classify_box_mlp (so
 * its arithmetic, classify.h); boxes scoring >= score_min (Q16) are kept in
 * their order with that score, the others are dropped (res->n_boxes shrinks).
 * Errors: NULL ws, m, img or res -> VT_E_ARG; m as vt_mlp_model_check; img as
 * vt_image_u8_check; res->n_boxes outside 0..VT_MAX_BOXES or a box outside img
 * -> VT_E_ARG. On error res is unchanged. */
vt_status vt_fulldet_verify(vt_cls_box_ws *ws, const vt_mlp_model *m, const vt_image_u8 *img,
                            int32_t score_min, vt_fulldet_result *res);

/* ------------------------------------------------------------------ wide pass
 * Boxes flatter than 1:2 (side views, trucks, cross traffic: a third of the
 * tusimple-vehicles-dev vehicles >= 32 px wide) have no box in vt_fulldet's grid,
 * whose windows are cut to one aspect (box_height_q8), and a square window's score
 * cannot say which aspect its vehicle has. The wide pass is a second grid scored by
 * a second window model trained on such boxes (an MLP on a wide window, e.g. HOG
 * 48x24; tools/train_wide_mlp.py): the windows of `win` (windows.h) with the vehicle
 * band veh_w_min_mm..veh_w_max_mm (a side view is as wide as the vehicle is long),
 * each cut to box_height_permille of its width, bottom row kept: a box of input
 * pixels left = x << level, right = min(((x + size) << level) - 1, w - 1), bottom =
 * min(((y + size) << level) - 1, h - 1), height max(1, floor((size << level) *
 * box_height_permille / 1000)) (top cut at 0), exact in int64. Each box is scored
 * on the input image by vt_classify_box_mlp (its arithmetic: classify.h); boxes
 * scoring >= score_min (Q16) are candidates (past VT_FULLDET_MAX_CAND the lowest
 * score is replaced, as in vt_fulldet), sorted by score (stable) and thinned by
 * greedy NMS: a box is dropped when, with a box kept before it, inter * 1000 >
 * nms_iou_permille * union or inter * 1000 > nms_contain_permille * (smaller area)
 * (inclusive areas, exact in int64). Each kept box that no box already in the result
 * overlaps by the same test is appended to the result (source VT_SRC_WINDOW, score
 * the wide model's), while n_boxes < VT_MAX_BOXES: the wide boxes follow the
 * result's own, so the result is no longer sorted by one score.
 * With alternative heights (alt_height_*: below) a window's box is the best-scoring
 * of up to three heights before the score_min test.
 * Cost: one vt_classify_box_mlp per window (area resampling of the box from the
 * input image, HOG of the model window, the MLP), plus one per alternative height for
 * each window over alt_score_min; measured in bench/. */
typedef struct {
    int32_t veh_w_min_mm;        /* the wide grid's band, 100..20000 mm, min <= max */
    int32_t veh_w_max_mm;
    int32_t box_height_permille; /* box height / width, 1..1000                     */
    int32_t score_min;           /* Q16 decision value of the wide model            */
    int32_t nms_iou_permille;    /* 0..1000                                         */
    int32_t nms_contain_permille;
    /* The box aspect chosen by the wide model's score (0, 0: off, one aspect): a window
     * whose box_height_permille box scores >= alt_score_min (Q16, a cascade gate, so
     * that only the few promising windows pay for more scoring) also has its box scored
     * at alt_height_a_permille and at alt_height_b_permille of its width (each 0: unused,
     * else 1..1000; same bottom row, same cut at row 0); the window's box is the one of
     * the highest score (ties: the earlier of box_height, a, b), and that score goes on
     * to score_min. The model resamples every box to its window, so the score is the
     * cue to the aspect: a box cut to the vehicle's own aspect looks most like the
     * positives it was trained on. */
    int32_t alt_height_a_permille;
    int32_t alt_height_b_permille;
    int32_t alt_score_min;
} vt_fulldet_wide_cfg;

/* Defaults: the band and box height tools/train_wide_mlp.py trains with (2-8 m, 0.4),
 * the model's own boundary (score 0), the NMS limits of the window model's settings
 * (0.2 / 0.5) and one aspect (no alternative heights). The threshold and NMS chosen on tusimple-vehicles-dev 'val' for the
 * shipped wide model travel in its file (tests/data/window_mlp_hog32_wide.npz:
 * score 5.5, NMS 0.1 / 0.3). */
#define VT_FULLDET_WIDE_CFG_DEFAULT                                                       \
    {                                                                                     \
        .veh_w_min_mm = 2000, .veh_w_max_mm = 8000, .box_height_permille = 400,          \
        .score_min = 0, .nms_iou_permille = 200, .nms_contain_permille = 500,            \
        .alt_height_a_permille = 0, .alt_height_b_permille = 0, .alt_score_min = 0,      \
    }

/* *cfg = VT_FULLDET_WIDE_CFG_DEFAULT. */
vt_status vt_fulldet_wide_cfg_default(vt_fulldet_wide_cfg *cfg);

/* VT_OK if every field is in its range (above), else VT_E_ARG. */
vt_status vt_fulldet_wide_cfg_check(const vt_fulldet_wide_cfg *cfg);

/* The wide pass on one gray frame, appending to res (normally vt_fulldet's result on
 * the same frame, after vt_fulldet_verify if that runs). st is scratch (its window
 * and candidate lists are overwritten: call after vt_fulldet has returned); ws is
 * the classifier's scratch; win the window rules (sizes, step, levels, lane width,
 * margin: vt_fulldet's cfg->win), whose band wc replaces; m the wide model; cam and
 * road as vt_fulldet's. Errors: NULL argument -> VT_E_ARG; wc, m, the window rules
 * with wc's band, cam and img as their checks; a road for another height ->
 * VT_E_SIZE; res->n_boxes outside 0..VT_MAX_BOXES -> VT_E_ARG. On error res is
 * unchanged. */
vt_status vt_fulldet_wide(vt_fulldet_state *st, vt_cls_box_ws *ws, const vt_fulldet_wide_cfg *wc,
                          const vt_win_cfg *win, const vt_mlp_model *m, const vt_camera_min *cam,
                          const vt_image_u8 *img, const vt_road_area *road,
                          vt_fulldet_result *res);

/* ------------------------------------------------------------ box regression
 * The window grid cuts every box to one aspect and the merge step averages
 * neighbours, so many boxes sit on a vehicle but miss its outline (IoU 0.2-0.5
 * with it: on tusimple 'val' 57 of the 141 false boxes >= 32 px). A box regressor
 * (bounding-box regression as in R-CNN, on this library's HOG) moves each side of
 * a box by an offset predicted from the box's surroundings: four linear models
 * (vt_svm_model, one per side: left, top, right, bottom) share one HOG descriptor
 * of the context box, the box grown by margin_permille of its width on every side
 * and cut to the image. The four models must have the same kind (VT_DESC_HOG),
 * window and dim; their Q16 "score" is the side's offset in box widths.
 * Trained by tools/train_box_regressor.py (ridge regression, scikit-learn). */
typedef struct {
    int32_t margin_permille; /* context margin, 0..1000 of the box width         */
    int32_t sources;         /* boxes moved: VT_FULLDET_SHADOW | VT_FULLDET_WINDOWS
                                bits of their source, 1..3                     */
    vt_svm_model side[4];    /* offsets of left, top, right, bottom (Q16 widths) */
} vt_box_regressor;

/* VT_OK if margin and sources are in range and the four models pass
 * vt_svm_model_check with one kind, window and dim; else VT_E_ARG (NULL too). */
vt_status vt_box_regressor_check(const vt_box_regressor *r);

/* One box of img (inclusive bounds inside img) moved by r. w = right - left + 1,
 * m = (margin_permille w + 500) / 1000 (integer division); the context box is
 * left - m .. right + m, top - m .. bottom + m, cut to the image; it is scored by
 * vt_classify_box with side[0] (classify.h: area resampling to the model's window,
 * its HOG, the dot product) and by vt_svm_decision with side[1..3] on the same
 * descriptor, giving o_k (Q16). Each side moves by floor((o_k w + 32768) / 65536)
 * (exact in int64: rounding half up), then left and right are cut to 0..w_img - 1,
 * top and bottom to 0..h_img - 1; if then right < left or bottom < top the box is
 * kept as it was. Errors: NULL argument -> VT_E_ARG; r as vt_box_regressor_check;
 * img as vt_image_u8_check; a box outside img -> VT_E_ARG. On error *out = *in
 * when both are given. Cost: one vt_classify_box plus three dot products. */
vt_status vt_box_regress(vt_cls_box_ws *ws, const vt_box_regressor *r, const vt_image_u8 *img,
                         const vt_box *in, vt_box *out);

/* Every box of res whose source is one of r->sources moved by vt_box_regress (the
 * others, and every score and source, unchanged; order kept). Errors as
 * vt_box_regress and res->n_boxes outside 0..VT_MAX_BOXES -> VT_E_ARG; on error
 * res is unchanged. */
vt_status vt_fulldet_refine(vt_cls_box_ws *ws, const vt_box_regressor *r, const vt_image_u8 *img,
                            vt_fulldet_result *res);

/* ------------------------------------------------------------ box rescoring
 * A second stage learnt on the first stage's own boxes (issue 8): the ACF trees
 * at a low threshold find most vehicles but with many false boxes (tusimple 'val',
 * threshold - 1.5: 3 in 4 of the vehicles >= 32 px, 31 false boxes a frame), and
 * the rear-view MLP (vt_fulldet_verify) judges squares, not the boxes they give.
 * vt_fulldet_rescore scores each box again from VT_RESCORE_N_FEAT integer features:
 *   0  hog's decision (Q16) on the HOG of the context box (vt_box_regressor's:
 *      the box grown by margin_permille of its width, cut to the image)
 *   1  the box's own score (Q16, the first stage's)
 *   2  w = right - left + 1 (px)
 *   3  floor(1000 (bottom - top + 1) / w)                        (aspect)
 *   4  floor(1000 w / d), d = max(1, bottom - horizon_y)        (width on the road)
 *   5  floor(1000 (left + right + 1) / (2 w_img))               (centre column)
 *   6  floor(1000 d / h_img)                                     (row below horizon)
 * (exact in int64) with boosted trees (full binary trees of `depth`: node 0, then
 * node = 2 node + 1 + (x[feat[node]] > thr[node]) `depth` times; score = bias +
 * sum of the trees' leaves, Q16, saturated to int32). Trees do not care about a
 * monotone change of a feature, so integer features lose nothing against the float
 * ones they were trained on. Trained by tools/train_rescorer.py (scikit-learn). */
#define VT_RESCORE_N_FEAT 7
#define VT_RESCORE_MAX_TREES 4096
#define VT_RESCORE_MAX_DEPTH 6
typedef struct {
    vt_svm_model hog;             /* linear model on the context HOG (kind VT_DESC_HOG) */
    int32_t margin_permille;      /* context margin, 0..1000 of the box width         */
    int32_t n_trees;              /* 1..VT_RESCORE_MAX_TREES                          */
    int32_t depth;                /* 1..VT_RESCORE_MAX_DEPTH                          */
    const uint8_t *feat;          /* n_trees x (2^depth - 1) feature indices          */
    const int32_t *thr;           /* n_trees x (2^depth - 1): right when x > thr      */
    const int32_t *leaf;          /* n_trees x 2^depth, Q16                           */
    int32_t bias;                 /* Q16                                              */
    int32_t score_min;            /* Q16: boxes scoring less go                       */
    int32_t nms_iou_permille;     /* the NMS after rescoring, 0..1000 (vt_nms's test) */
    int32_t nms_contain_permille;
    int32_t side_keep;            /* 1: a box the frame's side cuts (vt_fulldet_verify's
                                     side test: 4 left <= w + 4 or 4 (w_img - 1 - right)
                                     <= w + 4) whose first-stage score >= side_score_min
                                     stays, scored max(its new score, score_min): the
                                     trees learnt from whole boxes; 0: no such rule    */
    int32_t side_score_min;       /* Q16, the first stage's scale                     */
} vt_box_rescorer;

/* VT_OK if hog passes vt_svm_model_check with kind VT_DESC_HOG, margin, n_trees,
 * depth and the NMS limits are in range, the arrays are given and every feature
 * index is < VT_RESCORE_N_FEAT; else VT_E_ARG (NULL too). Cost: one pass over feat. */
vt_status vt_box_rescorer_check(const vt_box_rescorer *r);

/* The trees' score (Q16) of one feature vector f[VT_RESCORE_N_FEAT] (any values).
 * Errors: NULL -> VT_E_ARG; r as vt_box_rescorer_check. */
vt_status vt_box_rescore_trees(const vt_box_rescorer *r, const int32_t *f, int32_t *score);

/* The features (above) of one scored box of img; cam gives horizon_y. Errors: NULL
 * -> VT_E_ARG; r, cam, img as their checks; a box outside img -> VT_E_ARG. */
vt_status vt_box_rescore_features(vt_cls_box_ws *ws, const vt_box_rescorer *r,
                                  const vt_camera_min *cam, const vt_image_u8 *img,
                                  const vt_scored_box *in, int32_t *f);

/* Every box of res rescored: the boxes scoring >= score_min, with their new scores,
 * sorted by score (stable) and thinned by greedy NMS (vt__box_suppress's test at the
 * rescorer's limits: a box goes when a box kept before it overlaps it by more);
 * sources kept. Errors as vt_box_rescore_features and res->n_boxes outside
 * 0..VT_MAX_BOXES -> VT_E_ARG; on error res is unchanged. Cost: one
 * vt_classify_box per box plus the trees. */
vt_status vt_fulldet_rescore(vt_cls_box_ws *ws, const vt_box_rescorer *r,
                             const vt_camera_min *cam, const vt_image_u8 *img,
                             vt_fulldet_result *res);

#endif /* VEHTRACK_FULLDET_H */
