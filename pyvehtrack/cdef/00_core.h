/* The C API as cffi sees it (API mode: every "..." is read from the real
 * headers by the C compiler, so no number is copied into Python).
 * tests/test_cdef.py checks that every public declaration in include/vehtrack/
 * appears here with the same signature. */

#define VT_MAX_WIDTH ...
#define VT_MAX_HEIGHT ...
#define VT_MAX_PATCH_PIXELS ...
#define VT_MAX_TRACKS ...
#define VT_Q16_ONE ...
#define VT_Q14_ONE ...
#define VT_QDEG_PER_DEG ...
#define VT_QDEG_TURN ...
#define VT_VERSION_MAJOR ...
#define VT_VERSION_MINOR ...
#define VT_VERSION_PATCH ...

typedef enum { VT_OK, VT_E_ARG, VT_E_SIZE, VT_E_CAPACITY, VT_E_SINGULAR, ... } vt_status;
typedef int32_t vt_q16;
typedef int16_t vt_q14;
typedef int32_t vt_angle_qdeg;

typedef struct { const uint8_t *px; int32_t w; int32_t h; int32_t stride; } vt_image_u8;
typedef struct { uint8_t *px; int32_t w; int32_t h; int32_t stride; } vt_image_u8_mut;
typedef struct { int16_t *px; int32_t w; int32_t h; int32_t stride; } vt_image_s16;
typedef struct { uint32_t *px; int32_t w; int32_t h; int32_t stride; } vt_image_u32;

/* geometry.h */
typedef struct { int32_t left; int32_t top; int32_t right; int32_t bottom; } vt_box;
typedef struct { int32_t row; int32_t x_start; int32_t x_end; } vt_hypothesis;

/* status.h */
vt_status vt_status_name(int code, const char **name);

/* fixed.h */
int16_t vt_sat_s16(int32_t x);
int32_t vt_sat_s32(int64_t x);
vt_q16 vt_q16_from_int(int32_t n);
int32_t vt_q16_round(vt_q16 a);
vt_q16 vt_q16_add_sat(vt_q16 a, vt_q16 b);
vt_q16 vt_q16_sub_sat(vt_q16 a, vt_q16 b);
vt_q16 vt_q16_mul_sat(vt_q16 a, vt_q16 b);
vt_q16 vt_q16_mul_q14(vt_q16 a, vt_q14 b);
vt_q14 vt_q14_mul_sat(vt_q14 a, vt_q14 b);
uint16_t vt_isqrt_u32(uint32_t x);
uint32_t vt_isqrt_u64(uint64_t x);
vt_status vt_div_round_s64(int64_t n, int64_t d, int64_t *q);
vt_status vt_q16_div(vt_q16 a, vt_q16 b, vt_q16 *out);
vt_status vt_q16_recip(vt_q16 a, vt_q16 *out);

/* trig.h */
vt_status vt_sincos_q14(vt_angle_qdeg a, vt_q14 *sin_out, vt_q14 *cos_out);

/* image.h */
vt_status vt_image_u8_check(const vt_image_u8 *img);
vt_status vt_filter_h101(const vt_image_u8 *src, vt_image_s16 *dst);
vt_status vt_sobel_x(const vt_image_u8 *src, vt_image_s16 *dst);
vt_status vt_sobel_y(const vt_image_u8 *src, vt_image_s16 *dst);
vt_status vt_pyr_down(const vt_image_u8 *src, vt_image_u8_mut *dst);
vt_status vt_resize_area(const vt_image_u8 *src, vt_image_u8_mut *dst);
vt_status vt_pyr_down_rect(const vt_image_u8 *src, vt_image_u8_mut *dst, int32_t x0, int32_t y0,
                           int32_t x1, int32_t y1);
vt_status vt_integral(const vt_image_u8 *src, vt_image_u32 *dst);
vt_status vt_box_sum(const vt_image_u32 *ii, int32_t x, int32_t y, int32_t w, int32_t h, uint32_t *sum);
vt_status vt_ncc_u8(const vt_image_u8 *a, const vt_image_u8 *b, vt_q14 *ncc);
vt_status vt_sad_u8(const vt_image_u8 *a, const vt_image_u8 *b, uint32_t *sad);

/* road.h */
typedef struct {
    int32_t valid;
    int32_t y_top;
    int32_t y_bottom;
    int32_t height;
    int16_t x_left[...];
    int16_t x_right[...];
    int16_t lane_width[...];
} vt_road_area;
