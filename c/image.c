/* image.c -- pixel primitives: [-1 0 1] filter (thesis sec. 2.4.1.2), Sobel
 * (thesis sec. 2.4.2), Gaussian pyramid step (IVVI paper, sec. on optical flow),
 * integral image, normalised cross-correlation (thesis sec. 3.3) and SAD block
 * difference (IVVI paper, block matching). See image.h for scaling and borders. */
#include "vehtrack/image.h"
#include "internal.h"

vt_status vt_image_u8_check(const vt_image_u8 *img)
{
    if (img == NULL || img->px == NULL) {
        return VT_E_ARG;
    }
    return vt__check_dims(img->w, img->h, img->stride, VT_MAX_WIDTH, VT_MAX_HEIGHT);
}

static vt_status vt__check_s16(const vt_image_s16 *img)
{
    if (img == NULL || img->px == NULL) {
        return VT_E_ARG;
    }
    return vt__check_dims(img->w, img->h, img->stride, VT_MAX_WIDTH, VT_MAX_HEIGHT);
}

/* Checks a source, then an output view (present: its pointers are not NULL; w, h,
 * stride its size) of (W + 1) / 2 x (H + 1) / 2 pixels for `half`, else of
 * (W + 1) x (H + 1) (an integral image). */
static vt_status vt__check_src_out(const vt_image_u8 *src, int present, int32_t w, int32_t h, int32_t stride,
                                   int half)
{
    vt_status s = vt_image_u8_check(src);
    if (s != VT_OK) {
        return s;
    }
    if (!present) {
        return VT_E_ARG;
    }
    if (half ? (w != (src->w + 1) / 2 || h != (src->h + 1) / 2) : (w != src->w + 1 || h != src->h + 1)) {
        return VT_E_SIZE;
    }
    return stride >= w ? VT_OK : VT_E_SIZE;
}

/* Checks a source and a same-size int16 destination. */
static vt_status vt__check_src_dst(const vt_image_u8 *src, const vt_image_s16 *dst)
{
    vt_status s = vt_image_u8_check(src);
    s = s != VT_OK ? s : vt__check_s16(dst);
    if (s != VT_OK) {
        return s;
    }
    return (dst->w == src->w && dst->h == src->h) ? VT_OK : VT_E_SIZE;
}

vt_status vt_filter_h101(const vt_image_u8 *src, vt_image_s16 *dst)
{
    int32_t x, y, w;
    vt_status s = vt__check_src_dst(src, dst);
    if (s != VT_OK) {
        return s;
    }
    w = src->w;
    for (y = 0; y < src->h; ++y) {
        const uint8_t *p = src->px + (size_t)y * (size_t)src->stride;
        int16_t *o = dst->px + (size_t)y * (size_t)dst->stride;
        if (w == 1) {
            o[0] = 0;
            continue;
        }
        o[0] = (int16_t)(p[1] - p[0]);
        for (x = 1; x < w - 1; ++x) {
            o[x] = (int16_t)(p[x + 1] - p[x - 1]);
        }
        o[w - 1] = (int16_t)(p[w - 1] - p[w - 2]);
    }
    return VT_OK;
}

/* Sobel responses at one column with explicit neighbours (used at the borders). */
static int16_t vt__sx(const uint8_t *pm, const uint8_t *p0, const uint8_t *pp, int32_t xl, int32_t xr)
{
    return (int16_t)((pm[xr] - pm[xl]) + 2 * (p0[xr] - p0[xl]) + (pp[xr] - pp[xl]));
}

static int16_t vt__sy(const uint8_t *pm, const uint8_t *pp, int32_t xl, int32_t x, int32_t xr)
{
    return (int16_t)((pp[xl] + 2 * pp[x] + pp[xr]) - (pm[xl] + 2 * pm[x] + pm[xr]));
}

/* One row of Sobel d/dx: the interior has no border test, so the compiler can
 * vectorise it; the two border columns replicate their neighbour. */
static void vt__sobel_x_row(const uint8_t *pm, const uint8_t *p0, const uint8_t *pp, int32_t w,
                            int16_t *o)
{
    int32_t x;
    o[0] = vt__sx(pm, p0, pp, 0, w > 1 ? 1 : 0);
    x = 1;
#if VT__SSE2
    /* 8 outputs at a time (int16 lanes); x + 8 <= w - 1 keeps column x + 8 inside */
    for (; x + 8 <= w - 1; x += 8) {
        _mm_storeu_si128((__m128i *)(void *)(o + x), vt__sobel_x8(pm, p0, pp, x));
    }
#endif
    for (; x < w - 1; ++x) {
        o[x] = (int16_t)((pm[x + 1] - pm[x - 1]) + 2 * (p0[x + 1] - p0[x - 1]) + (pp[x + 1] - pp[x - 1]));
    }
    if (w > 1) {
        o[w - 1] = vt__sx(pm, p0, pp, w - 2, w - 1);
    }
}

