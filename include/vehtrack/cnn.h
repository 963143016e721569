/* vehtrack/cnn.h -- a small quantised CNN detector: the appearance stage as a
 * CenterNet-style heat map + box sides at the model's output stride (8 for the
 * shipped layout), in place of the GIST paper's sliding-window classifier (sec.
 * III) for full-frame hypotheses. The model is caller-owned and const (firmware
 * keeps it in flash); the activations live in one caller-owned uint8 work buffer
 * (vt_cnn_work_bytes). pyvehtrack/reference/cnn.py is the bit-exact NumPy twin.
 *
 * Arithmetic (all integer, exact; the C and the twin agree bit for bit):
 *   Activations are channel-last (HWC), row-major, tightly packed. The input is a
 *   uint8 gray image (w x h, row stride in bytes), the activation of layer 0 with
 *   one channel and zero point 0.
 *   Layer: ksize k (1 or 3), stride s (1 or 2), dilation d (1 or 2; 1 for 1x1),
 *   zero ("same") padding pad = d (k / 2). Output size per axis: out = (in + s - 1)
 *   / s (ceil). Output pixel (ox, oy) is centred on input (ox s, oy s): its taps
 *   are (ox s + (kx - 1) d, oy s + (ky - 1) d) for 3x3, (ox s, oy s) for 1x1; a tap
 *   outside the input reads 0.
 *   acc = bias[co] + sum over taps and ci of w[co][ky][kx][ci] a[ci] in int32:
 *   |w| <= 128, a <= 255, at most 9 x 128 taps (VT_CNN_MAX_CH): |sum| <= 37,601,280
 *   < 2^26, and |bias| <= 2^30 (checked), so |acc| < 2^30 + 2^26 < 2^31: no overflow.
 *   Requantise: q = floor((acc mult[co] + 2^(shift[co] - 1)) / 2^shift[co]) in
 *   int64 (|acc mult| < 2^62, so no overflow), i.e. acc mult / 2^shift rounded
 *   half up (toward +inf); mult 1 .. 2^31 - 1, shift 1 .. 62.
 *   Clamp: relu layers (all but the last) write uint8 q clamped to 0..255; the
 *   last layer (relu 0) writes int8 q clamped to -128..127, 5 channels: heat
 *   (channel 0) and the left, top, right, bottom side codes (channels 1..4).
 *   Decode (vt_cnn_decode): grid cell (x, y) is a peak when its heat >= thr and
 *   >= the heat of each of its (up to 8) in-grid neighbours (plateaus give every
 *   cell). Peaks are ordered by heat descending, ties in raster order (y, then
 *   x) ascending. Box in level pixels Q4, S = out_stride:
 *   cx = (x S + S / 2) 16, cy = (y S + S / 2) 16 (S / 2 floor);
 *   l = cx - lut[0][ql + 128], t = cy - lut[1][qt + 128],
 *   r = cx + lut[2][qr + 128], b = cy + lut[3][qb + 128];
 *   full-frame pixels: each v' = v 2^scale_shift; left / top = floor((v' + 8) / 16),
 *   right / bottom = floor((v' + 8) / 16) - 1 (the Q4 box is exclusive, vt_cnn_box
 *   inclusive). score = heat. Exact in int64, every value fits int32.
 *
 * Cost: no state; sizeof(vt_cnn_model) is 208 bytes on a 32-bit core (344 on a
 * 64-bit host) plus the caller's arrays. Work per frame: the sum over layers of
 * out_w out_h cout k^2 cin multiply-adds (about 10^8 for a stride-8 detector of
 * 32 channels on a 640x256 frame) and one int64 multiply per output value; the
 * decode is two passes over the grid with 1 KB of stack. The sums are taken four
 * output channels at a time (each input byte loaded once for four), a 3x3 layer of
 * dilation 1 reads each kernel row as one run of 3 cin bytes, and on x86 (unless
 * built with -DVT_NO_SIMD) eight int16-widened products per pmaddwd (SSE2); where
 * the CPU has AVX2 (asked at run time, once a vt_cnn_forward; -DVT_NO_AVX2 to leave
 * it out) two neighbouring output pixels in one pass with sixteen per vpmaddwd. With
 * AVX-VNNI (-DVT_NO_AVXVNNI) or AVX-512 VNNI (-DVT_NO_AVX512) a layer whose cin is a
 * multiple of 4 (with AVX-512 also the first layer's 3x3 of dilation 1 on one
 * channel) holds output channels in the lanes: one vpdpbusd adds 4 input channels'
 * products for 8 (256 bits) or 16 (512 bits) output channels, a tile of 6 or 8 pixels
 * of a row shares each weight vector, the weights of a pass are repacked on the stack
 * (18,432 or 36,864 bytes, x86 only) and a pixel's sums need no horizontal add. The
 * order of integer sums does not change them, so every build gives the same bits. Work buffer
 * (vt_cnn_work_bytes): the largest even-indexed plus the largest odd-indexed
 * layer output (the last layer writes the caller's out). */
