/* vehtrack/hood.h -- the ego car's hood found in the frame (issue 8, item 4: "hood
 * rows excluded" when no camera file says where the hood begins). The thesis's
 * shadow scan (sec. 2.4.2.1) looks for dark above bright; the hood's edge against
 * the road is often that very pattern, and the ego-lane detector then boxes road
 * and trees above it (Udacity test4). A hood's edge differs from a vehicle's
 * underside in one way a single frame shows: it is one continuous, nearly level
 * curve across most of the frame's width; a vehicle's shadow spans the vehicle.
 *
 * Rule (twin: pyvehtrack/reference/hood.py, equal result for result):
 *   band      rows y0 = max(1, floor(h * band_top_permille / 1000)) .. y1 = h - 2
 *   columns   x = col_step / 2 (>= 1), + col_step, ... while x + 1 < w
 *   strength  d(y, x) = |s(y + 1, x) - s(y - 1, x)|, s(y, x) = I(y, x-1) + I(y, x) +
 *             I(y, x+1): three times a vertical gray step, 0..765, either polarity
 *             (a hood may be brighter or darker than the road)
 *   strong    d >= 3 grad_min
 *   gain      min(d, 12 grad_min): one lane line's bright step does not pull the path
 *   path      dynamic programme left to right: each sampled column's row may differ
 *             from the previous column's by at most max_jump rows; the path of the
 *             largest gain sum wins. Ties: the predecessor of the lowest row (the
 *             first of r - max_jump .. r + max_jump, clamped to the band, that is
 *             strictly better), the end row the lowest index (highest row).
 *   found     n_strong (the path's strong columns) > 0 and
 *             1000 n_strong >= cover_permille n_cols
 *   row       the highest (smallest) row of the path's strong columns
 * All integer: gain sums <= 765 * 2048 < 2^31, counts and rows fit int16.
 *
 * Defaults (band 880, step 8, grad_min 24 (an 8-level step summed over 3 columns),
 * jump 2, cover 750): the smallest cover that finds a hood on at most one of the 405
 * tusimple TRAIN frames (their hood is a small bump in the bottom centre; a crosswalk's
 * stop line is the false case the cover bounds), while Udacity straight_lines1/2 (the
 * camera file's frames) keep theirs and none of the 78 KITTI frames gets one. A count
 * of found hoods, not a detection figure: README "The hood found in the frame".
 *
 * Cost: one pass over band rows x sampled columns, 2 max_jump + 1 compares and six
 * pixel reads per cell (1.77 M instructions at 1280x720 with the defaults, callgrind). Memory: vt_hood_state,
 * 16 bytes per row of VT_MAX_HEIGHT (17 KB at the default capacity); no frame buffer. */
#ifndef VEHTRACK_HOOD_H
#define VEHTRACK_HOOD_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/image.h"
#include "vehtrack/status.h"

typedef struct {
    int32_t band_top_permille; /* first searched row, permille of h, 500..999          */
    int32_t col_step;          /* every col_step-th column, 2..64                       */
    int32_t grad_min;          /* strong: |s(y+1) - s(y-1)| >= 3 x this, 1..255          */
    int32_t max_jump;          /* rows the path moves between sampled columns, 0..16    */
    int32_t cover_permille;    /* strong share of the path's columns for a hood, 1..1000 */
} vt_hood_cfg;

#define VT_HOOD_CFG_DEFAULT                                                        \
    {                                                                              \
        .band_top_permille = 880, .col_step = 8, .grad_min = 24, .max_jump = 2,    \
        .cover_permille = 750                                                      \
    }

/* The dynamic programme's two columns (previous, current); caller-owned, no content
 * carries over between calls. */
typedef struct {
    int32_t score[2][VT_MAX_HEIGHT];
    int16_t count[2][VT_MAX_HEIGHT];
    int16_t top[2][VT_MAX_HEIGHT];
} vt_hood_state;

typedef struct {
    int32_t found;    /* 1: a hood, its top at `row`                                 */
    int32_t row;      /* the hood's highest row, or -1                                */
    int32_t n_cols;   /* sampled columns (0 if the band or the columns are empty)    */
    int32_t n_strong; /* strong columns on the best path                              */
    int32_t path_end; /* the best path's row in the last column, or -1               */
} vt_hood_result;

/* Fill *cfg with VT_HOOD_CFG_DEFAULT. */
vt_status vt_hood_cfg_default(vt_hood_cfg *cfg);

/* VT_OK if every field is in its domain, else VT_E_ARG (VT_E_ARG for NULL). */
vt_status vt_hood_cfg_check(const vt_hood_cfg *cfg);

/* The hood in `img` (rule above). A frame too small for a band or a sampled column
 * (h < 3, w < 3) gives found = 0, row = -1 and VT_OK. On any error *res (if not
 * NULL) is found = 0, row = -1, the counts 0, path_end -1. */
vt_status vt_hood_find(vt_hood_state *st, const vt_hood_cfg *cfg, const vt_image_u8 *img,
                       vt_hood_result *res);

#endif /* VEHTRACK_HOOD_H */