/* One row of Sobel d/dy (the centre row has weight 0), borders as above. */
static void vt__sobel_y_row(const uint8_t *pm, const uint8_t *pp, int32_t w, int16_t *o)
{
    int32_t x;
    o[0] = vt__sy(pm, pp, 0, 0, w > 1 ? 1 : 0);
    x = 1;
#if VT__SSE2
    for (; x + 8 <= w - 1; x += 8) {
        _mm_storeu_si128((__m128i *)(void *)(o + x), vt__sobel_y8(pm, pp, x));
    }
#endif
    for (; x < w - 1; ++x) {
        o[x] = (int16_t)((pp[x - 1] + 2 * pp[x] + pp[x + 1]) - (pm[x - 1] + 2 * pm[x] + pm[x + 1]));
    }
    if (w > 1) {
        o[w - 1] = vt__sy(pm, pp, w - 2, w - 1, w - 1);
    }
}

/* Both Sobel images: the same checks and row set-up, then d/dx or d/dy per row. */
static vt_status vt__sobel(const vt_image_u8 *src, vt_image_s16 *dst, int d_dy)
{
    int32_t y;
    vt_status s = vt__check_src_dst(src, dst);
    if (s != VT_OK) {
        return s;
    }
    for (y = 0; y < src->h; ++y) {
        const uint8_t *pm, *p0, *pp;
        int16_t *o = dst->px + (size_t)y * (size_t)dst->stride;
        vt__sobel_rows(src, y, &pm, &p0, &pp);
        if (d_dy) {
            vt__sobel_y_row(pm, pp, src->w, o);
        } else {
            vt__sobel_x_row(pm, p0, pp, src->w, o);
        }
    }
    return VT_OK;
}

vt_status vt_sobel_x(const vt_image_u8 *src, vt_image_s16 *dst)
{
    return vt__sobel(src, dst, 0);
}

vt_status vt_sobel_y(const vt_image_u8 *src, vt_image_s16 *dst)
{
    return vt__sobel(src, dst, 1);
}

/* The output pixels [x0, x1) x [y0, y1) of one pyramid step (arguments checked).
 * Vertical pass into one row of column sums (<= 16*255, fits uint16), then the
 * horizontal pass; 15 multiply-adds per output pixel instead of 25. The row lives
 * on the stack: 2*VT_MAX_WIDTH bytes. Only the columns [cl, ch) are summed: output
 * column ox reads source columns 2 ox - 2 .. 2 ox + 2 reflected (reflect-101), and
 * with x0 <= ox < x1 those land in [max(0, 2 x0 - 2), min(w, 2 x1 + 1)): a column
 * left of 0 reflects to 1 or 2 (< 3 <= 2 x1 + 1, as x1 >= 1), one at w or w + 1
 * (only when 2 ox + 2 >= w) to w - 2 or w - 3 (>= 2 ox - 2 >= 2 x0 - 2); a frame
 * of 1 or 2 columns has x0 = 0, so cl = 0. Rows read likewise, through r[]. */
/* One output pixel of the horizontal pass at source column cx, the column sums
 * reflected at the borders (reflect-101). */
static uint8_t vt__pyr_border(const uint16_t *col, int32_t w, int32_t cx, const int32_t *k)
{
    int32_t i, acc = 0;
    for (i = 0; i < 5; ++i) {
        acc += k[i] * col[vt__reflect101(cx + i - 2, w)];
    }
    return (uint8_t)((acc + 128) >> 8);
}

