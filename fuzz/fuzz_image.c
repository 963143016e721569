/* fuzz_image.c -- the pixel primitives of vehtrack/image.h (thesis sec. 2.4,
 * IVVI paper): [-1 0 1], Sobel x/y, pyramid (whole or a rectangle of it),
 * the area downscale (against a plain per-pixel sum and division here, for sources up
 * to 64 K pixels), integral + box sums, NCC, SAD, the
 * view check. Sizes, strides and NULLs come from the bytes; outputs are exact
 * heap blocks (ASan sees any write past them); a successful call is checked
 * against the documented bounds of its output. */
#include "fuzz.h"
#include "vehtrack/image.h"

static void grad(fz *f, const vt_image_u8 *src, int op)
{
    vt_image_s16 dst;
    vt_status s;
    int32_t x, y, lim = op == 0 ? 255 : 1020;
    if (fz_u8(f) < 200 && src->w > 0 && src->h > 0 && src->w <= VT_MAX_WIDTH &&
        src->h <= VT_MAX_HEIGHT) { /* mostly the matching size, so the filter runs */
        dst.w = src->w;
        dst.h = src->h;
        dst.stride = src->w + (fz_u8(f) & 3);
        dst.px = (int16_t *)fz_alloc(f, ((size_t)(dst.h - 1) * (size_t)dst.stride + (size_t)dst.w) * 2u);
    } else {
        dst.px = (int16_t *)fz_out_view(f, VT_MAX_WIDTH, VT_MAX_HEIGHT, 2, &dst.w, &dst.h, &dst.stride);
    }
    s = op == 0 ? vt_filter_h101(src, &dst) : (op == 1 ? vt_sobel_x(src, &dst) : vt_sobel_y(src, &dst));
    fz_status(s);
    if (s == VT_OK) {
        for (y = 0; y < dst.h; y++) {
            for (x = 0; x < dst.w; x++) {
                int16_t v = dst.px[(size_t)y * (size_t)dst.stride + (size_t)x];
                FZ_ASSERT(v >= -lim && v <= lim);
            }
        }
    }
}

static void pyr(fz *f, const vt_image_u8 *src)
{
    vt_image_u8_mut dst;
    int own = 0; /* dst is the exact level-size block (stride = w) */
    if (fz_u8(f) < 200 && src->w > 0 && src->h > 0) {
        dst.w = (int32_t)(((int64_t)src->w + 1) / 2);
        dst.h = (int32_t)(((int64_t)src->h + 1) / 2);
        dst.stride = dst.w;
        dst.px = (src->w <= VT_MAX_WIDTH && src->h <= VT_MAX_HEIGHT)
                     ? (uint8_t *)fz_alloc(f, (size_t)dst.w * (size_t)dst.h) : NULL;
        own = dst.px != NULL;
    } else {
        dst.px = (uint8_t *)fz_out_view(f, VT_MAX_WIDTH, VT_MAX_HEIGHT, 1, &dst.w, &dst.h, &dst.stride);
    }
    if (fz_u8(f) < 128) {
        fz_status(vt_pyr_down(src, &dst));
    } else { /* a rectangle of the level image (plausible, or any edge values) */
        int32_t x0, y0, x1, y1, x, y, plain = fz_u8(f) < 200;
        vt_status s;
        if (plain) {
            x0 = fz_range(f, 0, dst.w);
            x1 = fz_range(f, x0, dst.w);
            y0 = fz_range(f, 0, dst.h);
            y1 = fz_range(f, y0, dst.h);
        } else {
            x0 = fz_edge(f, dst.w);
            x1 = fz_edge(f, dst.w);
            y0 = fz_edge(f, dst.h);
            y1 = fz_edge(f, dst.h);
        }
        if (own) {
            memset(dst.px, 0xA5, (size_t)dst.w * (size_t)dst.h);
        }
        s = vt_pyr_down_rect(src, &dst, x0, y0, x1, y1);
        fz_status(s);
        if (s == VT_OK && own) { /* image.h: only the pixels inside the rectangle are written */
            for (y = 0; y < dst.h; y++) {
                for (x = 0; x < dst.w; x++) {
                    if (x < x0 || x >= x1 || y < y0 || y >= y1) {
                        FZ_ASSERT(dst.px[(size_t)y * (size_t)dst.stride + (size_t)x] == 0xA5);
                    }
                }
            }
        }
    }
}

