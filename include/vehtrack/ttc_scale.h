/* vehtrack/ttc_scale.h -- monocular time to collision from the scale change measured
 * by many SAD-matched blocks inside a track's box (IVVI paper sec. 4's "TTC from the
 * box's scale change", measured the robust way of the Udacity SFND camera-TTC project:
 * the median of pairwise distance ratios of matched points, not the box edges, whose
 * +-1 px jitter on a ~100 px box is as large as a 1 % per-frame scale change).
 *
 * Per track, every frame:
 *   1. blocks of `block` x `block` px on a grid x grid lattice over the box's inner
 *      part (margin_permille cut from each side), kept if they have texture in both
 *      directions, are stored with their positions in a ring of the last frames;
 *   2. the blocks stored `lag` frames ago are searched in this frame by exact integer
 *      SAD over +-radius px around where the box's own shift and size change put them
 *      (or, when the box's size jumped away from it, the track's last measured scale:
 *      prior_gate_permille); a best match on the window's edge or with SAD > max_sad
 *      per pixel is dropped; the integer match is refined to 1/256 px by a parabola
 *      through the SADs of its neighbours in x and in y; fewer than min_match_permille
 *      of the blocks matched: no scale (misplaced windows);
 *   3. s = the (lower) median, over all pairs of matched blocks at least min_pair_px
 *      apart lag frames ago, of (distance now / distance then);
 *   4. TTC = lag frame_dt / (s - 1); with no scale over `lag` frames (a young track,
 *      lost blocks) steps 2-4 run again over lag - 1 .. min_lag frames.
 * Only VT_TTC_TRACKS tracks are measured: the nearest (largest box bottom), each keeping
 * its slot until a track nearer by more than evict_margin_px rows needs it.
 * pyvehtrack/reference/ttc_scale.py is the float twin (same integer search and ties).
 *
 * Number formats: positions Q8 px (int32), squared ratios and s Q16 (vt_q16), TTC
 * and frame_dt Q16 s.
 * Memory: sizeof(vt_ttc_state) = VT_TTC_TRACKS slots of VT_TTC_HIST entries of
 * VT_TTC_GRID^2 blocks of VT_TTC_BLOCK^2 bytes (+ positions), plus a pair scratch of
 * VT_TTC_GRID^2 (VT_TTC_GRID^2 - 1) / 2 int32: 113,064 bytes on x86-64 at the defaults
 * (grid 8, block 8, 6 frames, 4 tracks). Work per track and frame: up to grid^2 searches
 * of (2 radius + 1)^2 SADs of block^2 pixels (at most 64 x 169 x 64 = 692k absolute
 * differences; a SAD stops once it reaches the best so far, which keeps the search
 * exact), VT_TTC_ANCHORS searches over +-anchor_radius, the texture test of grid^2
 * blocks and two O(pairs) median selections (the scale, and the prior on integer
 * positions): 4.2 M instructions (gcc -O2; 3.0 M without anchors and prior) for the
 * KITTI clip's lead car, 38 blocks (make ttc-cost); a fallback lag repeats the search. */
#ifndef VEHTRACK_TTC_SCALE_H
#define VEHTRACK_TTC_SCALE_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/fixed.h"
#include "vehtrack/image.h"
#include "vehtrack/status.h"
#include "vehtrack/tracker.h"

/* Capacities (override with -D). */
#ifndef VT_TTC_TRACKS
#define VT_TTC_TRACKS 4 /* tracks measured at once (the lead and its neighbours) */
#endif
#ifndef VT_TTC_GRID
#define VT_TTC_GRID 8   /* largest grid side                                      */
#endif
#ifndef VT_TTC_BLOCK
#define VT_TTC_BLOCK 8  /* largest block side, px                                 */
#endif
#ifndef VT_TTC_HIST
#define VT_TTC_HIST 6   /* frames kept per track; lag <= VT_TTC_HIST - 1          */
#endif
#if VT_TTC_TRACKS < 1 || VT_TTC_GRID < 2 || VT_TTC_GRID > 16 || VT_TTC_BLOCK < 4 || \
    VT_TTC_BLOCK > 16 || VT_TTC_HIST < 2 || VT_TTC_HIST > 64
#error "VT_TTC_* capacities out of range"
#endif
#define VT_TTC_MAX_BLOCKS (VT_TTC_GRID * VT_TTC_GRID)
#define VT_TTC_ANCHORS 4 /* blocks k n / 4 (k = 0..3) of the n stored are the anchors */
#define VT_TTC_MAX_PAIRS (VT_TTC_MAX_BLOCKS * (VT_TTC_MAX_BLOCKS - 1) / 2)

