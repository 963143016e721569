/* vehtrack/classify.h -- appearance classifier: HOG and GIST descriptors and a
 * linear SVM with quantised weights (GIST paper sec. III: GIST + SVM
 * verification of vehicle hypotheses; HOG as in Dalal & Triggs, the layout of
 * skimage.feature.hog).
 *
 * Sliding-window design. A "prepare" call computes the expensive part once over
 * an image (a band of one pyramid level, a sub-view of the frame): per 8x8 cell
 * the HOG histograms, normalised per 2x2-cell block (vt_hog_prepare), or the 32
 * Gabor energies (vt_gist_prepare). A window whose top-left corner is on the
 * 8 px cell grid then costs lookups only: its HOG descriptor is the
 * concatenation of the prepared blocks it covers, its GIST grid cells are sums
 * of prepared cells (the cell grid plays the part of an integral image: windows
 * move in whole cells, so cell sums are all an integral image would give).
 * Window positions are in cells: (cx, cy) = top-left corner at pixel
 * (8 cx, 8 cy) of the prepared image.
 *
 * Descriptor values are Q15 (32768 = 1.0), all in 0..32768, as uint16.
 *
 * Cost (callgrind, gcc 12 -O2, x86-64; bench/classify_cost.c on a 1280x192 band
 * of bench/data/road_1280x720.png): vt_hog_prepare 93 instructions per band pixel
 * (22.8 M); a window's SVM score is dim multiply-adds, 14.2 k instructions for
 * the 64x64 model (1764 values; 2601 windows: 37 M; -O3 10 k); vt_classify_box
 * with the HOG model on a 120x100 box 0.72 M. GIST is the box verifier, not the
 * sliding-window scorer: ~700 multiply-adds per pixel over its pyramid.
 * Memory: sizeof(vt_hog_ws) = 274,832 bytes at the default 1280x192 band,
 * vt_gist_ws 52,492, vt_cls_box_ws 86,228 (capacities in config.h).
 *
 * Arithmetic, HOG (vt_hog_prepare):
 *   - gradient gx = I(x+1) - I(x-1), gy = I(y+1) - I(y-1); 0 on the image's
 *     outermost rows/columns (as skimage); |g| <= 255;
 *   - orientation folded to [0, 180) and binned into 9 bins of 20 degrees (hard
 *     binning, as skimage): boundaries tested exactly with Q30 sin/cos in int64
 *     (the lattice |g| <= 255 never comes within 2^-20 of a boundary, so bins
 *     equal the float ones);
 *   - magnitude in Q4: round(16 sqrt(gx^2 + gy^2)), exact rounding (error
 *     <= 1/32 per pixel); cell sums uint32 (<= 64 * 5770);
 *   - block (36 sums h) L2-Hys: s2 = sum h^2 (uint64, exact); h_i is clipped
 *     where 25 h_i^2 > s2 (u_i > 0.2 tested exactly); the renormalised value
 *     is round(2^15 * c_i / ||c||) from integer square roots scaled by 256
 *     (relative error < 2^-16 before the final rounding): <= 1 LSB Q15 from
 *     the exact L2-Hys of the Q4 sums. An all-zero block gives zeros (skimage's
 *     eps = 1e-5 changes nothing else measurable).
 * Arithmetic, GIST: see vt_gist_prepare.
 * Arithmetic, SVM (vt_svm_decision): see vt_svm_model. */
#ifndef VEHTRACK_CLASSIFY_H
#define VEHTRACK_CLASSIFY_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/image.h"
#include "vehtrack/status.h"
#include "vehtrack/verify.h"

#define VT_DESC_HOG 1
#define VT_DESC_GIST 2

