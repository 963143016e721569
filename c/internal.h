/* internal.h -- helpers shared by the C sources; not part of the public API. */
#ifndef VEHTRACK_INTERNAL_H
#define VEHTRACK_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "vehtrack/config.h"
#include "vehtrack/geometry.h" /* vt_box, for vt__box_suppress */
#include "vehtrack/image.h"
#include "vehtrack/shadow.h" /* vt_shadow_cfg, for vt__shadow_suppresses */
#include "vehtrack/status.h"
#include "vehtrack/fulldet.h" /* for vt__fulldet_verify */
#include "vehtrack/windows.h" /* vt_scored_box, for vt__cand_add */

/* Size check shared by every view type: VT_E_SIZE unless 1 <= w <= maxw,
 * 1 <= h <= maxh and stride >= w. */
static inline vt_status vt__check_dims(int32_t w, int32_t h, int32_t stride, int32_t maxw,
                                       int32_t maxh)
{
    if (w < 1 || h < 1 || w > maxw || h > maxh || stride < w) {
        return VT_E_SIZE;
    }
    return VT_OK;
}

/* The body of every vt_*_cfg_default(): *dst = the const default (n bytes);
 * VT_E_ARG for a NULL dst. */
static inline vt_status vt__cfg_copy(void *dst, const void *def, size_t n)
{
    if (dst == NULL) {
        return VT_E_ARG;
    }
    memcpy(dst, def, n);
    return VT_OK;
}

/* |v| for v > INT32_MIN (pixel coordinates and differences of them). */
static inline int32_t vt__abs_i32(int32_t v)
{
    return v < 0 ? -v : v;
}

static inline int32_t vt__max_i32(int32_t a, int32_t b)
{
    return a > b ? a : b;
}

