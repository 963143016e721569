/* cnn.h: a small quantised CNN detector (heat map + box sides) and its peak decoder. */
#define VT_CNN_MAX_LAYERS ...
#define VT_CNN_MAX_CH ...
#define VT_CNN_OUT_CH ...
#define VT_CNN_BIAS_MAX ...
#define VT_CNN_HEAT_SCALE_MAX ...
#define VT_CNN_MAX_LEVEL ...
#define VT_CNN_MAX_RUN_LEVELS ...
#define VT_CNN_MAX_PEAKS ...
#define VT_CNN_REF_HORIZON_Q16 ...

typedef struct {
    uint8_t ksize;
    uint8_t stride;
    uint8_t dilation;
    uint8_t relu;
    uint16_t cin;
    uint16_t cout;
    const int8_t *w;
    const int32_t *bias;
    const int32_t *mult;
    const uint8_t *shift;
} vt_cnn_layer;

typedef struct {
    uint8_t n_layers;
    vt_cnn_layer layer[...];
    uint8_t out_stride;
    int8_t heat_thr;
    int32_t heat_scale_q16;
    const uint16_t *side_lut;
} vt_cnn_model;

typedef struct {
    int32_t l;
    int32_t t;
    int32_t r;
    int32_t b;
    int32_t score;
} vt_cnn_box;

typedef struct {
    int32_t first_level;
    int32_t n_levels;
    int32_t thr_offset;
    int32_t cap_per_level;
    int32_t nms_iou_permille;
    int32_t nms_contain_permille;
    int32_t l0_top_permille;
    int32_t l0_bottom_permille;
    int32_t stretch_tail_permille;
    int32_t up_top_permille;
    int32_t up_bottom_permille;
    int32_t up_left_permille;
    int32_t up_right_permille;
} vt_cnn_cfg;

vt_status vt_cnn_check_model(const vt_cnn_model *m);
vt_status vt_cnn_out_size(const vt_cnn_model *m, int32_t w, int32_t h, int32_t *gw, int32_t *gh);
vt_status vt_cnn_work_bytes(const vt_cnn_model *m, int32_t w, int32_t h, size_t *bytes);
#define VT_CNN_SIMD_PORTABLE 0
#define VT_CNN_SIMD_SSE2 1
#define VT_CNN_SIMD_AVX2 2
#define VT_CNN_SIMD_AVXVNNI 3
#define VT_CNN_SIMD_AVX512VNNI 4
vt_status vt_cnn_simd_path(int32_t *path);
vt_status vt_cnn_forward(const vt_cnn_model *m, const uint8_t *img, int32_t w, int32_t h,
                         int32_t stride, uint8_t *work, size_t work_bytes, int8_t *out,
                         size_t out_len);
vt_status vt_cnn_decode(const vt_cnn_model *m, const int8_t *out, int32_t gw, int32_t gh,
                        int32_t thr, int32_t scale_shift, vt_cnn_box *boxes, int32_t cap,
                        int32_t *n, int32_t *n_peaks);
vt_status vt_cnn_cfg_default(vt_cnn_cfg *cfg);
vt_status vt_cnn_cfg_check(const vt_cnn_cfg *cfg);
vt_status vt_cnn_cfg_at_horizon(const vt_cnn_cfg *cfg, int32_t horizon_q16, vt_cnn_cfg *out);
vt_status vt_cnn_frame_work_bytes(const vt_cnn_model *m, const vt_cnn_cfg *cfg, int32_t w,
                                  int32_t h, size_t *bytes);
vt_status vt_cnn_detect_frame(const vt_cnn_model *m, const vt_cnn_cfg *cfg, const uint8_t *img,
                              int32_t w, int32_t h, int32_t stride, uint8_t *work,
                              size_t work_bytes, vt_cnn_box *boxes, int32_t cap, int32_t *n,
                              int32_t *n_peaks);
