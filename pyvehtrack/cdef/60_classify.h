/* classify.h: HOG / GIST descriptors and the quantised linear SVM. */
#define VT_DESC_HOG ...
#define VT_DESC_GIST ...
#define VT_CLS_CELL ...
#define VT_HOG_BINS ...
#define VT_HOG_BLOCK_LEN ...
#define VT_GIST_SCALES ...
#define VT_GIST_ORIENT ...
#define VT_GIST_FILTERS ...
#define VT_GIST_GRID ...
#define VT_GIST_DIM ...
#define VT_GIST_KSIZE ...
#define VT_CLS_MAX_W ...
#define VT_CLS_MAX_H ...
#define VT_CLS_MAX_WIN ...
#define VT_CLS_MAX_DIM ...
#define VT_GIST_MAX_W ...
#define VT_GIST_MAX_H ...
#define VT_MLP_MAX_HIDDEN ...

typedef struct {
    int32_t kind;
    int32_t win_w;
    int32_t win_h;
    int32_t dim;
    int32_t w_shift;
    int32_t bias_q16;
    int32_t threshold_q16;
    const int16_t *w;
} vt_svm_model;

typedef struct { int32_t cells_x; int32_t cells_y; ...; } vt_hog_ws;
typedef struct { int32_t cells_x; int32_t cells_y; ...; } vt_gist_ws;
typedef struct { ...; } vt_cls_box_ws;

vt_status vt_hog_prepare(vt_hog_ws *ws, const vt_image_u8 *img);
vt_status vt_hog_descriptor(const vt_hog_ws *ws, int32_t cx, int32_t cy, int32_t win_w,
                            int32_t win_h, uint16_t *out, int32_t cap, int32_t *n_out);
vt_status vt_hog_window_score(const vt_hog_ws *ws, const vt_svm_model *m, int32_t cx,
                              int32_t cy, int32_t *score_q16);
vt_status vt_hog_scan(const vt_hog_ws *ws, const vt_svm_model *m, int32_t cx0, int32_t cy0,
                      int32_t ncx, int32_t ncy, int32_t *scores, int32_t cap);
vt_status vt_gist_prepare(vt_gist_ws *ws, const vt_image_u8 *img);
vt_status vt_gist_descriptor(const vt_gist_ws *ws, int32_t cx, int32_t cy, int32_t win_w,
                             int32_t win_h, uint16_t *out, int32_t cap, int32_t *n_out);
vt_status vt_svm_decision(const vt_svm_model *m, const uint16_t *desc, int32_t n,
                          int32_t *score_q16);
vt_status vt_svm_model_check(const vt_svm_model *m);
vt_status vt_resample_area(const vt_image_u8 *src, const vt_box *box, vt_image_u8_mut *dst);
vt_status vt_classify_box(vt_cls_box_ws *ws, const vt_svm_model *m, const vt_image_u8 *frame,
                          const vt_box *box, int32_t *score_q16);
vt_status vt_svm_default_model(int32_t kind, const vt_svm_model **m);

typedef struct {
    int32_t kind;
    int32_t win_w;
    int32_t win_h;
    int32_t dim;
    int32_t hidden;
    int32_t w1_shift;
    int32_t w2_shift;
    int32_t b2_q16;
    int32_t threshold_q16;
    const int16_t *w1;
    const int32_t *b1_q16;
    const int16_t *w2;
} vt_mlp_model;
vt_status vt_mlp_model_check(const vt_mlp_model *m);
vt_status vt_mlp_decision(const vt_mlp_model *m, const uint16_t *desc, int32_t n,
                          int32_t *score_q16);
vt_status vt_classify_box_mlp(vt_cls_box_ws *ws, const vt_mlp_model *m, const vt_image_u8 *frame,
                              const vt_box *box, int32_t *score_q16);
vt_status vt_mlp_default_model(const vt_mlp_model **m);