#ifndef VEHTRACK_CNN_H
#define VEHTRACK_CNN_H

#include <stddef.h>
#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/status.h"
#include "vehtrack/windows.h" /* VT_MAX_NMS_BOXES: the frame-level merge is vt_nms */

#define VT_CNN_MAX_LAYERS 8
/* Channels of a layer: a check only (no buffer is sized by it; the caller's work
 * buffer follows the model). 64 until 2026-11-29; 128 keeps the accumulator bound
 * above inside int32 with room to spare, and the work sizes inside a 32-bit size_t:
 * a layer's output is at most w h 128 <= 2^29 bytes (w h <= 2^22, config.h, the
 * upsampled band included), the two ping-pong regions <= 2^30. */
#define VT_CNN_MAX_CH 128
/* Channels of the last layer: heat, left, top, right, bottom. */
#define VT_CNN_OUT_CH 5
/* Largest |bias| (accumulator units): keeps acc inside int32 (above). */
#define VT_CNN_BIAS_MAX 1073741824
/* Largest heat_scale_q16 (256.0 per heat step): 128 x 2^24 = 2^31, so a heat times
 * the scale (the pipeline's Q16 score) stays inside int32. */
#define VT_CNN_HEAT_SCALE_MAX 16777216
/* Frame-level detection (vt_cnn_detect_frame): the deepest pyramid level, the most
 * levels one call runs, and the most peaks decoded per level (cap_per_level). */
#define VT_CNN_MAX_LEVEL 5
#define VT_CNN_MAX_RUN_LEVELS 5
#define VT_CNN_MAX_PEAKS 256

/* One convolution layer (const: may live in flash). */
typedef struct {
    uint8_t ksize;        /* 1 or 3                                                    */
    uint8_t stride;       /* 1 or 2                                                    */
    uint8_t dilation;     /* 1 or 2 for 3x3; 1 for 1x1                                 */
    uint8_t relu;         /* 1: uint8 out = clamp(q, 0, 255) (every layer but the
                             last); 0: only the last layer, int8 out = clamp(q, -128, 127) */
    uint16_t cin;         /* 1 .. VT_CNN_MAX_CH; layer 0: 1; else the previous cout    */
    uint16_t cout;        /* 1 .. VT_CNN_MAX_CH; the last layer: VT_CNN_OUT_CH         */
    const int8_t *w;      /* [cout][ksize][ksize][cin], symmetric per output channel   */
    const int32_t *bias;  /* [cout], accumulator units, |bias| <= VT_CNN_BIAS_MAX      */
    const int32_t *mult;  /* [cout], 1 .. 2^31 - 1                                     */
    const uint8_t *shift; /* [cout], 1 .. 62                                           */
} vt_cnn_layer;