#define VT_CLS_CELL 8         /* cell side in pixels (HOG cell; GIST accumulation cell) */
#define VT_HOG_BINS 9         /* unsigned orientation bins of 20 degrees */
#define VT_HOG_BLOCK_LEN 36   /* 2x2 cells x 9 bins */
#define VT_GIST_SCALES 4
#define VT_GIST_ORIENT 8
#define VT_GIST_FILTERS 32    /* scales x orientations */
#define VT_GIST_GRID 4        /* 4x4 grid per window */
#define VT_GIST_DIM 512       /* grid cells x filters */
#define VT_GIST_KSIZE 11      /* Gabor kernel side (taps of each 1-D factor) */
#define VT_MLP_MAX_HIDDEN 64  /* hidden units of vt_mlp_model */

/* A linear SVM (const: may live in flash). The caller owns `w`.
 * score = w . x + b with x the Q15 descriptor; weights are Q(w_shift)
 * (real weight = w[i] / 2^w_shift), the bias is Q16. vt_svm_decision forms
 * sum w[i] x[i] exactly in int64 (|sum| < 2^15 * 2^15 * dim), converts it to
 * Q16 by rounding half up (shift by w_shift - 1) and adds the bias,
 * saturating to int32. Error against the float score w_f . x_f + b_f: the
 * weight quantisation (<= 2^-(w_shift+1) per weight, times sum x) plus one
 * Q16 LSB; the descriptor's own error comes on top. */
typedef struct {
    int32_t kind;          /* VT_DESC_HOG or VT_DESC_GIST */
    int32_t win_w;         /* window the model was trained on, px: HOG multiples */
    int32_t win_h;         /* of 8 in 16..VT_CLS_MAX_WIN; GIST multiples of 32 */
    int32_t dim;           /* descriptor length: HOG (win_w/8-1)(win_h/8-1)*36, GIST 512 */
    int32_t w_shift;       /* weight scale, 1..30 */
    int32_t bias_q16;      /* b in Q16 */
    int32_t threshold_q16; /* vehicle if score >= threshold (Q16); 0 for the plain SVM */
    const int16_t *w;      /* dim weights, in descriptor order */
} vt_svm_model;

/* HOG over a prepared image: blocks[by][bx][36], Q15, for every 2x2-cell block
 * of the image (block stride one cell, as skimage). Capacity: images up to
 * VT_CLS_MAX_W x VT_CLS_MAX_H. */
typedef struct {
    int32_t cells_x;  /* cells of the prepared image: w / 8, h / 8 (floor) */
    int32_t cells_y;
    uint32_t hist[2][VT_CLS_MAX_W / VT_CLS_CELL][VT_HOG_BINS]; /* two cell rows (Q4 sums) */
    uint16_t blocks[VT_CLS_MAX_H / VT_CLS_CELL - 1][VT_CLS_MAX_W / VT_CLS_CELL - 1]
                   [VT_HOG_BLOCK_LEN];
} vt_hog_ws;

/* GIST over a prepared image: per 8x8 cell, the 32 filters' energies summed
 * over the cell (see vt_gist_prepare), and row buffers. Capacity: images up
 * to VT_GIST_MAX_W x VT_GIST_MAX_H. */
typedef struct {
    int32_t cells_x;
    int32_t cells_y;
    uint32_t cell[VT_GIST_MAX_H / VT_CLS_CELL][VT_GIST_MAX_W / VT_CLS_CELL][VT_GIST_FILTERS];
    uint8_t level[2][VT_GIST_MAX_H / 2 + 1][VT_GIST_MAX_W / 2 + 1]; /* pyramid ping-pong */
    int32_t rows[VT_GIST_KSIZE][VT_GIST_MAX_W][2]; /* row-filtered ring (complex) */
} vt_gist_ws;

/* Scratch of vt_classify_box: the box resampled to the model window and the
 * descriptor workspaces for one window. */
typedef struct {
    uint8_t win[VT_CLS_MAX_WIN * VT_CLS_MAX_WIN];
    uint16_t desc[VT_CLS_MAX_DIM];
    uint32_t hist[2][VT_CLS_MAX_WIN / VT_CLS_CELL][VT_HOG_BINS];
    vt_gist_ws gist;
} vt_cls_box_ws;