typedef struct vt_ttc_cfg {
    int32_t block;       /* block side, px, 4..VT_TTC_BLOCK                           */
    int32_t grid;        /* grid x grid blocks, 2..VT_TTC_GRID                        */
    int32_t margin_permille; /* cut from each side of the box, 1/1000, 0..400         */
    int32_t radius;      /* search +-radius px, 1..16                                 */
    int32_t min_texture; /* mean |step| across and along a block, grey levels, 0..255 */
    int32_t max_sad;     /* mean |difference| of a match, grey levels, 1..255          */
    int32_t lag;         /* frames between the two views, 1..VT_TTC_HIST-1            */
    int32_t min_pair_px; /* pairs closer than this then are not used, 1..4096         */
    int32_t min_pairs;   /* fewer usable pairs: no scale, 1..VT_TTC_MAX_PAIRS         */
    vt_q16 frame_dt;     /* s per frame, (0, 1]                                        */
    vt_q16 ttc_max;      /* s; larger (or s <= 1) is "no TTC", (0, 1000]               */
    int32_t anchor_radius; /* 0, or radius+1..48: first search VT_TTC_ANCHORS blocks over
                            +-anchor_radius px; the (lower) median of their integer
                            offsets moves every block's window (the tracker's box jumps
                            on detection frames by more than radius)                  */
    int32_t evict_margin_px; /* -1: a slot stays with its track while the track lives (the
                            first VT_TTC_TRACKS tracks in input order own them); 0..4096:
                            slots go to the nearest tracks (lowest box bottom row, ties in
                            input order), and a track without a slot takes the slot of the
                            farthest owner when its bottom is more than this many rows
                            lower (hysteresis, so ownership is stable under box jitter) */
    int32_t prior_gate_permille; /* -1: blocks are always predicted with the box's size
                            change; 0..1000: with the track's coarse scale of its last
                            measurement (its prior) instead, when the box's size ratio
                            over the lag differs from that prior by more than this many
                            thousandths of it (the box's size jumps on a detection re-fit,
                            or stops growing when cut by the frame's edge; the blocks' own
                            scale over the same lag does not)                          */
    int32_t min_lag;     /* 1..VT_TTC_HIST-1: a track with fewer than lag frames, or
                            whose blocks give no scale over lag frames, is measured over
                            the longest lag down to min_lag that does (min_lag >= lag:
                            no fallback)                                               */
    int32_t min_match_permille; /* 0..1000: fewer matched blocks than this many thousandths
                            of those searched: no scale (the windows were misplaced; what
                            matched in them is not trusted), and the fallback lags try */
} vt_ttc_cfg;

/* block 8, grid 8, margin 10 %, radius 6, texture 2, SAD 24, lag 5, pairs >= 16 px,
 * >= 10 pairs, 0.1 s, 20 s, anchors over +-12 px: grid, texture, lag and the anchor
 * radius chosen on KITTI frames 0-38 only (tools/eval_kitti_range.py reports frames
 * 39-77). The anchors keep the blocks after the tracker's box jumps on a detection
 * frame (frames 15-18 of KITTI lost 85-95 % of their pairs without them).
 * Eviction margin 8 rows: more than the box bottom's frame-to-frame jitter (1-2 rows)
 * and its largest detection re-fit step on KITTI frames 0-38 (5 rows). Prior gate 10 %:
 * twice the largest difference between the box's size ratio over 5 frames and the
 * blocks' scale on KITTI frames 0-38 (5 %), so the prior steps in only where the box
 * jumped (using it on every frame changed 22 of frames 0-38 and scored worse there).
 * min_lag 2: on frames 0-38 the single-lag scales score 31.9 % (lag 1), 21.8 % (2),
 * 17.5 % (3), 21.6 % (4), 18.7 % (5) against the lidar TTC; lags 2-4 as fallback give
 * the first frames of a track a TTC (34 -> 37 of the 37 lidar-TTC frames, median
 * unchanged), lag 1 is too noisy to use. Matched share >= 50 %: a majority; the lowest
 * share on frames 0-38 is 76 % (29 of 38 blocks), so it changes nothing there, while a
 * box that jumped 20 % keeps about a third, whose scale is wrong (0.84 for a true 1.02:
 * tests/test_ttc_slots_prior.py). */
#define VT_TTC_CFG_DEFAULT                                                             \
    {                                                                                  \
        .block = 8, .grid = 8, .margin_permille = 100, .radius = 6, .min_texture = 2, \
        .max_sad = 24, .lag = 5, .min_pair_px = 16, .min_pairs = 10, .frame_dt = 6554, \
        .ttc_max = 20 * VT_Q16_ONE, .anchor_radius = 12, .evict_margin_px = 8,         \
        .prior_gate_permille = 100, .min_lag = 2, .min_match_permille = 500,           \
    }

vt_status vt_ttc_cfg_default(vt_ttc_cfg *cfg);
/* VT_OK if every field is in its range above, else VT_E_ARG. */
vt_status vt_ttc_cfg_check(const vt_ttc_cfg *cfg);

