/* vehtrack/flow.h -- overtaking vehicles by block-matching optical flow in the
 * lateral areas of the image (IVVI paper, sec. 2-3).
 *
 * Per frame: the frame is reduced to pyramid level cfg.level, only where this
 * step or the next reads the level image (vt_pyr_down_rect: each watched area
 * widened by 2 search_x / 2 search_y, each hand-over track's cells widened by the
 * search range + 1; the rectangles are recorded per level image, vt_flow_state.rect);
 * each lateral area (a strip at the left and/or right border, rows
 * top..bottom %) is cut into square cells of cfg.cell px; a cell's motion vector
 * is searched by the sum of absolute differences (SAD) against the previous level
 * image, but only where enough of the cell's pixels changed since the previous
 * frame (the paper's speed-up); cells without horizontal texture are skipped
 * (dx is undefined there); the vectors are filtered by range (magnitude),
 * direction (an overtaking vehicle moves *inward*, against the outward flow of
 * the background it passes), a forward-backward check and blob size
 * (8-connected components of accepted cells, two-pass union-find in a fixed
 * table; 8, not 4: a dark car with little texture gives accepted cells only on
 * its edges and lights, which often touch only at corners); a blob of at
 * least cfg.min_blob_cells cells that overlaps blobs of the previous
 * cfg.min_age - 1 frames becomes an overtaking hypothesis (box, side, mean flow).
 * The texture gate, the backward check and the persistence are not in the
 * paper: they were added because foliage and the flat band under a car gave
 * false overtakes (README: what each bought).
 *
 * Which side overtakes depends on the country (paper sec. 2): with right-hand
 * traffic (continental Europe, where the paper's vehicle drives; the Americas)
 * vehicles overtake on the LEFT, so the default watches the left area; left-hand
 * traffic (UK, Japan, ...) sets VT_FLOW_SIDE_RIGHT. VT_FLOW_SIDE_BOTH watches both.
 *
 * The reverse case (paper sec. 3, last paragraph): when the ego vehicle overtakes
 * another, the tracker hands that vehicle over as it leaves the geometric model's
 * reach; vt_flow_seed() starts a "hand-over" track from its box, which the flow
 * stage then moves every frame by the mean SAD vector of the cells inside it,
 * until it leaves the frame (see vt_flow_seed for how the pipeline calls it).
 *
 * Vector convention: motion (dx, dy) of a cell from the previous frame to the
 * current one, i.e. the cell at (x, y) in the current level image matches the
 * block at (x - dx, y - dy) in the previous one. Exact integer SAD; ties go to
 * (0, 0) first, then the first candidate in the scan order dy = -sy..sy
 * (outer), dx = -sx..sx (inner); candidates whose block leaves the previous
 * level image are skipped.
 *
 * Lifecycle: the first frame after vt_flow_init/vt_flow_reset only stores the
 * level image (result->ready = 0, no hypotheses: a documented no-op); so is a
 * frame whose areas the previous level image was not computed over (cfg.level, or
 * the areas or search range widened between calls). A frame of
 * another size than the previous one gives VT_E_SIZE and leaves the state
 * untouched (the caller decides: vt_flow_reset and start again).
 *
 * Cost: sizeof(vt_flow_state) ~ 3 * VT_FLOW_MAX_PIXELS bytes (previous and
 * current level image, level-1 scratch for level 2) + 22 * VT_FLOW_MAX_CELLS
 * bytes (vectors, SADs, flags, labels): 1,917,440 bytes at the defaults
 * (1920x1080, level >= 1);
 * a firmware build sets VT_MAX_WIDTH/HEIGHT (or VT_FLOW_MAX_PIXELS) to its
 * camera. Work: the pyramid (11 instructions per input pixel per level, over the
 * input pixels under the computed rectangles: about half the frame with both
 * 30 % areas, a quarter with one), then
 * per computed cell at most cell^2 * (2 sx + 1) * (2 sy + 1) absolute differences
 * (twice for the cells the backward check runs on; successive elimination and the
 * row early exit skip most, vt__search) plus (2 sx + cell) * (cell + 4 sy) adds of
 * block sums, per lateral cell 2 cell^2 for the
 * change and texture gates; the union-find is linear in cells.
 * Stack: < 4 KB (vt_pyr_down_rect's row; the blob list, 1.6 KB). Measured
 * (callgrind, bench/callgrind_main.c, 640x480, both areas, every left cell
 * moving): 6.8 M instructions, 22.2 per frame pixel: the level-1 pyramid over the
 * two areas 4.9, the searches 15.5, the rest 1.8 (before the level image was
 * restricted to the areas and the search pruned: 10.4 M, 33.7 = 12.7 + 19.2 +
 * 1.8); 1280x720: 15.9 M, 17.3 per pixel (26.0 M, 28.2). */
