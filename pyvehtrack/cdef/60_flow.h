/* flow.h: overtaking vehicles by SAD block-matching flow (IVVI sec. 3). */
#define VT_FLOW_MAX_PIXELS ...
#define VT_FLOW_MAX_CELLS ...
#define VT_FLOW_MAX_HYPS ...
#define VT_FLOW_MAX_SEEDS ...
#define VT_FLOW_MAX_BLOBS ...
#define VT_FLOW_MAX_RECTS ...
#define VT_FLOW_SIDE_LEFT ...
#define VT_FLOW_SIDE_RIGHT ...
#define VT_FLOW_SIDE_BOTH ...
#define VT_FLOW_KIND_OVERTAKING ...
#define VT_FLOW_KIND_HANDOVER ...
#define VT_FLOW_CELL_COMPUTED ...
#define VT_FLOW_CELL_ACCEPTED ...
#define VT_FLOW_CELL_FLAT ...

typedef struct {
    int32_t level;
    int32_t sides;
    int32_t strip_permille;
    int32_t top_permille;
    int32_t bottom_permille;
    int32_t cell;
    int32_t search_x;
    int32_t search_y;
    int32_t diff_thresh;
    int32_t diff_min_permille;
    int32_t min_inward;
    int32_t max_mag;
    int32_t max_sad_per_px;
    int32_t min_blob_cells;
    int32_t seed_min_visible_permille;
    int32_t min_texture;
    int32_t min_age;
    int32_t back_tol;
} vt_flow_cfg;

typedef struct {
    vt_box box;
    int32_t side;
    int32_t kind;
    int32_t id;
    int32_t cells;
    vt_q16 flow_x;
    vt_q16 flow_y;
    int32_t age;
    int32_t cy;
} vt_flow_hyp;

typedef struct {
    int32_t ready;
    int32_t n;
    vt_flow_hyp hyp[...];
    int32_t dropped;
    int32_t cells_total;
    int32_t cells_computed;
    int32_t cells_accepted;
} vt_flow_result;

typedef struct {
    int32_t active;
    int32_t id;
    vt_q16 left;
    vt_q16 top;
    int32_t width;
    int32_t height;
    int32_t age;
} vt_flow_seed_track;

typedef struct {
    int32_t have_prev;
    int32_t prev_index;
    int32_t w, h;
    int32_t lw, lh;
    int32_t level;
    int32_t next_id;
    int32_t gw[2], gh[2], x0[2], y0[2];
    int8_t dx[...];
    int8_t dy[...];
    uint8_t flag[...];
    uint32_t sad[...];
    vt_flow_seed_track seeds[...];
    int32_t n_blobs[2];
    vt_box blob_box[...];
    int32_t blob_age[...];
    int32_t n_rect[2];
    ...;
} vt_flow_state;

vt_status vt_flow_cfg_default(vt_flow_cfg *cfg);
vt_status vt_flow_cfg_check(const vt_flow_cfg *cfg);
vt_status vt_flow_init(vt_flow_state *st);
vt_status vt_flow_reset(vt_flow_state *st);
vt_status vt_flow_step(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_image_u8 *frame,
                       vt_flow_result *out);
vt_status vt_flow_seed(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_box *box, int32_t *id);
vt_status vt_flow_seed_frame(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_image_u8 *frame,
                             const vt_box *box, int32_t *id);
vt_status vt_flow_unseed(vt_flow_state *st, int32_t id);
