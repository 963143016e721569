/* vehtrack/edge_track.h -- the GIST paper's tracking measurement (sec. III.B):
 * the continuous edge curves of a tracked vehicle, found Canny-style (Sobel
 * gradient, non-maximum suppression in 4 directions, hysteresis with two
 * thresholds) in fixed memory, are matched to the next frame's curves; the
 * displacement that matches best is the Kalman filter's measurement.
 *
 * Matching is a search over integer displacements scoring the truncated chamfer
 * distance: the new frame's curves get a two-pass 3-4 chamfer distance transform
 * (3 per axial step, 4 per diagonal step, i.e. 3 * max(|dx|,|dy|) + min(|dx|,|dy|)
 * to the nearest curve pixel), and each template point at its displaced position
 * reads it. Everything is exact integer arithmetic.
 *
 * Cost: vt_edge_ws holds 5 bytes per pixel of the largest crop,
 * VT_EDGE_MAX_PIXELS, plus 24 (327,704 bytes at 65536); vt_edge_template holds
 * 4 * VT_EDGE_MAX_POINTS + 20 bytes (1,044 at 256). Work: two Sobel responses,
 * a few compares and the two chamfer passes per crop pixel; the match reads
 * (2 scale_steps + 1) (2 radius + 1)^2 n distances (370 k for 256 points at the
 * defaults). Stack: vt_edge_match keeps the scaled points, 4 * VT_EDGE_MAX_POINTS
 * bytes; the flood fills use the workspace, not the stack. */
#ifndef VEHTRACK_EDGE_TRACK_H
#define VEHTRACK_EDGE_TRACK_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/geometry.h" /* vt_box */
#include "vehtrack/image.h"
#include "vehtrack/status.h"

typedef struct {
    /* Hysteresis thresholds on the L1 magnitude |gx| + |gy| of the Sobel
     * responses (each Sobel has a gain of 4, so a 12-level vertical step gives
     * 48): a non-maximum-suppressed pixel >= high is an edge seed, one >= low an
     * edge when 8-connected to a seed through such pixels. 1 <= low <= high. */
    int32_t low;
    int32_t high;
    /* Curves (8-connected components of the edge pixels) with fewer pixels are
     * dropped: the paper keeps continuous curves, not speckle. >= 1. */
    int32_t min_len;
    /* Displacements searched: the prediction +- radius px in x and y. 0..64. */
    int32_t radius;
    /* A template point's chamfer distance is capped here (3-4 units, 3 = one
     * pixel), and a point displaced outside the crop scores it: one occluded or
     * missing curve cannot outweigh the rest. 1..1000. */
    int32_t trunc;
    /* A match is accepted when its mean capped distance per point is at most
     * max_mean_q8 / 256 units (score * 256 <= max_mean_q8 * n). 0..256000. */
    int32_t max_mean_q8;
    /* A template with fewer points is not matched (too little structure). 1..VT_EDGE_MAX_POINTS. */
    int32_t min_points;
    /* Scale search: besides the template as it is, scales 1 +- k * scale_step_q8 / 256
     * for k = 1..scale_steps about the template box's bottom centre (an approaching
     * vehicle grows about its contact with the road). scale_steps 0..8 (0: translation
     * only, the paper's measurement), scale_step_q8 1..64. */
    int32_t scale_steps;
    int32_t scale_step_q8;
} vt_edge_cfg;

/* Defaults, set by reasoning before any evaluation: thresholds of a clear vehicle
 * contour (a 10 / 25-level step), curves of at least 10 pixels, +-8 px of search,
 * distances capped at 5 px, a mean of at most 2 px (1536), at least 16 points,
 * scales 1 +- 1.6 % and +- 3.1 % (a vehicle closing 3 % of its distance per
 * frame). A stricter mean of 1 px (768) halved the false positives on the
 * synthetic set of seed 1 but changed nothing on seed 0 and lost the KITTI lead
 * car (real edges are not that clean), so the a-priori value stays. */
#define VT_EDGE_CFG_DEFAULT  \
    {                        \
        .low = 40,           \
        .high = 100,         \
        .min_len = 10,       \
        .radius = 8,         \
        .trunc = 15,         \
        .max_mean_q8 = 1536, \
        .min_points = 16,    \
        .scale_steps = 2,    \
        .scale_step_q8 = 4,  \
    }

/* Workspace of one crop. After vt_edge_map: lab[y * w + x] is 1 on a curve
 * pixel, else 0, and dt[y * w + x] its 3-4 chamfer distance to the nearest
 * curve pixel of the crop (65535 when the crop has none); (x0, y0) is the crop's
 * top-left in the frame. The union reuses the gradient planes for the
 * hysteresis/curve queue and then for the distances (all exact, see .c). */
struct vt_edge_grad {
    int16_t mag[VT_EDGE_MAX_PIXELS];
    int16_t dir[VT_EDGE_MAX_PIXELS];
};
union vt_edge_planes {
    struct vt_edge_grad g;
    int32_t queue[VT_EDGE_MAX_PIXELS];
    uint16_t dt[VT_EDGE_MAX_PIXELS];
};
typedef struct {
    int32_t x0, y0, w, h;
    int32_t n_curve;  /* curve pixels kept */
    int32_t n_curves; /* curves kept */
    union vt_edge_planes u;
    uint8_t lab[VT_EDGE_MAX_PIXELS];
} vt_edge_ws;