static void integral(fz *f, const vt_image_u8 *src)
{
    vt_image_u32 ii;
    vt_status s;
    int i;
    if (fz_u8(f) < 200 && src->w > 0 && src->h > 0 && src->w <= VT_MAX_WIDTH && src->h <= VT_MAX_HEIGHT) {
        ii.w = src->w + 1;
        ii.h = src->h + 1;
        ii.stride = ii.w + (fz_u8(f) & 1);
        ii.px = (uint32_t *)fz_alloc(f, ((size_t)(ii.h - 1) * (size_t)ii.stride + (size_t)ii.w) * 4u);
    } else {
        ii.px = (uint32_t *)fz_out_view(f, VT_MAX_WIDTH + 1, VT_MAX_HEIGHT + 1, 4, &ii.w, &ii.h, &ii.stride);
    }
    s = vt_integral(src, &ii);
    fz_status(s);
    for (i = 0; i < 8; i++) {
        uint32_t sum = 0;
        int32_t x = fz_edge(f, ii.w), y = fz_edge(f, ii.h), w = fz_edge(f, ii.w), h = fz_edge(f, ii.h);
        vt_status sb = vt_box_sum(s == VT_OK ? &ii : (fz_u8(f) & 1 ? NULL : &ii), x, y, w, h,
                                  fz_u8(f) == 0xFF ? NULL : &sum);
        fz_status(sb);
        if (s == VT_OK && sb == VT_OK) {
            FZ_ASSERT(sum <= (uint32_t)w * (uint32_t)h * 255u);
        }
    }
}

static void patches(fz *f, const vt_image_u8 *a)
{
    vt_image_u8 b;
    vt_q14 ncc = 0;
    uint32_t sad = 0;
    vt_status s;
    b = fz_image_u8(f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    if (fz_u8(f) < 128) { /* the same view twice: equal sizes, so both are compared */
        b = *a;
    }
    s = vt_ncc_u8(a, &b, fz_u8(f) == 0xFF ? NULL : &ncc);
    fz_status(s);
    if (s == VT_OK) {
        FZ_ASSERT(ncc >= -VT_Q14_ONE && ncc <= VT_Q14_ONE);
    }
    fz_status(vt_sad_u8(a, &b, fz_u8(f) == 0xFF ? NULL : &sad));
}

static int64_t resize_overlap(int64_t a0, int64_t a1, int64_t b0, int64_t b1)
{
    int64_t lo = a0 > b0 ? a0 : b0, hi = a1 < b1 ? a1 : b1;
    return hi > lo ? hi - lo : 0;
}

static void resize(fz *f, const vt_image_u8 *src)
{
    vt_image_u8_mut dst;
    vt_status s;
    int own = 0;
    if (fz_u8(f) < 220 && src->w > 0 && src->h > 0 && src->w <= VT_MAX_WIDTH && src->h <= VT_MAX_HEIGHT) {
        dst.w = fz_range(f, 1, src->w);
        dst.h = fz_range(f, 1, src->h);
        dst.stride = dst.w + (fz_u8(f) & 3);
        dst.px = (uint8_t *)fz_alloc(f, (size_t)(dst.h - 1) * (size_t)dst.stride + (size_t)dst.w);
        own = 1;
    } else {
        dst.px = (uint8_t *)fz_out_view(f, VT_MAX_WIDTH, VT_MAX_HEIGHT, 1, &dst.w, &dst.h, &dst.stride);
    }
    s = vt_resize_area(src, &dst);
    fz_status(s);
    if (s == VT_OK && own && (int64_t)src->w * src->h <= 65536) {
        const int64_t W = src->w, H = src->h, d = W * H;
        int32_t x, y, i, j;
        for (y = 0; y < dst.h; y++) {
            for (x = 0; x < dst.w; x++) {
                int64_t sum = 0;
                for (j = 0; j < src->h; j++) {
                    int64_t oy = resize_overlap((int64_t)y * H, (int64_t)(y + 1) * H, (int64_t)j * dst.h,
                                                (int64_t)(j + 1) * dst.h);
                    for (i = 0; oy > 0 && i < src->w; i++) {
                        sum += oy * resize_overlap((int64_t)x * W, (int64_t)(x + 1) * W, (int64_t)i * dst.w,
                                                   (int64_t)(i + 1) * dst.w) *
                               src->px[(size_t)j * (size_t)src->stride + (size_t)i];
                    }
                }
                FZ_ASSERT(dst.px[(size_t)y * (size_t)dst.stride + (size_t)x] == (uint8_t)((sum + d / 2) / d));
            }
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t op = fz_u8(&f);
    vt_image_u8 src = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    fz_status(vt_image_u8_check(fz_u8(&f) == 0xFF ? NULL : &src));
    switch (op % 7u) {
    case 0: grad(&f, &src, 0); break;
    case 1: grad(&f, &src, 1); break;
    case 2: grad(&f, &src, 2); break;
    case 3: pyr(&f, &src); break;
    case 4: integral(&f, &src); break;
    case 5: resize(&f, &src); break;
    default: patches(&f, &src); break;
    }
    fz_close(&f);
    return 0;
}