/* A network: layers 0 .. n_layers - 1, then the box decoder's settings. */
typedef struct {
    uint8_t n_layers;                     /* 1 .. VT_CNN_MAX_LAYERS                      */
    vt_cnn_layer layer[VT_CNN_MAX_LAYERS];
    uint8_t out_stride;                   /* the product of the layers' strides          */
    int8_t heat_thr;                      /* the default peak threshold (heat channel)   */
    int32_t heat_scale_q16;               /* the logit of one heat step, Q16,
                                             1 .. VT_CNN_HEAT_SCALE_MAX: a heat h is the
                                             logit h heat_scale_q16 / 2^16 (the pipeline's
                                             score; |h| <= 128 keeps it in int32)       */
    const uint16_t *side_lut;             /* [4][256]: side distances in level px Q4 for
                                             channels 1..4 (l, t, r, b), index q + 128  */
} vt_cnn_model;

/* A decoded box: inclusive full-frame pixels, score = the peak's heat (-128..127). */
typedef struct {
    int32_t l;
    int32_t t;
    int32_t r;
    int32_t b;
    int32_t score;
} vt_cnn_box;

/* VT_OK if the model is valid: n_layers in range; per layer ksize, stride,
 * dilation (1 for 1x1), cin, cout in range and the pointers non-NULL; cin of
 * layer 0 is 1 and cin of layer i the cout of layer i - 1; relu 1 on every layer
 * but the last, relu 0 on the last, whose cout is VT_CNN_OUT_CH; every bias,
 * mult and shift in range; out_stride the product of the strides; side_lut
 * non-NULL; heat_scale_q16 in 1 .. VT_CNN_HEAT_SCALE_MAX. Else (NULL m included) VT_E_ARG. Cost: one pass over the per-channel
 * arrays (not the weights: every int8 weight is valid). */
vt_status vt_cnn_check_model(const vt_cnn_model *m);

/* *gw, *gh = the last layer's output size for a w x h input (each layer's ceil
 * above). Errors: NULL m, gw or gh, or an invalid model -> VT_E_ARG; w or h
 * outside 1 .. VT_MAX_WIDTH / VT_MAX_HEIGHT -> VT_E_SIZE. */
vt_status vt_cnn_out_size(const vt_cnn_model *m, int32_t w, int32_t h, int32_t *gw, int32_t *gh);

/* *bytes = the work buffer vt_cnn_forward needs for a w x h input: the largest
 * even-indexed layer output plus the largest odd-indexed one, the last layer's
 * excluded (0 for a one-layer model). Errors as vt_cnn_out_size (NULL bytes ->
 * VT_E_ARG). */
vt_status vt_cnn_work_bytes(const vt_cnn_model *m, int32_t w, int32_t h, size_t *bytes);

/* Which inner loops vt_cnn_forward takes in this build on this CPU (the same bits on
 * every path; the speed differs): *path = VT_CNN_SIMD_PORTABLE (non-x86 targets,
 * -DVT_NO_SIMD), VT_CNN_SIMD_SSE2 (x86-64 without AVX2, or -DVT_NO_AVX2),
 * VT_CNN_SIMD_AVX2 (or -DVT_NO_AVXVNNI), VT_CNN_SIMD_AVXVNNI (256 bits; or
 * -DVT_NO_AVX512) or VT_CNN_SIMD_AVX512VNNI; the CPU is asked (cpuid) on every
 * call, as vt_cnn_forward does once a call (vt_cnn_detect_frame once a frame). NULL
 * path -> VT_E_ARG. */
#define VT_CNN_SIMD_PORTABLE 0
#define VT_CNN_SIMD_SSE2 1
#define VT_CNN_SIMD_AVX2 2
#define VT_CNN_SIMD_AVXVNNI 3
#define VT_CNN_SIMD_AVX512VNNI 4
vt_status vt_cnn_simd_path(int32_t *path);