/* One stored frame of a track (private; public for its size). */
typedef struct vt_ttc_entry {
    vt_box box;
    int32_t n;                                   /* blocks stored                     */
    int16_t x[VT_TTC_MAX_BLOCKS];                /* top-left corners, px              */
    int16_t y[VT_TTC_MAX_BLOCKS];
    uint8_t px[VT_TTC_MAX_BLOCKS][VT_TTC_BLOCK * VT_TTC_BLOCK];
} vt_ttc_entry;

typedef struct vt_ttc_track {
    int32_t id;                                  /* 0 = free                           */
    int32_t n_hist;                              /* entries held (<= VT_TTC_HIST)      */
    int32_t head;                                /* next entry index                   */
    vt_q16 prior;                                /* coarse scale of the last measurement
                                                    (integer match positions), Q16; 0 =
                                                    none (see vt_ttc_step)             */
    vt_ttc_entry e[VT_TTC_HIST];
} vt_ttc_track;

typedef struct vt_ttc_state {
    int32_t img_w, img_h;                        /* frame size (0: none yet)           */
    vt_ttc_track t[VT_TTC_TRACKS];
    int32_t pair[VT_TTC_MAX_PAIRS];              /* scratch: squared ratios, Q16       */
} vt_ttc_state;

#define VT_TTC_SCALE_VALID 1 /* at least min_pairs pairs: scale is measured            */
#define VT_TTC_VALID 2       /* 1 < s and TTC <= ttc_max                               */

typedef struct vt_ttc_out {
    int32_t id;
    int32_t flags;       /* VT_TTC_*                                                   */
    int32_t blocks;      /* blocks searched (stored lag frames ago)                    */
    int32_t matched;     /* of them matched                                            */
    int32_t pairs;       /* pairs in the median                                        */
    vt_q16 scale;        /* s, Q16 (0 unless SCALE_VALID)                               */
    vt_q16 ttc;          /* s, Q16 (0 unless VALID)                                     */
    int32_t lag;         /* frames the scale spans (cfg lag, or a shorter fallback; 0
                            when nothing was measured)                                 */
} vt_ttc_out;

/* Empty the stage. VT_E_ARG for NULL. */
vt_status vt_ttc_init(vt_ttc_state *st);

/* One frame (8-bit grey, the frame the boxes are in). Tracks FREE are skipped; slots of
 * ids absent this frame are freed. Slots (cfg->evict_margin_px >= 0): tracks without one
 * are served nearest first (largest box bottom, ties in input order): a free slot, else
 * the slot of the owner with the smallest bottom (ties: the later in input order) if the
 * track's bottom exceeds it by more than evict_margin_px (the owner's history is
 * dropped); with -1, free slots in input order and no eviction. An id with no slot gets
 * no output (and VT_E_CAPACITY at the end). A frame of another size than the last one
 * forgets every track (a documented restart, not an error). Per track: if it holds an
 * entry lag frames old, the blocks are matched (see the file comment; with
 * prior_gate_permille >= 0, a prior, the measurement over cfg->lag, and |sn 2^16 - prior so| 1000 > gate prior so
 * (so, sn: width + height of the box then and now), a block's window is the box
 * centre's shift plus the prior scale about it: x + ((cn - co) 2^16 + (2 x + block - 1 - co) (prior - 2^16)) /
 * 2^17 rounded half away from zero, c = left + right or top + bottom) and
 *   - sub-pixel offset per axis: (S- - S+) 256 / (2 (S- - 2 S0 + S+)) rounded half away
 *     from zero, clamped to +-128 (0 if the denominator is 0): Q8 px;
 *   - squared ratio per pair: (dx^2 + dy^2 now, Q16 px^2) / (dx^2 + dy^2 then, px^2),
 *     rounded half away from zero, saturated at 2^31 - 1 (s = 181);
 *   - s = floor(sqrt(median 2^16)) (Q16; the lower median, element (n - 1) / 2);
 *   - TTC = lag frame_dt 2^16 / (s - 2^16) rounded half away from zero, Q16 s;
 *   - the prior for the next frame: the same median taken over the same pairs with
 *     the integer match positions (exact in C and oracle alike), floor(sqrt(median
 *     2^16)), Q16; 0 (none) when fewer than min_pairs pairs or no entry to measure.
 * Then this frame's blocks are stored. Writes one vt_ttc_out per measured track in input
 * order, up to out_cap; *n_out = their number. VT_E_ARG for NULL, a bad cfg, a bad image
 * (VT_E_SIZE for its size), n_tracks < 0, a box with right < left or bottom < top or a
 * duplicate id (state unchanged). VT_E_CAPACITY when outputs or slots ran out. */
vt_status vt_ttc_step(vt_ttc_state *st, const vt_ttc_cfg *cfg, const vt_image_u8 *img,
                      const vt_track_out *tracks, int32_t n_tracks, vt_ttc_out *out,
                      int32_t out_cap, int32_t *n_out);

#endif /* VEHTRACK_TTC_SCALE_H */
