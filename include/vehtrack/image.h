/* vehtrack/image.h -- image views and the pixel primitives every stage uses:
 * [-1 0 1] filter (thesis sec. 2.4.1.2, lane edges), Sobel x/y (thesis sec. 2.4.2,
 * shadow and vertical edges), 2x Gaussian pyramid step (IVVI paper, coarse-to-fine
 * optical flow), integral image and box sums, normalised cross-correlation
 * (thesis sec. 3, track check before drop) and SAD of two blocks (IVVI paper,
 * block matching).
 *
 * Cost: no state, no RAM beyond the caller's buffers. Every function is one pass
 * over its output (the pyramid: 25 multiply-adds per output pixel, separable).
 *
 * Views do not own memory. `stride` is in elements of the view's pixel type
 * (not bytes) and must be >= w. Sizes must be 1..VT_MAX_WIDTH by
 * 1..VT_MAX_HEIGHT unless a function says otherwise. Borders: the 3x3 filters
 * replicate the edge pixel (OpenCV BORDER_REPLICATE); the pyramid reflects
 * without repeating the edge (BORDER_REFLECT_101, as cv2.pyrDown).
 * Source and destination must not overlap. */
#ifndef VEHTRACK_IMAGE_H
#define VEHTRACK_IMAGE_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/fixed.h"
#include "vehtrack/status.h"

/* Read-only 8-bit gray view. */
typedef struct {
    const uint8_t *px;
    int32_t w;
    int32_t h;
    int32_t stride;
} vt_image_u8;

/* Writable 8-bit gray view. */
typedef struct {
    uint8_t *px;
    int32_t w;
    int32_t h;
    int32_t stride;
} vt_image_u8_mut;

/* Writable signed 16-bit view (gradients). */
typedef struct {
    int16_t *px;
    int32_t w;
    int32_t h;
    int32_t stride;
} vt_image_s16;

/* Writable unsigned 32-bit view (integral images). */
typedef struct {
    uint32_t *px;
    int32_t w;
    int32_t h;
    int32_t stride;
} vt_image_u32;

/* Check a read-only view: VT_E_ARG if it or its pixels are NULL, VT_E_SIZE if
 * w/h are not in 1..VT_MAX_* or stride < w. */
vt_status vt_image_u8_check(const vt_image_u8 *img);

/* dst = src(x+1) - src(x-1) per row, edge pixel replicated. |out| <= 255.
 * dst must have src's size. Exact. */
vt_status vt_filter_h101(const vt_image_u8 *src, vt_image_s16 *dst);

/* 3x3 Sobel d/dx ([-1 0 1] x [1 2 1]^T), edge replicated. |out| <= 1020. Exact. */
vt_status vt_sobel_x(const vt_image_u8 *src, vt_image_s16 *dst);

/* 3x3 Sobel d/dy ([1 2 1] x [-1 0 1]^T): positive where the image gets
 * brighter going down. |out| <= 1020. Exact. */
vt_status vt_sobel_y(const vt_image_u8 *src, vt_image_s16 *dst);

/* One Gaussian pyramid step: 5x5 kernel [1 4 6 4 1]^T[1 4 6 4 1]/256, then keep
 * even rows and columns. dst must be ((w+1)/2) x ((h+1)/2). The sum of 25
 * products is exact in int32; the /256 rounds half up, as cv2.pyrDown does.
 * Stack: one row of column sums, 2 * VT_MAX_WIDTH bytes (3.8 KB at the default
 * width; build with a smaller VT_MAX_WIDTH for a small firmware stack). */
vt_status vt_pyr_down(const vt_image_u8 *src, vt_image_u8_mut *dst);