#ifndef VEHTRACK_FLOW_H
#define VEHTRACK_FLOW_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/fixed.h"
#include "vehtrack/image.h"
#include "vehtrack/status.h"
#include "vehtrack/verify.h"

/* Pixels of one level image the state can hold (previous, current, scratch).
 * The default fits a full VT_MAX_WIDTH x VT_MAX_HEIGHT frame at level >= 1. */
#ifndef VT_FLOW_MAX_PIXELS
#define VT_FLOW_MAX_PIXELS (((VT_MAX_WIDTH) + 1) / 2 * (((VT_MAX_HEIGHT) + 1) / 2))
#endif
/* Cells of one lateral area (vectors, labels). */
#ifndef VT_FLOW_MAX_CELLS
#define VT_FLOW_MAX_CELLS 16384
#endif
/* Hypotheses per frame (blobs over the area threshold + hand-over tracks). */
#ifndef VT_FLOW_MAX_HYPS
#define VT_FLOW_MAX_HYPS 16
#endif
/* Blobs over the area threshold kept per lateral area and frame (for the
 * persistence check). */
#ifndef VT_FLOW_MAX_BLOBS
#define VT_FLOW_MAX_BLOBS 32
#endif
/* Hand-over tracks (vehicles the ego car overtakes) followed at once. */
#ifndef VT_FLOW_MAX_SEEDS
#define VT_FLOW_MAX_SEEDS 4
#endif
/* Rectangles of one level image the state records as computed (see
 * vt_flow_state.rect): the two areas, one per hand-over track, and one per
 * vt_flow_seed_frame call between two steps (past that they merge). */
#define VT_FLOW_MAX_RECTS (2 + 2 * (VT_FLOW_MAX_SEEDS))
#if VT_FLOW_MAX_PIXELS < 1 || VT_FLOW_MAX_CELLS < 1 || VT_FLOW_MAX_CELLS > 1048576 || \
    VT_FLOW_MAX_HYPS < 1 || VT_FLOW_MAX_SEEDS < 1 || VT_FLOW_MAX_BLOBS < 1
#error "flow capacities out of range (see vehtrack/flow.h)"
#endif

/* Lateral areas, a bit mask. */
#define VT_FLOW_SIDE_LEFT 1
#define VT_FLOW_SIDE_RIGHT 2
#define VT_FLOW_SIDE_BOTH 3

/* What a hypothesis comes from. */
#define VT_FLOW_KIND_OVERTAKING 1 /* a blob moving inward in a lateral area   */
#define VT_FLOW_KIND_HANDOVER 2   /* a vehicle seeded by vt_flow_seed          */

/* Cell flags in vt_flow_state.flag[side][cell]. */
#define VT_FLOW_CELL_COMPUTED 1 /* the change gate passed: a vector was searched */
#define VT_FLOW_CELL_ACCEPTED 2 /* the vector passed range, direction and SAD   */
#define VT_FLOW_CELL_FLAT 4     /* changed, but too little texture to search    */

typedef struct {
    int32_t level;            /* pyramid level 0..2 the flow runs on              */
    int32_t sides;            /* VT_FLOW_SIDE_*: where overtaking vehicles appear */
    int32_t strip_permille;   /* width of each lateral area, permille of the width, 1..500 */
    int32_t top_permille;     /* rows of the areas: top..bottom, permille of the height, */
    int32_t bottom_permille;  /* 0 <= top < bottom <= 1000                        */
    int32_t cell;             /* cell (block) side at the level, px, 2..32        */
    int32_t search_x;         /* max |dx| at the level, px, 0..32                 */
    int32_t search_y;         /* max |dy| at the level, px, 0..32                 */
    int32_t diff_thresh;      /* |I_t - I_t-1| > this: the pixel changed, 0..255   */
    int32_t diff_min_permille; /* changed pixels a cell needs for a search, permille 0..1000 */
    int32_t min_inward;       /* range: inward dx >= this, px/frame at the level  */
    int32_t max_mag;          /* range: |dx| + |dy| <= this                       */
    int32_t max_sad_per_px;   /* best SAD above this * cell^2: no match (0..255)  */
    int32_t min_blob_cells;   /* area threshold of a blob, cells, >= 1            */
    int32_t seed_min_visible_permille; /* hand-over track dropped when fewer columns */
                              /* than this permille of its width are in the frame, 0..1000 */
    int32_t min_texture;      /* mean |I(x+1) - I(x)| in a cell below this: no    */
                              /* search (dx is undefined on flat or horizontal-  */
                              /* edge cells: the aperture problem), 0..255        */
    int32_t min_age;          /* frames in a row a blob must be seen (overlapping */
                              /* the previous frame's blob) to be reported, >= 1  */
    int32_t back_tol;         /* forward-backward check: the matched block, searched */
                              /* back, must return within this many px; -1 off     */
} vt_flow_cfg;