/* The forward pass over a gray image img (w x h, row stride `stride` bytes):
 * out = the last layer's gh x gw x 5 int8 (HWC, vt_cnn_out_size). Layer i < the
 * last writes its uint8 output at work (i even) or at work + the largest even
 * layer output (i odd); nothing is written outside work[0 .. needed) and
 * out[0 .. gh gw 5). work may be NULL only when vt_cnn_work_bytes gives 0.
 * Errors: NULL m, img or out, an invalid model, or a NULL work that is needed ->
 * VT_E_ARG; w, h outside 1 .. VT_MAX_WIDTH / VT_MAX_HEIGHT or stride < w ->
 * VT_E_SIZE; work_bytes or out_len (int8 values) smaller than needed ->
 * VT_E_CAPACITY. Nothing is written on an error. */
vt_status vt_cnn_forward(const vt_cnn_model *m, const uint8_t *img, int32_t w, int32_t h,
                         int32_t stride, uint8_t *work, size_t work_bytes, int8_t *out,
                         size_t out_len);

/* The peaks of a forward output `out` (gh x gw x 5 int8, HWC) as boxes (decode
 * above): any int32 thr (the model's heat_thr is the caller's default; thr > 127
 * finds nothing, thr <= -128 makes every plateau cell a peak), scale_shift 0..5
 * (the input was pyramid level scale_shift, 2^scale_shift times smaller than
 * the frame). The first
 * min(cap, peaks) peaks in the order above go to boxes[0 ..], *n = how many were
 * written, *n_peaks = how many peaks there are (so a truncation is never silent;
 * boxes past *n are not written). Errors: NULL m, out, boxes, n or n_peaks, an
 * invalid model, cap < 1 or scale_shift outside 0..VT_CNN_MAX_LEVEL -> VT_E_ARG; gw, gh outside
 * 1 .. VT_MAX_WIDTH / VT_MAX_HEIGHT -> VT_E_SIZE. On an error *n and *n_peaks are
 * 0 where they are not NULL. Cost: two passes over the grid. */
vt_status vt_cnn_decode(const vt_cnn_model *m, const int8_t *out, int32_t gw, int32_t gh,
                        int32_t thr, int32_t scale_shift, vt_cnn_box *boxes, int32_t cap,
                        int32_t *n, int32_t *n_peaks);

/* Frame-level detection: one network over several Gaussian pyramid levels of a
 * frame (level k = the frame after k vt_pyr_down steps, image.h), the peaks of
 * every level merged by greedy NMS. Settings (const: may live in flash): */