static void vt__pyr_rect(const vt_image_u8 *src, vt_image_u8_mut *dst, int32_t x0, int32_t y0,
                         int32_t x1, int32_t y1)
{
    uint16_t col[VT_MAX_WIDTH];
    static const int32_t k[5] = {1, 4, 6, 4, 1};
    const int32_t w = src->w, h = src->h;
    const int32_t cl = 2 * x0 - 2 > 0 ? 2 * x0 - 2 : 0;
    const int32_t ch = 2 * x1 + 1 < w ? 2 * x1 + 1 : w;
    int32_t ox, oy, i;
    for (oy = y0; oy < y1; ++oy) {
        const uint8_t *r[5];
        int32_t x;
        for (i = 0; i < 5; ++i) {
            r[i] = src->px + (size_t)vt__reflect101(2 * oy + i - 2, h) * (size_t)src->stride;
        }
        x = cl;
#if VT__SSE2
        for (; x + 8 <= ch; x += 8) { /* <= 16 * 255: uint16 lanes */
            __m128i v = _mm_add_epi16(_mm_add_epi16(vt__ld8(r[0] + x), vt__ld8(r[4] + x)),
                                      _mm_slli_epi16(_mm_add_epi16(vt__ld8(r[1] + x), vt__ld8(r[3] + x)), 2));
            __m128i c2 = vt__ld8(r[2] + x);
            v = _mm_add_epi16(v, _mm_add_epi16(_mm_slli_epi16(c2, 2), _mm_slli_epi16(c2, 1)));
            _mm_storeu_si128((__m128i *)(void *)(col + x), v);
        }
#endif
        for (; x < ch; ++x) {
            col[x] = (uint16_t)(r[0][x] + 4 * r[1][x] + 6 * r[2][x] + 4 * r[3][x] + r[4][x]);
        }
        {
            /* acc <= 256*255: round half up, no saturation needed. The interior
             * columns [ia, ib) (2 ox - 2 >= 0, 2 ox + 2 < w) need no reflection, so
             * their loop has no border test. */
            uint8_t *o = dst->px + (size_t)oy * (size_t)dst->stride;
            const int32_t ia = x0 > 1 ? x0 : 1;
            const int32_t ib = (w - 1) / 2 < x1 ? ((w - 1) / 2 > ia ? (w - 1) / 2 : ia) : x1;
            for (ox = x0; ox < x1 && ox < ia; ++ox) {
                o[ox] = vt__pyr_border(col, w, 2 * ox, k);
            }
            for (ox = ia; ox < ib; ++ox) {
                const uint16_t *c = col + 2 * ox - 2;
                int32_t acc = c[0] + 4 * c[1] + 6 * c[2] + 4 * c[3] + c[4];
                o[ox] = (uint8_t)((acc + 128) >> 8);
            }
            for (ox = ib > ia ? ib : ia; ox < x1; ++ox) {
                o[ox] = vt__pyr_border(col, w, 2 * ox, k);
            }
        }
    }
}

static vt_status vt__check_pyr(const vt_image_u8 *src, const vt_image_u8_mut *dst)
{
    return vt__check_src_out(src, dst != NULL && dst->px != NULL, dst != NULL ? dst->w : 0,
                             dst != NULL ? dst->h : 0, dst != NULL ? dst->stride : 0, 1);
}

vt_status vt_pyr_down(const vt_image_u8 *src, vt_image_u8_mut *dst)
{
    vt_status s = vt__check_pyr(src, dst);
    if (s != VT_OK) {
        return s;
    }
    vt__pyr_rect(src, dst, 0, 0, dst->w, dst->h);
    return VT_OK;
}

vt_status vt_pyr_down_rect(const vt_image_u8 *src, vt_image_u8_mut *dst, int32_t x0, int32_t y0,
                           int32_t x1, int32_t y1)
{
    vt_status s = vt__check_pyr(src, dst);
    if (s != VT_OK) {
        return s;
    }
    /* Compared one by one, so no sum of two arguments can overflow. */
    if (x0 < 0 || y0 < 0 || x1 < x0 || y1 < y0 || x1 > dst->w || y1 > dst->h) {
        return VT_E_ARG;
    }
    vt__pyr_rect(src, dst, x0, y0, x1, y1);
    return VT_OK;
}