/* Defaults for a 640x480..1280x720 camera at level 1: 30 % strips over the
 * lower 60 % of the frame, 8x8 cells, +-6 x +-3 px search (+-12 x +-6 input px
 * per frame), a change of 12 grey levels in a quarter of a cell, inward motion of
 * at least 1 px at the level, blobs of 4 cells (16x16 level px), cells with a
 * mean horizontal difference of at least 3 grey levels, blobs seen in 3 frames
 * in a row, vectors that the backward search confirms within 1 px. */
#define VT_FLOW_CFG_DEFAULT         \
    {                               \
        .level = 1,                 \
        .sides = VT_FLOW_SIDE_LEFT, \
        .strip_permille = 300,      \
        .top_permille = 400,        \
        .bottom_permille = 1000,    \
        .cell = 8,                  \
        .search_x = 6,              \
        .search_y = 3,              \
        .diff_thresh = 12,          \
        .diff_min_permille = 250,   \
        .min_inward = 1,            \
        .max_mag = 9,               \
        .max_sad_per_px = 24,       \
        .min_blob_cells = 4,        \
        .seed_min_visible_permille = 250, \
        .min_texture = 3,           \
        .min_age = 3,               \
        .back_tol = 1,              \
    }

/* One hypothesis: box in input pixels (inclusive, as vt_box), the side it is on
 * (VT_FLOW_SIDE_LEFT/RIGHT; for a hand-over track the side its centre is on),
 * its kind, the hand-over id (0 for overtaking blobs), its size in cells and
 * its mean flow in input px/frame, Q15.16 (sum of the level vectors * 2^level,
 * divided by the count, rounded half away from zero). */
typedef struct {
    vt_box box;
    int32_t side;
    int32_t kind;
    int32_t id;
    int32_t cells;
    vt_q16 flow_x;
    vt_q16 flow_y;
    int32_t age;    /* frames in a row this blob (or hand-over track) was seen */
    int32_t cy;     /* row of its centre of gravity, input px: level row
                       y0 + cell (2 sum(j) + cells) / (2 cells), times 2^level
                       (hand-over: the box's middle row)                     */
} vt_flow_hyp;

typedef struct {
    int32_t ready;          /* 0 on a first frame (no previous one), else 1     */
    int32_t n;              /* hypotheses in hyp[]                                */
    vt_flow_hyp hyp[VT_FLOW_MAX_HYPS];
    int32_t dropped;        /* blobs over the threshold that did not fit         */
    int32_t cells_total;    /* cells of the lateral areas                         */
    int32_t cells_computed; /* ... of which passed the change gate (the speed-up) */
    int32_t cells_accepted; /* ... of which passed range and direction            */
} vt_flow_result;

/* A hand-over track: box position in input px, Q15.16 (sub-pixel motion adds
 * up), size in input px; active 0/1. */
typedef struct {
    int32_t active;
    int32_t id;
    vt_q16 left;
    vt_q16 top;
    int32_t width;
    int32_t height;
    int32_t age;
} vt_flow_seed_track;

/* The state: two level images (ping-pong: prev_index says which holds the
 * previous frame), the scratch level-1 image for level 2, and per lateral area
 * (index 0 left, 1 right) the cell grid of the last frame: gw x gh cells starting
 * at level column x0 / row y0, vectors dx/dy, best SAD and VT_FLOW_CELL_* flags,
 * row-major from index side * VT_FLOW_MAX_CELLS. */
typedef struct {
    int32_t have_prev;
    int32_t prev_index;
    int32_t w, h;         /* input frame size of the previous frame            */
    int32_t lw, lh;       /* its level image size                               */
    int32_t level;        /* the level the stored image is at                   */
    int32_t next_id;
    uint8_t img[2][VT_FLOW_MAX_PIXELS];
    uint8_t scratch[VT_FLOW_MAX_PIXELS];
    int32_t gw[2], gh[2], x0[2], y0[2];
    int8_t dx[2 * VT_FLOW_MAX_CELLS]; /* side s, cell c at [s * VT_FLOW_MAX_CELLS + c] */
    int8_t dy[2 * VT_FLOW_MAX_CELLS];
    uint8_t flag[2 * VT_FLOW_MAX_CELLS];
    uint32_t sad[2 * VT_FLOW_MAX_CELLS];
    int32_t parent[VT_FLOW_MAX_CELLS];
    int32_t count[VT_FLOW_MAX_CELLS];
    vt_flow_seed_track seeds[VT_FLOW_MAX_SEEDS];
    /* The last frame's blobs per area (boxes, ages), side s at [s * VT_FLOW_MAX_BLOBS]. */
    int32_t n_blobs[2];
    vt_box blob_box[2 * VT_FLOW_MAX_BLOBS];
    int32_t blob_age[2 * VT_FLOW_MAX_BLOBS];
    /* The parts of img[i] computed from its frame (the rest is stale or never
     * written): n_rect[i] rectangles, level px, half-open [x0, x1) x [y0, y1) at
     * rect[i][k][0..3]. */
    int32_t n_rect[2];
    int32_t rect[2][VT_FLOW_MAX_RECTS][4];
} vt_flow_state;