typedef struct {
    int32_t first_level;      /* 0..VT_CNN_MAX_LEVEL - 1: the first level the network
                                 runs on (1 = half size; the levels above are only
                                 pyramid steps)                                        */
    int32_t n_levels;         /* 1..VT_CNN_MAX_RUN_LEVELS, and first_level + n_levels - 1
                                 <= VT_CNN_MAX_LEVEL                                   */
    int32_t thr_offset;       /* any int32: the peak threshold is the model's heat_thr
                                 + thr_offset (in int64, clamped to -128..128, which
                                 finds the same peaks as the exact sum)                */
    int32_t cap_per_level;    /* 1..VT_CNN_MAX_PEAKS: peaks decoded per level, highest
                                 heat first; n_levels cap_per_level <= VT_MAX_NMS_BOXES
                                 ((n_levels + 1) cap_per_level with the upsampled band) */
    int32_t nms_iou_permille; /* 0..1000: vt_nms's IoU limit over all levels' boxes    */
    int32_t nms_contain_permille; /* 0..1000: vt_nms's containment limit               */
    int32_t l0_top_permille;  /* 0 <= l0_top_permille < l0_bottom_permille <= 1000: the
                                 rows of level 0 the network runs on (a band around the
                                 horizon, where small far vehicles stand, at full
                                 resolution), y0 .. y1 - 1 with, exactly in int64,
                                 y0 = floor(h l0_top_permille / 1000),
                                 y1 = ceil(h l0_bottom_permille / 1000) (h = the frame's
                                 height). Never empty: y1 >= h bottom / 1000 > h top / 1000
                                 >= y0, so 1 <= y1 - y0 <= h. Used only when first_level is
                                 0 (checked always); 0 and 1000 = the whole frame        */
    int32_t l0_bottom_permille; /* see l0_top_permille                                 */
    int32_t stretch_tail_permille; /* 0: off. 1..100: the network sees the frame's contrast
                                 stretched (issue 8 item 5: overcast and dusk light). From
                                 the histogram of the whole frame (w x h pixels, n), with
                                 k = floor(n stretch_tail_permille / 1000) in int64:
                                 lo = the least level with more than k pixels <= it,
                                 hi = the greatest level with more than k pixels >= it
                                 (lo <= hi, as 2k < n), span = max(hi - lo,
                                 VT_CNN_STRETCH_MIN_SPAN); each pixel x becomes
                                 0 if x <= lo, else min(255, floor(((x - lo) 510 + span) /
                                 (2 span))) (x - lo scaled by 255 / span, rounded half
                                 up). The pyramid and level 0's band are built from that
                                 frame; the boxes are the same frame's pixels           */
    /* The upsampled band (all four 0: off, the default): the network also runs on a
     * rectangle of the frame (after the stretch) at twice its size, for the far
     * vehicles near the vanishing point that are 7..20 px wide at the frame, below
     * the shipped head's 16 px. When on: 0 <= top < bottom <= 1000 and 0 <= left <
     * right <= 1000; rows y0 .. y1 - 1 as level 0's band (floor(h top / 1000),
     * ceil(h bottom / 1000)), columns x0 .. x1 - 1 alike with w. The 2x image
     * (2 (x1 - x0) x 2 (y1 - y0), which must fit VT_MAX_WIDTH x VT_MAX_HEIGHT, else
     * VT_E_SIZE) has cv2.INTER_LINEAR's pixel centres: output column j samples
     * source column c = x0 + floor(j / 2) with weight 3/4 and its neighbour (c - 1
     * for even j, c + 1 for odd; clamped to the frame, not the band) with 1/4, rows
     * alike, out = floor((sum of weights 9, 3, 3, 1 times the pixels + 8) / 16),
     * exact (OpenCV's 2x INTER_LINEAR_EXACT of the frame, cut to the rectangle: the
     * same bits, tests/test_cnn_upband.py). Its peaks decode at half scale: each Q4 value v becomes
     * floor((v + 16) / 32) (the decode's rule with 2^-1), moved by (x0, y0); they
     * join the levels' boxes after the last level, cap_per_level of them, so
     * (n_levels + 1) cap_per_level <= VT_MAX_NMS_BOXES.                             */
    int32_t up_top_permille;
    int32_t up_bottom_permille;
    int32_t up_left_permille;
    int32_t up_right_permille;
} vt_cnn_cfg;

/* The contrast stretch's least span (levels): a gain of at most 255 / 64 (about 4), so a
 * flat frame's noise is not blown up to the full range. */
#define VT_CNN_STRETCH_MIN_SPAN 64

/* Defaults: levels 1..3 (a vehicle 16..128 px wide at the frame is 8..64 px on one of
 * them, the shipped stride-8 head's range); the model's own threshold; 64 peaks per
 * level (more than a road scene has vehicles, so the cap only bounds the NMS's
 * O(n^2)); NMS at IoU 0.5 and containment 0.8: the same car found on two adjacent
 * levels gives boxes of IoU ~0.7+ (one kept), while two cars side by side or one
 * partly behind another overlap less (vt_nms' other callers, fulldet and ACF, use
 * 0.301 / 0.699 and 0.3 / 1.0 for sliding windows, whose neighbours overlap more);
 * level 0's band the whole frame. A struct filled field by field should start from
 * these (vt_cnn_cfg_default): zeroed band fields (0, 0) are refused, not a default.
 * No contrast stretch: the frame as it comes; no upsampled band. */