vt_status vt_resize_area(const vt_image_u8 *src, vt_image_u8_mut *dst)
{
    uint32_t acc[VT_MAX_WIDTH];
    int32_t W, H, w, h, x, y, i, j;
    uint64_t d, m, half;
    vt_status s = vt_image_u8_check(src);
    if (s != VT_OK) {
        return s;
    }
    if (dst == NULL || dst->px == NULL) {
        return VT_E_ARG;
    }
    if (dst->w < 1 || dst->h < 1 || dst->w > src->w || dst->h > src->h || dst->stride < dst->w) {
        return VT_E_SIZE;
    }
    W = src->w;
    H = src->h;
    w = dst->w;
    h = dst->h;
    d = (uint64_t)W * (uint64_t)H;
    m = (((uint64_t)1 << 52) + d - 1) / d;
    half = d / 2;
    for (y = 0; y < h; ++y) {
        /* the input rows overlapping [y H, (y + 1) H) of the row axis (units of 1/h row) */
        const int64_t r0 = (int64_t)y * H, r1 = r0 + H;
        for (x = 0; x < w; ++x) {
            acc[x] = 0;
        }
        for (j = (int32_t)(r0 / h); (int64_t)j * h < r1; ++j) {
            const int64_t lo = (int64_t)j * h, hi = lo + h;
            const uint32_t wy = (uint32_t)((hi < r1 ? hi : r1) - (lo > r0 ? lo : r0));
            const uint8_t *p = src->px + (size_t)j * (size_t)src->stride;
            /* input pixel i spans [i w, (i + 1) w): within output x = i w / W, or split at
             * (x + 1) W with the next (an input pixel is no wider than an output one) */
            int64_t edge = W; /* (x + 1) W */
            x = 0;
            for (i = 0; i < W; ++i) {
                const int64_t a = (int64_t)i * w, b = a + w;
                const uint32_t v = wy * p[i];
                if (b <= edge) {
                    acc[x] += v * (uint32_t)w;
                    if (b == edge) {
                        ++x;
                        edge += W;
                    }
                } else {
                    acc[x] += v * (uint32_t)(edge - a);
                    acc[x + 1] += v * (uint32_t)(b - edge);
                    ++x;
                    edge += W;
                }
            }
        }
        {
            uint8_t *o = dst->px + (size_t)y * (size_t)dst->stride;
            for (x = 0; x < w; ++x) {
                o[x] = (uint8_t)((((uint64_t)acc[x] + half) * m) >> 52);
            }
        }
    }
    return VT_OK;
}

vt_status vt_integral(const vt_image_u8 *src, vt_image_u32 *dst)
{
    int32_t x, y, w, h;
    vt_status s = vt__check_src_out(src, dst != NULL && dst->px != NULL, dst != NULL ? dst->w : 0,
                                    dst != NULL ? dst->h : 0, dst != NULL ? dst->stride : 0, 0);
    if (s != VT_OK) {
        return s;
    }
    w = src->w;
    h = src->h;
    for (x = 0; x <= w; ++x) {
        dst->px[x] = 0;
    }
    for (y = 0; y < h; ++y) {
        const uint8_t *p = src->px + (size_t)y * (size_t)src->stride;
        const uint32_t *above = dst->px + (size_t)y * (size_t)dst->stride;
        uint32_t *o = dst->px + (size_t)(y + 1) * (size_t)dst->stride;
        uint32_t run = 0;
        o[0] = 0;
        for (x = 0; x < w; ++x) {
            run += p[x];
            o[x + 1] = above[x + 1] + run;
        }
    }
    return VT_OK;
}

vt_status vt_box_sum(const vt_image_u32 *ii, int32_t x, int32_t y, int32_t w, int32_t h,
                     uint32_t *sum)
{
    const uint32_t *r0, *r1;
    if (ii == NULL || ii->px == NULL || sum == NULL) {
        return VT_E_ARG;
    }
    if (ii->w < 2 || ii->h < 2 || ii->w > VT_MAX_WIDTH + 1 || ii->h > VT_MAX_HEIGHT + 1 ||
        ii->stride < ii->w) {
        return VT_E_SIZE;
    }
    /* Written so no sum of two int32 arguments can overflow. */
    if (x < 0 || y < 0 || w < 1 || h < 1 || x > ii->w - 1 - w || y > ii->h - 1 - h) {
        return VT_E_SIZE;
    }
    r0 = ii->px + (size_t)y * (size_t)ii->stride;
    r1 = ii->px + (size_t)(y + h) * (size_t)ii->stride;
    /* Unsigned wrap-around in the middle cancels exactly: the result is < 2^32. */
    *sum = r1[x + w] - r1[x] - r0[x + w] + r0[x];
    return VT_OK;
}

/* Shared checks for the two-patch functions. */
static vt_status vt__check_pair(const vt_image_u8 *a, const vt_image_u8 *b)
{
    vt_status s = vt_image_u8_check(a);
    s = s != VT_OK ? s : vt_image_u8_check(b);
    if (s != VT_OK) {
        return s;
    }
    return (a->w == b->w && a->h == b->h) ? VT_OK : VT_E_SIZE;
}