/* Area downscale (OpenCV's INTER_AREA rule, in exact integers) of src into dst's size,
 * for a camera wider than the stages were tuned at: vt_pipeline_work_size gives the
 * size (pyvehtrack's work_width, 1280 by default), this makes the frame. With W x H the
 * source and w x h the output (1 <= w <= W, 1 <= h <= H), input pixel i spans [i w,
 * (i+1) w) and output pixel x spans [x W, (x+1) W) of a common axis; each output is the
 * overlap-weighted sum of the inputs it covers (weights sum to W H), rounded half up:
 * out = floor((sum + W H / 2) / (W H)). The sum is below 255.5 W H <= 2^30 (W H <=
 * 2^22, config.h) and the division is a 2^52 reciprocal, exact because (sum + W H / 2)
 * W H < 2^52. VT_E_ARG for NULL or a NULL dst->px, VT_E_SIZE for a dst larger than src in
 * either side, < 1, or with stride < w. dst must not overlap src. Stack: one row of
 * uint32 sums, 4 * VT_MAX_WIDTH bytes (7.5 KB at the default width). */
vt_status vt_resize_area(const vt_image_u8 *src, vt_image_u8_mut *dst);

/* vt_pyr_down restricted to the output pixels (ox, oy) with x0 <= ox < x1 and
 * y0 <= oy < y1 of dst (the whole ((w+1)/2) x ((h+1)/2) level image, checked as
 * for vt_pyr_down): each gets exactly the value vt_pyr_down gives it (same sums,
 * reflection and rounding); no other pixel of dst is written, and only the source
 * pixels those outputs read are read (rows and columns 2 y0 - 2 .. 2 y1 and
 * 2 x0 - 2 .. 2 x1, reflected into the frame). VT_E_ARG unless
 * 0 <= x0 <= x1 <= dst->w and 0 <= y0 <= y1 <= dst->h; an empty rectangle does
 * nothing. Stack and scaling as vt_pyr_down. For a stage that reads only parts
 * of a level image (the flow stage's lateral areas). */
vt_status vt_pyr_down_rect(const vt_image_u8 *src, vt_image_u8_mut *dst, int32_t x0, int32_t y0,
                           int32_t x1, int32_t y1);

/* Integral image: dst is (w+1) x (h+1), dst(0,*) = dst(*,0) = 0 and
 * dst(y+1,x+1) = sum of src over [0..x] x [0..y] (as cv2.integral). Exact:
 * VT_MAX_WIDTH*VT_MAX_HEIGHT*255 < 2^32. dst->w must be w+1 (so it may be
 * VT_MAX_WIDTH+1). */
vt_status vt_integral(const vt_image_u8 *src, vt_image_u32 *dst);

/* Sum of the source pixels in the rectangle [x, x+w) x [y, y+h), read from an
 * integral image made by vt_integral (four lookups). The rectangle must lie
 * inside the source (0 <= x, w >= 1, x + w <= ii->w - 1, same for y). Exact. */
vt_status vt_box_sum(const vt_image_u32 *ii, int32_t x, int32_t y, int32_t w,
                     int32_t h, uint32_t *sum);

/* Normalised cross-correlation (Pearson coefficient) of two equal-size patches,
 * in Q1.14, [-16384, 16384]. At most VT_MAX_PATCH_PIXELS pixels.
 * Scaling: the centred sums n*sum(ab) - sum(a)sum(b) etc. are exact in int64
 * (< 2^48); both variances are normalised to 62 bits before an exact integer
 * square root, so the quotient carries ~29 significant bits before the final
 * rounding (half away from zero) to Q14: error <= 1 LSB.
 * VT_E_SINGULAR if either patch is flat (zero variance: undefined). */
vt_status vt_ncc_u8(const vt_image_u8 *a, const vt_image_u8 *b, vt_q14 *ncc);

/* Sum of absolute differences of two equal-size blocks. Exact:
 * 255 * VT_MAX_WIDTH * VT_MAX_HEIGHT < 2^32. */
vt_status vt_sad_u8(const vt_image_u8 *a, const vt_image_u8 *b, uint32_t *sad);

#endif /* VEHTRACK_IMAGE_H */