#define VT_CNN_CFG_DEFAULT                                                                \
    {                                                                                    \
        .first_level = 1, .n_levels = 3, .thr_offset = 0, .cap_per_level = 64,           \
        .nms_iou_permille = 500, .nms_contain_permille = 800, .l0_top_permille = 0,      \
        .l0_bottom_permille = 1000, .stretch_tail_permille = 0, .up_top_permille = 0,     \
        .up_bottom_permille = 0, .up_left_permille = 0, .up_right_permille = 0,           \
    }

/* Fill *cfg with VT_CNN_CFG_DEFAULT (VT_E_ARG for NULL). */
vt_status vt_cnn_cfg_default(vt_cnn_cfg *cfg);

/* VT_OK if every field of cfg is in its range above; VT_E_ARG otherwise (NULL too). */
vt_status vt_cnn_cfg_check(const vt_cnn_cfg *cfg);

/* The horizon (Q16 share of the frame height) the shipped models' rows were chosen for:
 * the default road camera's, 330 / 720 of the height (pipeline.h's VT_ROAD_CAMERA_DEFAULT,
 * TuSimple's camera). */
#define VT_CNN_REF_HORIZON_Q16 30037

/* *out = cfg with its rows moved to a camera whose horizon lies at horizon_q16 (Q16 share of
 * the height, -65536..65536, as vt_road_camera's): both level 0's band (l0_top/bottom) and,
 * when on, the upsampled band (up_top/bottom) move down by
 *   d = floor(((horizon_q16 - VT_CNN_REF_HORIZON_Q16) 1000 + 32768) / 65536) permille
 * (rounded half up; floor of a negative numerator toward minus infinity), each keeping its
 * height in permille: top' = min(max(top + d, 0), 1000 - (bottom - top)), bottom' = top' +
 * (bottom - top), so a band pushed past an edge of the frame stops there. Why: the bands look
 * closely at the rows where far vehicles are, a few rows about the horizon; their permille
 * were chosen for one camera, and a camera file's horizon says where those rows are on
 * another (the lanes' one-frame vanishing row is not used: on TuSimple the bottoms of
 * vehicles under 32 px wide scatter 17.6 rows about it against 10.3 about a fixed row).
 * Columns, levels and the rest are copied; horizon_q16 = VT_CNN_REF_HORIZON_Q16 gives *out =
 * *cfg. out may be cfg. Errors: NULL cfg or out, an invalid cfg (vt_cnn_cfg_check) or
 * horizon_q16 outside -65536..65536 -> VT_E_ARG, *out not written. */
vt_status vt_cnn_cfg_at_horizon(const vt_cnn_cfg *cfg, int32_t horizon_q16, vt_cnn_cfg *out);

/* *bytes = the work buffer vt_cnn_detect_frame needs for a w x h frame: up to 7 bytes
 * to align what follows for int32; with stretch_tail_permille > 0 the stretched frame
 * (w h bytes); the boxes of every run level (n_levels
 * cap_per_level vt_scored_box) and one level's decode (cap_per_level vt_cnn_box);
 * two ping-pong level images (level 1, then level 2, each built from the one before:
 * odd levels in the first, even levels >= 2 in the second; only as many as the last
 * run level needs; level 0 is the caller's frame); the largest vt_cnn_work_bytes and
 * the largest forward output (gw gh 5 int8) over the run levels, level 0's for its
 * band (w x (y1 - y0), vt_cnn_cfg) when first_level is 0; with the upsampled band on,
 * its 2x image (4 (x1 - x0) (y1 - y0) bytes), cap_per_level more vt_scored_box, and its
 * forward work and output in the largest above (VT_E_SIZE when the 2x image is past
 * VT_MAX_WIDTH x VT_MAX_HEIGHT). Exact, so with a band it is
 * not monotone in h (the band's rounding can give a frame of h rows one band row more
 * than one of h + 1): size a buffer by the query for each frame size it serves. Errors: NULL m, cfg or bytes, an
 * invalid model or cfg -> VT_E_ARG; w, h outside 1 .. VT_MAX_WIDTH / VT_MAX_HEIGHT ->
 * VT_E_SIZE. */
