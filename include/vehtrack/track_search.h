/* vehtrack/track_search.h -- the tracker's measurement: find a tracked vehicle's
 * bottom edge and sides inside its predicted region of interest (thesis sec. 3.6.1).
 *
 * Cost: no state of its own; the caller's vt_track_search_ws holds two projection
 * vectors (4 * (VT_MAX_WIDTH + VT_MAX_HEIGHT) bytes). Work: two 3x3 Sobel
 * responses per ROI pixel and two passes over the projections; no frame buffer. */
#ifndef VEHTRACK_TRACK_SEARCH_H
#define VEHTRACK_TRACK_SEARCH_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/geometry.h" /* vt_box: the detector's boxes, which the tracker takes in */
#include "vehtrack/image.h"
#include "vehtrack/status.h"

/* Which border of the shadow is the bottom edge (as vt_shadow_cfg.polarity, so
 * the tracker measures the edge the detector found). */
#define VT_EDGE_DARK_ABOVE 0 /* shadow above the lit road: sobel_y >= h_thresh */
#define VT_EDGE_DARK_BELOW 1 /* body above its shadow: -sobel_y >= h_thresh */

typedef struct {
    int32_t polarity; /* VT_EDGE_DARK_ABOVE (default) or VT_EDGE_DARK_BELOW */
    /* A horizontal (shadow) edge pixel has s * Sobel d/dy >= h_thresh, s = +1 for
     * DARK_ABOVE, -1 for DARK_BELOW. Sobel has a gain of 4 (a 12-level step: 48). */
    int32_t h_thresh;
    /* A vertical edge pixel has |Sobel d/dx| >= v_thresh. */
    int32_t v_thresh;
    /* The bottom edge needs at least this many edge pixels in its row, in
     * permille of the ROI width (so a blank ROI is "not found"). 0..1000. */
    int32_t min_h_permille;
    /* A side needs at least this many edge pixels in its column, in permille of
     * the searched height. 0..1000. */
    int32_t min_v_permille;
    /* The bottom edge is the lowest row (between the ROI's bottom and middle)
     * whose count reaches this permille of the largest count there: 1000 is the
     * thesis's "largest projection value"; lower values prefer the shadow's
     * border, which is weaker than a bumper edge above it. 1..1000. */
    int32_t bottom_permille;
    /* VT_SIDES_TWO_THRESHOLD: the thesis's tracking rule (half the largest value,
     * then the largest when the side jumps more than ever before);
     * VT_SIDES_LARGEST: the verification step's rule (the largest value). */
    int32_t side_mode;
} vt_track_search_cfg;

#define VT_SIDES_TWO_THRESHOLD 0
#define VT_SIDES_LARGEST 1

/* Defaults: 60 as vt_verify_cfg's vertical-edge threshold; a weak 16 (a
 * 4-level step) for the shadow border, the lowest row at half the largest count,
 * and the verification step's side rule. These three were chosen on the 78 KITTI
 * frames of tools/eval_kitti_track.py (the thesis's rules, bottom_permille 1000 and
 * VT_SIDES_TWO_THRESHOLD, are one field away; the README gives both figures). */
#define VT_TRACK_SEARCH_CFG_DEFAULT     \
    {                                   \
        .polarity = VT_EDGE_DARK_ABOVE, \
        .h_thresh = 16,                 \
        .v_thresh = 60,                 \
        .min_h_permille = 200,          \
        .min_v_permille = 200,          \
        .bottom_permille = 500,         \
        .side_mode = VT_SIDES_LARGEST,  \
    }

/* Projection vectors; caller-owned so the search allocates nothing. */
typedef struct {
    int32_t hproj[VT_MAX_HEIGHT];
    int32_t vproj[VT_MAX_WIDTH];
} vt_track_search_ws;

/* Per-track memory of the two-threshold side rule. */
typedef struct {
    int32_t have_prev;       /* 0 until the first accepted measurement */
    int32_t prev_left;
    int32_t prev_right;
    int32_t max_change_left; /* largest accepted side move so far, px */
    int32_t max_change_right;
} vt_track_sides;

/* Search `roi` (clipped to the image) of `img`:
 * 1. horizontal-edge projection per row (count of shadow-edge pixels); searched
 *    from the bottom row up to the middle row, the first row reaching
 *    bottom_permille of the largest value there is the bottom edge;
 * 2. vertical-edge projection per column over rows roi.top..bottom edge; the left
 *    half is searched from the left, the right half from the right: with
 *    VT_SIDES_LARGEST for the largest value, with VT_SIDES_TWO_THRESHOLD for the
 *    first column >= half of that half's largest value, and if the side then
 *    moved more than the largest move accepted so far (`sides`), for the largest
 *    value itself (the thesis's two thresholds). `sides` is updated.
 * *found is 1 and *meas the box (its top copied from roi) when all three edges
 * were found, else 0 (and *meas untouched). Exact integer arithmetic throughout.
 * `sides` may be NULL (no history: first threshold only). */
/* VT_OK if every field of *cfg is in its domain (polarity and side_mode one of
 * their constants, thresholds >= 1, min_h/min_v_permille 0..1000, bottom_permille 1..1000);
 * VT_E_ARG otherwise and for NULL. vt_track_search checks the same. */
vt_status vt_track_search_cfg_check(const vt_track_search_cfg *cfg);

vt_status vt_track_search(vt_track_search_ws *ws, vt_track_sides *sides,
                          const vt_track_search_cfg *cfg, const vt_image_u8 *img,
                          const vt_box *roi, vt_box *meas, int32_t *found);

#endif /* VEHTRACK_TRACK_SEARCH_H */