/* Fill *cfg with VT_FLOW_CFG_DEFAULT. */
vt_status vt_flow_cfg_default(vt_flow_cfg *cfg);

/* VT_E_ARG unless every field of *cfg is in its documented range. */
vt_status vt_flow_cfg_check(const vt_flow_cfg *cfg);

/* Forget everything: no previous frame, no hand-over tracks, ids from 1. */
vt_status vt_flow_init(vt_flow_state *st);

/* Forget the previous frame (the next frame is a first frame again); hand-over
 * tracks are dropped too, since they cannot be followed across the gap. */
vt_status vt_flow_reset(vt_flow_state *st);

/* One frame. VT_E_ARG: NULL or a bad cfg; VT_E_SIZE: a bad view or another
 * frame size than the previous call (state untouched); VT_E_CAPACITY: the level
 * image exceeds VT_FLOW_MAX_PIXELS or a lateral area VT_FLOW_MAX_CELLS cells
 * (state untouched). A change of cfg.level, or of the areas or search range that
 * widens what the areas read, between calls restarts from a first
 * frame. On error *out is zeroed (n = 0, ready = 0). Blobs over the area
 * threshold are kept in order of their first cell (left area first, then
 * raster order; past VT_FLOW_MAX_BLOBS per area they are counted in
 * out->dropped); each gets an age, 1 + the largest age of the previous frame's
 * blobs on that side whose box it overlaps, and is reported once its age
 * reaches cfg.min_age (past VT_FLOW_MAX_HYPS: counted in out->dropped).
 * Hand-over tracks follow the blobs. */
vt_status vt_flow_step(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_image_u8 *frame,
                       vt_flow_result *out);

/* Hand a vehicle over to the motion stage (the ego car is overtaking it, and the
 * geometric model will lose it as it leaves the frame). `box` is in the input
 * pixels of the last frame given to vt_flow_step (it must overlap that frame;
 * VT_E_ARG otherwise, or if there was no previous frame); *id receives the
 * track's id (also in its hypotheses). VT_E_CAPACITY when VT_FLOW_MAX_SEEDS
 * tracks are active. From the next vt_flow_step on, the track's box moves by
 * the mean vector of the cells inside it (searched without the change gate or
 * the direction filter; the texture gate, min_texture, and the SAD check kept:
 * a flat cell matches at zero motion whatever moved) and is reported as a
 * VT_FLOW_KIND_HANDOVER hypothesis; it ends when fewer than seed_min_visible_permille / 1000
 * of its columns remain in the frame or no textured cell inside it finds a match.
 * Pipeline use (c/pipeline.c does this, the rule in vehtrack/pipeline.h,
 * vt_pipeline_set_flow_ws): when a confirmed track's box reaches a lateral area
 * while the ego car is faster (its bottom row moves down, so its box grows), call
 * vt_flow_seed with the track's last box after vt_flow_step of that frame and
 * stop tracking it with the model; read it back from the flow results. */
vt_status vt_flow_seed(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_box *box, int32_t *id);

/* vt_flow_seed, and the previous level image computed over the track's box from
 * `frame`, which must be the frame last given to vt_flow_step (VT_E_SIZE if its
 * size differs; its pixels are the caller's word). vt_flow_step computes the level
 * image only where it reads it (the lateral areas with their search margins, the
 * live hand-over tracks with theirs: the recorded rectangles of vt_flow_state), so
 * a track seeded with vt_flow_seed elsewhere follows, on its first step, only the
 * cells inside those rectangles (none: it ends); seeded with this function, its
 * first step uses all its cells, as every later step does. The pipeline calls
 * this one. Past VT_FLOW_MAX_RECTS rectangles (more seeds than slots between two
 * steps, with vt_flow_unseed in between) the last one grows to cover the new one. */
vt_status vt_flow_seed_frame(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_image_u8 *frame,
                             const vt_box *box, int32_t *id);

/* Stop a hand-over track (e.g. the tracker took it back). VT_E_ARG if no
 * active track has this id. */
vt_status vt_flow_unseed(vt_flow_state *st, int32_t id);

#endif /* VEHTRACK_FLOW_H */