vt_status vt_cnn_frame_work_bytes(const vt_cnn_model *m, const vt_cnn_cfg *cfg, int32_t w,
                                  int32_t h, size_t *bytes);

/* Detection over pyramid levels first_level .. first_level + n_levels - 1 of the gray
 * frame img (w x h, row stride `stride` bytes; contrast-stretched first into the work
 * buffer when cfg's stretch_tail_permille > 0): per level k, vt_cnn_forward on the
 * level image, vt_cnn_decode with thr (cfg's thr_offset above), scale_shift k and cap
 * cap_per_level. Level 0 (when first_level is 0) is only cfg's band: the forward pass
 * on the w x (y1 - y0) image at img + y0 stride (same stride), its decoded boxes moved
 * down y0 rows (t + y0, b + y0; |values| stay far inside int32); the pyramid for the
 * levels >= 1 is built from the whole frame. Each box clipped to the frame (0..w - 1,
 * 0..h - 1; not to the band: a box may reach past the rows its peak came from) and
 * dropped when that leaves it empty (entirely outside, or zero width or height:
 * decode's r = l - 1 for zero sides). With the upsampled band on, the network runs
 * last on its 2x image (vt_cnn_cfg), decoded at half scale with cap_per_level, moved by
 * (x0, y0), clipped alike. Then vt_nms over all levels' boxes (cfg's limits; score = heat),
 * so the output is in NMS order: heat descending, ties by level, then decode order
 * (heat descending, raster), the upsampled band's after every level's. The first min(cap, kept) go to boxes[0 ..] (score = the
 * heat, -128..127), *n = how many were written, *n_peaks = the peaks over all levels
 * before the cap, clipping and NMS (a truncation is never silent). Nothing is written
 * outside work[0 .. vt_cnn_frame_work_bytes) and boxes[0 .. *n). Errors: NULL m, cfg,
 * img, work, boxes, n or n_peaks, an invalid model or cfg, cap < 1 -> VT_E_ARG; w, h
 * outside 1 .. VT_MAX_WIDTH / VT_MAX_HEIGHT or stride < w -> VT_E_SIZE; work_bytes
 * below vt_cnn_frame_work_bytes -> VT_E_CAPACITY. On an error *n and *n_peaks are 0
 * where not NULL and boxes is not written. Cost: the pyramid steps (25 multiply-adds
 * per level pixel), the forward passes (cnn.h's cost per level: the levels after the
 * first add at most a third of the first's whole-level cost; level 0's is its band's
 * share, (y1 - y0) / h, of it; the upsampled band's is a level-0 pass over 4 times its
 * rectangle, plus 4 multiply-adds per 2x pixel to build it), the decodes, and the NMS's O(n^2) over
 * at most n_levels cap_per_level boxes; with the stretch, one histogram and one table
 * lookup per frame pixel; stack: vt_pyr_down's row (image.h), vt_cnn_decode's 1 KB or
 * the stretch's 1.25 KB (histogram and table). */
vt_status vt_cnn_detect_frame(const vt_cnn_model *m, const vt_cnn_cfg *cfg, const uint8_t *img,
                              int32_t w, int32_t h, int32_t stride, uint8_t *work,
                              size_t work_bytes, vt_cnn_box *boxes, int32_t cap, int32_t *n,
                              int32_t *n_peaks);

#endif /* VEHTRACK_CNN_H */