static inline int32_t vt__clamp_i32(int32_t v, int32_t lo, int32_t hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* floor(n / d) for d > 0 (n may be negative; C99 division truncates toward zero). */
static inline int64_t vt__floor_div64(int64_t n, int64_t d)
{
    int64_t q = n / d;
    return (n % d != 0 && n < 0) ? q - 1 : q;
}

/* The smoothing blend of every tracked quantity (the camera's pitch, the lane
 * tracker's lines): prev + alpha (cur - prev), alpha = a / 1000 (a in 0..1000,
 * checked by the caller's config check). The step (cur - prev) * a / 1000 is
 * rounded half away from zero (C99 division truncates toward zero, so adding
 * +-500 first rounds ties outward), which keeps the result between prev and cur
 * (|step| <= |cur - prev|) and treats a rise and a fall alike. |cur - prev| <
 * 2^52 keeps the product exact in int64; the callers' values are < 2^33. */
static inline int64_t vt__blend_permille(int64_t prev, int64_t cur, int32_t a)
{
    int64_t n = (cur - prev) * a;
    return prev + (n >= 0 ? n + 500 : n - 500) / 1000;
}

/* BORDER_REFLECT_101 index (as OpenCV's borderInterpolate): ... 2 1 | 0 1 2 ... n-1 | n-2 ...
 * reflected as often as needed, so tiny images work too. */
static inline int32_t vt__reflect101(int32_t p, int32_t n)
{
    if (n == 1) {
        return 0;
    }
    while (p < 0 || p >= n) {
        p = p < 0 ? -p : 2 * (n - 1) - p;
    }
    return p;
}

/* The three source rows a 3x3 Sobel reads at row y (0 <= y < img->h): above,
 * at and below it, the edge row standing in for the row past the border
 * (replicated border, as OpenCV's BORDER_REPLICATE). Every Sobel of the core
 * (vt_sobel_x/y, the shadow scan, verification, the tracker's search) starts here. */
static inline void vt__sobel_rows(const vt_image_u8 *img, int32_t y, const uint8_t **pm,
                                  const uint8_t **p0, const uint8_t **pp)
{
    *pm = img->px + (size_t)(y > 0 ? y - 1 : 0) * (size_t)img->stride;
    *p0 = img->px + (size_t)y * (size_t)img->stride;
    *pp = img->px + (size_t)(y < img->h - 1 ? y + 1 : img->h - 1) * (size_t)img->stride;
}

/* NMS's test (c/windows.c, vt_nms): box b is suppressed by the kept box a when their
 * IoU exceeds iou_permille / 1000 or the intersection exceeds contain_permille / 1000
 * of the smaller box. Exact in int64 for coordinates within +-2^24. */
int vt__box_suppress(const vt_box *a, const vt_box *b, int32_t iou_permille, int32_t contain_permille);

/* c/windows.c: add a candidate to cand[0 .. *n - 1] (capacity cap >= 1): appended while
 * there is room, else it replaces the lowest-scoring one (the first such) if it scores
 * higher; every add past the capacity counts in *n_dropped. vt_fulldet's and
 * vt_acf_detect's candidate lists. */
/* c/fulldet.c: vt_fulldet_verify, where boxes that the rear-view stage cannot judge pass
 * unscored with their own score: with VT__VERIFY_SKIP_FLAT in skip a box flatter than 1:2
 * (2 height < width: a side view; vt_pipeline_cfg.verify 2), with VT__VERIFY_SKIP_SIDE also
 * a box whose gap to the frame's left or right side is at most a quarter of its width
 * plus 1 px (4 gap <= width + 4: a vehicle the frame's edge cuts, whose bottom-row square
 * cannot show it whole; the edge models' boxes, acf.h's cols; verify 3), with
 * VT__VERIFY_SKIP_SMALL also a box narrower than VT__VERIFY_SMALL_W px (a far car: the
 * 64x64 MLP would see it enlarged 2x or more, with no detail to judge; verify 4). */
#define VT__VERIFY_SKIP_FLAT 1
#define VT__VERIFY_SKIP_SIDE 2
#define VT__VERIFY_SKIP_SMALL 4
#define VT__VERIFY_SMALL_W 32
vt_status vt__fulldet_verify(vt_cls_box_ws *ws, const vt_mlp_model *m, const vt_image_u8 *img,
                             int32_t score_min, int32_t skip, vt_fulldet_result *res);

void vt__cand_add(vt_scored_box *cand, int32_t *n, int32_t cap, int32_t *n_dropped, const vt_box *b,
                  int32_t score, int32_t source);

/* shadow.c: does the kept shadow edge k suppress edge c above it (the
 * one-edge-per-vehicle rule; vt_detect applies it to verified edges only when
 * cfg->reduce_verified)? cfg must have passed vt_shadow_cfg_check. */
int vt__shadow_suppresses(const vt_shadow_cfg *cfg, int32_t k_row, int32_t k_xs, int32_t k_xe,
                          int32_t c_row, int32_t c_xs, int32_t c_xe);

/* image.c: vt_ncc_u8's arithmetic in two halves, so a caller correlating one patch with
 * many (the tracker's template match) normalises the fixed one once. vt__ncc_norm_of:
 * one patch's v = n*ss - s*s over n <= VT_MAX_PATCH_PIXELS pixels, sqrt(v) = root / 2^k
 * with root in [2^30, 2^31); 0 for a flat patch (v <= 0). vt__ncc_from_norms: the Q14
 * correlation from the sums and both norms, as vt_ncc_u8 returns it. */
typedef struct {
    uint64_t root;
    int32_t k;
} vt__ncc_norm;
int vt__ncc_norm_of(uint64_t n, uint64_t s, uint64_t ss, vt__ncc_norm *out);
vt_status vt__ncc_from_norms(uint64_t n, uint64_t sa, uint64_t sb, uint64_t sab, const vt__ncc_norm *a,
                             const vt__ncc_norm *b, vt_q14 *ncc);

/* SSE2 (every x86-64) inner loops beside the portable ones (image.c's Sobel rows,
 * track_search.c's projections); other targets and builds with -DVT_NO_SIMD take the
 * portable loops, with the same results. */
#if defined(__SSE2__) && !defined(VT_NO_SIMD)
#define VT__SSE2 1
#include <emmintrin.h>
/* 8 bytes at p widened to int16 lanes. */
static inline __m128i vt__ld8(const uint8_t *p)
{
    return _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)(const void *)p), _mm_setzero_si128());
}
/* Sobel d/dx and d/dy at the 8 columns x .. x+7 of rows pm, p0, pp (columns x-1 .. x+8
 * read); each response is within +-1020, an int16 lane. */
static inline __m128i vt__sobel_x8(const uint8_t *pm, const uint8_t *p0, const uint8_t *pp, int32_t x)
{
    return _mm_add_epi16(_mm_add_epi16(_mm_sub_epi16(vt__ld8(pm + x + 1), vt__ld8(pm + x - 1)),
                                       _mm_sub_epi16(vt__ld8(pp + x + 1), vt__ld8(pp + x - 1))),
                         _mm_slli_epi16(_mm_sub_epi16(vt__ld8(p0 + x + 1), vt__ld8(p0 + x - 1)), 1));
}
static inline __m128i vt__sobel_y8(const uint8_t *pm, const uint8_t *pp, int32_t x)
{
    return _mm_sub_epi16(_mm_add_epi16(_mm_add_epi16(vt__ld8(pp + x - 1), vt__ld8(pp + x + 1)),
                                       _mm_slli_epi16(vt__ld8(pp + x), 1)),
                         _mm_add_epi16(_mm_add_epi16(vt__ld8(pm + x - 1), vt__ld8(pm + x + 1)),
                                       _mm_slli_epi16(vt__ld8(pm + x), 1)));
}
#else
#define VT__SSE2 0
#endif

#endif /* VEHTRACK_INTERNAL_H */