/* Fill every HOG block of img (any view of 16..VT_CLS_MAX_W x
 * 16..VT_CLS_MAX_H pixels; the last w % 8 columns and h % 8 rows are not
 * used, as skimage) into ws. Arithmetic: see the top of this header. */
vt_status vt_hog_prepare(vt_hog_ws *ws, const vt_image_u8 *img);

/* The HOG descriptor of the win_w x win_h window at cell (cx, cy) of the
 * prepared image (skimage.feature.hog's order: block row, block column, cell
 * row, cell column, bin) into out[0..cap-1]; *n_out = its length. VT_E_SIZE if
 * the window does not fit the prepared image or cap is too small. */
vt_status vt_hog_descriptor(const vt_hog_ws *ws, int32_t cx, int32_t cy, int32_t win_w,
                            int32_t win_h, uint16_t *out, int32_t cap, int32_t *n_out);

/* SVM score (Q16) of the window at cell (cx, cy) under model m (kind HOG):
 * the dot product read straight from the prepared blocks, no copy. */
vt_status vt_hog_window_score(const vt_hog_ws *ws, const vt_svm_model *m, int32_t cx,
                              int32_t cy, int32_t *score_q16);

/* Scores of every window position cx0..cx0+ncx-1, cy0..cy0+ncy-1 (row-major:
 * scores[(cy - cy0) * ncx + (cx - cx0)]), cap >= ncx * ncy. All positions must
 * fit the prepared image. The detector's per-level call. */
vt_status vt_hog_scan(const vt_hog_ws *ws, const vt_svm_model *m, int32_t cx0, int32_t cy0,
                      int32_t ncx, int32_t ncy, int32_t *scores, int32_t cap);

/* GIST filter bank on img (32..VT_GIST_MAX_W x 32..VT_GIST_MAX_H): scale s
 * (0..3) works on the Gaussian pyramid level s (vt_pyr_down applied s times);
 * there each of 8 orientations theta_o = o pi / 8 is a complex Gabor filter
 * exp(-(x^2+y^2) / (2 sigma^2)) exp(i 2 pi (x cos theta + y sin theta) / lambda),
 * sigma = 2, lambda = 4 px, 11x11 taps (the real and imaginary parts are
 * cv2.getGaborKernel with gamma 1, psi 0 and -pi/2), applied as two complex
 * 1-D passes (the isotropic envelope makes it separable), border
 * reflect-101 (as cv2.filter2D). Taps are Q14 (c/tables/gist_q14.h). Row pass:
 * exact int32 sums of Q14 x u8; they are rounded to Q4 (shift 10, half up);
 * column pass: exact int64 sums of Q14 x Q4, rounded to Q0 (shift 18, half
 * up) giving re, im; the energy re^2 + im^2 is summed over the level's pixels
 * of each 8x8 base cell (8 / 2^s level pixels square) and divided by the
 * pixel count (round half up): cell[cy][cx][s * 8 + o] = mean energy, uint32,
 * saturating. */
vt_status vt_gist_prepare(vt_gist_ws *ws, const vt_image_u8 *img);

/* The GIST descriptor (512 values) of the win_w x win_h window (multiples of
 * 32) at cell (cx, cy): per grid cell (win/4 px square) and filter, the RMS
 * amplitude sqrt(mean energy) (integer square root, Q4), then the 512-vector
 * scaled to unit L2 norm in Q15 (round half up). Order: grid row, grid column,
 * scale, orientation. */
vt_status vt_gist_descriptor(const vt_gist_ws *ws, int32_t cx, int32_t cy, int32_t win_w,
                             int32_t win_h, uint16_t *out, int32_t cap, int32_t *n_out);