/* A vehicle's curve points at its last good frame, frame coordinates. */
typedef struct {
    int32_t n;  /* points used, 0..VT_EDGE_MAX_POINTS */
    vt_box box; /* the box they were taken from */
    int16_t x[VT_EDGE_MAX_POINTS];
    int16_t y[VT_EDGE_MAX_POINTS];
} vt_edge_template;

/* Fill *cfg with VT_EDGE_CFG_DEFAULT. VT_E_ARG for NULL. */
vt_status vt_edge_cfg_default(vt_edge_cfg *cfg);

/* VT_OK if every field is in its stated range, else VT_E_ARG (NULL too). */
vt_status vt_edge_cfg_check(const vt_edge_cfg *cfg);

/* Edge curves and their distance transform in the crop `roi` of `img` (clipped
 * to the image; the crop is filtered as an image of its own: Sobel with the
 * crop's border pixel replicated, as vt_sobel_x/y on the crop view).
 * 1. gx, gy: vt_sobel_x / vt_sobel_y; m = |gx| + |gy| (<= 2040, exact).
 * 2. direction of (gx, gy) in 4 sectors of 45 degrees, exactly: with ax = |gx|,
 *    ay = |gy|, along x if ay / ax < tan 22.5 deg = sqrt(2) - 1, tested as
 *    (ax + ay)^2 <= 2 ax^2 (no integer pair but 0, 0 lies on the boundary), along
 *    y if (ax + ay)^2 <= 2 ay^2, else the diagonal of sign(gx gy).
 * 3. non-maximum suppression along that direction: kept if m >= low, m > m(p - u)
 *    and m >= m(p + u) (u the unit step along the gradient; neighbours outside
 *    the crop count 0; the asymmetric tie keeps one pixel of a plateau).
 * 4. hysteresis: kept pixels >= high seed a breadth-first flood through kept
 *    pixels >= low (8-connected). The queue has a slot per crop pixel and each
 *    pixel enters once, so it cannot overflow: the result is exact.
 * 5. curves: 8-connected components of the edges with >= min_len pixels.
 * 6. two-pass 3-4 chamfer distance transform of the curve pixels (uint16,
 *    saturating at 65535; the largest finite value, 3 * 4096 + 4096 = 16384, is below it).
 * VT_E_CAPACITY if the clipped crop has more than VT_EDGE_MAX_PIXELS pixels
 * (nothing is computed: the caller must use a smaller crop), VT_E_SIZE if it is
 * empty (roi outside the image), VT_E_ARG for NULLs, a bad cfg or roi with
 * left > right / top > bottom or a coordinate beyond +-4 VT_MAX_WIDTH/HEIGHT. */
vt_status vt_edge_map(vt_edge_ws *ws, const vt_edge_cfg *cfg, const vt_image_u8 *img,
                      const vt_box *roi);

/* The curve pixels of ws (after vt_edge_map) inside `box` (clipped to the crop)
 * become the template, box copied. More than VT_EDGE_MAX_POINTS pixels: every
 * one of K pixels in raster order is numbered and points floor(i K / cap),
 * i = 0..cap-1, are kept (an even thinning, defined, never an overflow).
 * *n_out (may be NULL) gets the number kept. VT_E_ARG for NULLs or a bad box,
 * VT_E_SIZE if ws holds no crop. */
vt_status vt_edge_template_set(const vt_edge_ws *ws, const vt_box *box, vt_edge_template *tpl,
                               int32_t *n_out);

/* Best scale and displacement of `tpl` over the crop of ws (after vt_edge_map).
 * Scales s = 256 + k * scale_step_q8 (Q8), k in the order 0, -1, +1, ..., -scale_steps,
 * +scale_steps; a point (x, y) scales about the anchor ax = floor((box.left +
 * box.right) / 2), ay = box.bottom to (ax + r(x - ax), ay + r(y - ay)) with
 * r(v) = floor((v s + 128) / 256) (nearest, halves up; exact in int32). For each
 * scale every (dx, dy) with |dx - cx| <= radius and |dy - cy| <= radius, scanned
 * dy then dx ascending, scores S = sum over points of min(dt(x' + dx, y' + dy),
 * trunc), trunc for a point outside the crop; the first smallest S wins (so the
 * unscaled template wins ties). *dx, *dy, *scale_q8, *score (S, <= 1000 *
 * VT_EDGE_MAX_POINTS, exact) are written; *found = 1 if tpl->n >= min_points and
 * S * 256 <= max_mean_q8 * n, else 0 (outputs written when n >= 1; with n == 0
 * only *found = 0). The measured box is tpl->box scaled the same way about the
 * same anchor, then moved by (dx, dy). VT_E_ARG for NULLs, a bad cfg, |cx|,
 * |cy| > 8192 or a template with n outside 0..VT_EDGE_MAX_POINTS or a bad box;
 * VT_E_SIZE if ws holds no crop. */
vt_status vt_edge_match(const vt_edge_ws *ws, const vt_edge_cfg *cfg, const vt_edge_template *tpl,
                        int32_t cx, int32_t cy, int32_t *dx, int32_t *dy, int32_t *scale_q8,
                        int32_t *score, int32_t *found);

/* r(v) of vt_edge_match: a coordinate offset v (|v| <= 2^20) scaled by s (Q8). */
vt_status vt_edge_scale(int32_t v, int32_t s_q8, int32_t *out);

#endif /* VEHTRACK_EDGE_TRACK_H */