/* Largest k with v << 2k < 2^62 (v > 0, v < 2^62). */
static int vt__norm_shift(uint64_t v)
{
    int k = 0;
    while ((v << 2) < ((uint64_t)1 << 62)) {
        v <<= 2;
        ++k;
    }
    return k;
}

int vt__ncc_norm_of(uint64_t n, uint64_t s, uint64_t ss, vt__ncc_norm *out)
{
    /* n <= 2^16 and each sum of products < 2^32: below 2^48, exact. */
    int64_t v = (int64_t)(n * ss) - (int64_t)(s * s);
    if (v <= 0) {
        return 0;
    }
    /* sqrt(v) = root / 2^k with root in [2^30, 2^31): ~30 significant bits. */
    out->k = vt__norm_shift((uint64_t)v);
    out->root = vt_isqrt_u64((uint64_t)v << (2 * out->k));
    return 1;
}

vt_status vt__ncc_from_norms(uint64_t n, uint64_t sa, uint64_t sb, uint64_t sab, const vt__ncc_norm *a,
                             const vt__ncc_norm *b, vt_q14 *ncc)
{
    int64_t cov = (int64_t)(n * sab) - (int64_t)(sa * sb), q;
    uint64_t p = (a->root * b->root) >> 14; /* sqrt(va*vb) * 2^(ka+kb) / 2^14, >= 2^46 */
    /* |cov| * 2^(ka+kb) <= sqrt(va*vb) * 2^(ka+kb) < 2^62 by Cauchy-Schwarz. */
    vt_status s = vt_div_round_s64(cov * ((int64_t)1 << (a->k + b->k)), (int64_t)p, &q);
    if (s != VT_OK) {
        return s;
    }
    /* The floored square roots can push |q| a hair past 1.0. */
    *ncc = (vt_q14)(q > VT_Q14_ONE ? VT_Q14_ONE : (q < -VT_Q14_ONE ? -VT_Q14_ONE : q));
    return VT_OK;
}

/* Both patches normalised, then correlated; VT_E_SINGULAR for a flat one. */
static vt_status vt__ncc_from_sums(uint64_t n, uint64_t sa, uint64_t sb, uint64_t saa, uint64_t sbb,
                                   uint64_t sab, vt_q14 *ncc)
{
    vt__ncc_norm na, nb;
    if (!vt__ncc_norm_of(n, sa, saa, &na) || !vt__ncc_norm_of(n, sb, sbb, &nb)) {
        return VT_E_SINGULAR;
    }
    return vt__ncc_from_norms(n, sa, sb, sab, &na, &nb, ncc);
}

vt_status vt_ncc_u8(const vt_image_u8 *a, const vt_image_u8 *b, vt_q14 *ncc)
{
    uint64_t sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    int32_t x, y;
    vt_status s;
    if (ncc == NULL) {
        return VT_E_ARG;
    }
    s = vt__check_pair(a, b);
    if (s != VT_OK) {
        return s;
    }
    if ((int64_t)a->w * a->h > VT_MAX_PATCH_PIXELS) {
        return VT_E_SIZE;
    }
    for (y = 0; y < a->h; ++y) {
        const uint8_t *pa = a->px + (size_t)y * (size_t)a->stride;
        const uint8_t *pb = b->px + (size_t)y * (size_t)b->stride;
        for (x = 0; x < a->w; ++x) {
            uint32_t u = pa[x], v = pb[x];
            sa += u;
            sb += v;
            saa += u * u;
            sbb += v * v;
            sab += u * v;
        }
    }
    return vt__ncc_from_sums((uint64_t)a->w * (uint64_t)a->h, sa, sb, saa, sbb, sab, ncc);
}

vt_status vt_sad_u8(const vt_image_u8 *a, const vt_image_u8 *b, uint32_t *sad)
{
    int32_t x, y;
    uint32_t acc = 0;
    vt_status s;
    if (sad == NULL) {
        return VT_E_ARG;
    }
    s = vt__check_pair(a, b);
    if (s != VT_OK) {
        return s;
    }
    for (y = 0; y < a->h; ++y) {
        const uint8_t *pa = a->px + (size_t)y * (size_t)a->stride;
        const uint8_t *pb = b->px + (size_t)y * (size_t)b->stride;
        for (x = 0; x < a->w; ++x) {
            acc += (uint32_t)(pa[x] > pb[x] ? pa[x] - pb[x] : pb[x] - pa[x]);
        }
    }
    *sad = acc;
    return VT_OK;
}