/* score (Q16) = w . desc + b, see vt_svm_model. n must equal m->dim. */
vt_status vt_svm_decision(const vt_svm_model *m, const uint16_t *desc, int32_t n,
                          int32_t *score_q16);

/* VT_OK if the model's fields are consistent (kind, window, dim, shift, w not
 * NULL), else VT_E_ARG. */
vt_status vt_svm_model_check(const vt_svm_model *m);

/* Resample src's rectangle box (inclusive bounds, inside src) to dst (any
 * size) by integer area means: dst pixel (i, j) is the mean of src columns
 * left + floor(i bw / dw) .. left + max(floor((i+1) bw / dw), that + 1) - 1
 * (bw = box width; rows alike), rounded half up. Exact. */
vt_status vt_resample_area(const vt_image_u8 *src, const vt_box *box, vt_image_u8_mut *dst);

/* Score one box of a frame: resample it to the model's window
 * (vt_resample_area), compute the model's descriptor on the window alone (HOG
 * borders as skimage on a crop) and the SVM score (Q16). The hypothesis
 * verifier's call: GIST is affordable here, for a handful of boxes. */
vt_status vt_classify_box(vt_cls_box_ws *ws, const vt_svm_model *m, const vt_image_u8 *frame,
                          const vt_box *box, int32_t *score_q16);

/* A small multilayer perceptron on the same descriptors (the GIST paper's best
 * classifier is an MLP): one hidden layer of `hidden` ReLU units and a linear
 * output. Layer 1: a_j = sum_i w1[j dim + i] x[i] exactly in int64 (Q(w1_shift + 15)),
 * converted to Q16 by rounding half up (shift w1_shift - 1), plus b1_q16[j],
 * saturated to int32, then max(0, .). Output: sum_j w2[j] h_j exactly in int64
 * (Q(w2_shift + 16)), rounded half up to Q16 (shift w2_shift), plus b2_q16,
 * saturated: the logit of sklearn's MLPClassifier. Error against the float net:
 * the weights' rounding (<= 2^-(shift+1) each) and 1 Q16 LSB per rounding,
 * propagated through the output weights. Cost: hidden x dim multiply-adds. */
typedef struct {
    int32_t kind;          /* descriptor: VT_DESC_HOG or VT_DESC_GIST */
    int32_t win_w;
    int32_t win_h;
    int32_t dim;
    int32_t hidden;        /* 1..VT_MLP_MAX_HIDDEN */
    int32_t w1_shift;      /* 1..30 */
    int32_t w2_shift;      /* 1..30 */
    int32_t b2_q16;
    int32_t threshold_q16; /* vehicle if score >= threshold */
    const int16_t *w1;     /* hidden x dim, row-major */
    const int32_t *b1_q16; /* hidden */
    const int16_t *w2;     /* hidden */
} vt_mlp_model;

/* VT_OK if the MLP's fields are consistent (as vt_svm_model_check, and hidden
 * in 1..VT_MLP_MAX_HIDDEN, no NULL arrays), else VT_E_ARG. */
vt_status vt_mlp_model_check(const vt_mlp_model *m);

/* score (Q16) of the MLP on one descriptor; n must equal m->dim. */
vt_status vt_mlp_decision(const vt_mlp_model *m, const uint16_t *desc, int32_t n,
                          int32_t *score_q16);

/* vt_classify_box with an MLP. */
vt_status vt_classify_box_mlp(vt_cls_box_ws *ws, const vt_mlp_model *m, const vt_image_u8 *frame,
                              const vt_box *box, int32_t *score_q16);

/* The default MLP (c/tables/svm_default.h); VT_E_ARG if none is built in. */
vt_status vt_mlp_default_model(const vt_mlp_model **m);

/* The default models generated from the trained .npz files into c/tables/
 * (tools/gen_tables.py): *m is set to point at a static const model. */
vt_status vt_svm_default_model(int32_t kind, const vt_svm_model **m);

#endif /* VEHTRACK_CLASSIFY_H */
