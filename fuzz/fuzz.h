/* fuzz.h -- the framework every libFuzzer harness in fuzz/ shares (issue 11,
 * item 1): a reader that turns the fuzz bytes into arguments, with edge values
 * (0, -1, the capacities and one past them, INT32_MIN/MAX) as likely as random
 * ones, and image views whose size, stride (< w included) and pixels all come
 * from the bytes. Harness code is test code: it may use malloc (the core may
 * not); every view is a heap block of exactly the bytes it spans, so ASan sees
 * any read or write past it.
 *
 * A harness is one file fuzz/fuzz_NAME.c defining
 *     int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
 * that opens `fz f = fz_open(data, size)`, draws arguments, calls the core, and
 * calls fz_close(&f) to free the views; fuzz/fuzz.mk builds every fuzz_*.c and
 * fuzz/corpus/NAME/ holds its seeds. Nothing else to register. */
#ifndef VT_FUZZ_H
#define VT_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "vehtrack/config.h"
#include "vehtrack/geometry.h"
#include "vehtrack/image.h"
#include "vehtrack/road.h"
#include "vehtrack/status.h"

#define FZ_MAX_BLOCKS 16
/* Largest pixel block a view may span: keeps one input fast (a 1920-wide row is
 * fine, a full frame would slow the fuzzer 1000-fold). */
#define FZ_MAX_BYTES (1u << 14)

typedef struct {
    const uint8_t *d;
    size_t n;
    void *blocks[FZ_MAX_BLOCKS];
    int n_blocks;
} fz;

static inline fz fz_open(const uint8_t *d, size_t n)
{
    fz f;
    memset(&f, 0, sizeof f);
    f.d = d;
    f.n = n;
    return f;
}

static inline void fz_close(fz *f)
{
    int i;
    for (i = 0; i < f->n_blocks; i++) {
        free(f->blocks[i]);
    }
    f->n_blocks = 0;
}

/* An exact-size heap block (at least 1 byte), freed by fz_close. */
static inline void *fz_alloc(fz *f, size_t bytes)
{
    void *p;
    if (f->n_blocks == FZ_MAX_BLOCKS) {
        return NULL;
    }
    p = malloc(bytes ? bytes : 1);
    if (p != NULL) {
        f->blocks[f->n_blocks++] = p;
    }
    return p;
}

static inline uint8_t fz_u8(fz *f)
{
    uint8_t v;
    if (f->n == 0) {
        return 0;
    }
    v = f->d[0];
    f->d++;
    f->n--;
    return v;
}

static inline uint32_t fz_u32(fz *f)
{
    uint32_t v = fz_u8(f);
    v |= (uint32_t)fz_u8(f) << 8;
    v |= (uint32_t)fz_u8(f) << 16;
    return v | (uint32_t)fz_u8(f) << 24;
}

static inline int32_t fz_raw_i32(fz *f)
{
    uint32_t u = fz_u32(f);
    return u <= (uint32_t)INT32_MAX ? (int32_t)u : -(int32_t)(~u) - 1;
}

/* An int32 in [lo, hi] (lo <= hi), uniform enough. */
static inline int32_t fz_range(fz *f, int32_t lo, int32_t hi)
{
    uint32_t span = (uint32_t)((int64_t)hi - lo) + 1u;
    uint32_t r = span == 0u ? fz_u32(f) : (span <= 256u ? fz_u8(f) : fz_u32(f)) % span;
    return (int32_t)((int64_t)lo + r);
}

/* A value that is often an edge of `cap`'s domain: one selector byte picks 0, 1,
 * -1, cap-1, cap, cap+1, INT32_MIN, INT32_MAX, a small value in [0, cap]
 * (most likely), or 4 raw bytes. */
static inline int32_t fz_edge(fz *f, int32_t cap)
{
    uint8_t k = fz_u8(f);
    cap = cap < 1 ? 1 : (cap == INT32_MAX ? INT32_MAX - 1 : cap); /* cap +- 1 stay in range */
    switch (k & 15u) {
    case 0: return 0;
    case 1: return 1;
    case 2: return -1;
    case 3: return cap - 1;
    case 4: return cap;
    case 5: return cap + 1;
    case 6: return INT32_MIN;
    case 7: return INT32_MAX;
    case 8: return fz_raw_i32(f);
    default: return fz_range(f, 0, cap);
    }
}

/* base + an offset in [lo, hi], clamped to int32 (so edges stay edges). */
static inline int32_t fz_near(fz *f, int32_t base, int32_t lo, int32_t hi)
{
    int64_t v = (int64_t)base + fz_range(f, lo, hi);
    return (int32_t)(v > INT32_MAX ? INT32_MAX : (v < INT32_MIN ? INT32_MIN : v));
}

/* A size: mostly 1..small (fast inputs), sometimes an edge of 1..cap. */
static inline int32_t fz_size(fz *f, int32_t small, int32_t cap)
{
    uint8_t k = fz_u8(f);
    if (k < 200) {
        return 1 + (int32_t)(k % (uint8_t)(small > 255 ? 255 : small));
    }
    return fz_edge(f, cap);
}

/* Fill w x h pixels (row stride `stride`) from the bytes: raw bytes tiled, a
 * constant, a ramp, or dark and bright rectangles on a background (so the
 * edge-based stages have something to find). */
static inline void fz_fill(fz *f, uint8_t *px, int32_t w, int32_t h, int32_t stride)
{
    int32_t x, y, i, n;
    uint8_t mode = fz_u8(f) & 3u;
    if (mode == 0) {
        size_t len = f->n < 4096 ? f->n : 4096, k = 0;
        for (y = 0; y < h; y++) {
            for (x = 0; x < w; x++) {
                px[(size_t)y * (size_t)stride + (size_t)x] = len ? f->d[k] : 0;
                k = len ? (k + 1) % len : 0;
            }
        }
        f->d += len;
        f->n -= len;
        return;
    }
    {
        uint8_t bg = fz_u8(f), gx = fz_u8(f), gy = fz_u8(f);
        for (y = 0; y < h; y++) {
            for (x = 0; x < w; x++) {
                px[(size_t)y * (size_t)stride + (size_t)x] =
                    mode == 1 ? bg : (uint8_t)(bg + (uint8_t)((uint32_t)x * gx / 16u) + (uint8_t)((uint32_t)y * gy / 16u));
            }
        }
    }
    if (mode == 3) {
        n = fz_u8(f) & 15;
        for (i = 0; i < n; i++) {
            int32_t x0 = fz_range(f, 0, w - 1), y0 = fz_range(f, 0, h - 1);
            int32_t x1 = x0 + fz_range(f, 0, w), y1 = y0 + fz_range(f, 0, h);
            uint8_t v = fz_u8(f);
            for (y = y0; y < y1 && y < h; y++) {
                for (x = x0; x < x1 && x < w; x++) {
                    px[(size_t)y * (size_t)stride + (size_t)x] = v;
                }
            }
        }
    }
}

/* Geometry of a view: size and stride from the bytes (stride < w, negative and
 * huge ones included), within [1, small] x [1, small] most of the time. Returns
 * the elements the view spans, (h-1)*stride + w, or 0 when the geometry is
 * invalid or too large to allocate (then the caller points px at a 1-element
 * block: a correct core rejects the view before any access). */
static inline size_t fz_geom_small(fz *f, int32_t small, int32_t maxw, int32_t maxh, int32_t *w,
                                   int32_t *h, int32_t *stride, size_t elem)
{
    uint8_t k;
    *w = fz_size(f, small, maxw);
    *h = fz_size(f, small, maxh);
    k = fz_u8(f);
    {
        int64_t st = k < 160 ? *w : (k < 220 ? (int64_t)*w + (k & 15) :
                                    (k < 240 ? (int64_t)*w - 1 - (k & 3) : fz_raw_i32(f)));
        *stride = (int32_t)(st > INT32_MAX ? INT32_MAX : (st < INT32_MIN ? INT32_MIN : st));
    }
    if (*w < 1 || *h < 1 || *stride < *w || *w > maxw || *h > maxh) {
        return 0;
    }
    {
        uint64_t span = (uint64_t)(*h - 1) * (uint64_t)*stride + (uint64_t)*w;
        if (span * elem > FZ_MAX_BYTES) {
            /* Too big for a fast input: keep the width and stride, cut rows. */
            uint64_t rows;
            if ((uint64_t)*w * elem > FZ_MAX_BYTES) { /* cannot happen: w <= 4096 */
                *w = (int32_t)(FZ_MAX_BYTES / elem);
                *stride = *w;
            }
            rows = (FZ_MAX_BYTES / elem - (uint64_t)*w) / (uint64_t)*stride + 1u;
            *h = (int32_t)(rows < (uint64_t)*h ? rows : (uint64_t)*h);
            span = (uint64_t)(*h - 1) * (uint64_t)*stride + (uint64_t)*w;
        }
        return (size_t)span;
    }
}

/* fz_geom_small with the usual 1..48 sizes. */
static inline size_t fz_geom(fz *f, int32_t maxw, int32_t maxh, int32_t *w, int32_t *h,
                             int32_t *stride, size_t elem)
{
    return fz_geom_small(f, 48, maxw, maxh, w, h, stride, elem);
}

/* A read-only 8-bit view from the bytes (px NULL sometimes), mostly 1..small
 * square (edges of 1..max sometimes): a harness whose stage costs much per
 * pixel passes a smaller `small`, never a smaller max (a view the core accepts
 * must be a view the harness allocated). */
static inline vt_image_u8 fz_image_u8_small(fz *f, int32_t small, int32_t maxw, int32_t maxh)
{
    vt_image_u8 v;
    int32_t w, h, stride;
    size_t n = fz_geom_small(f, small, maxw, maxh, &w, &h, &stride, 1);
    uint8_t *px = (uint8_t *)fz_alloc(f, n);
    if (px != NULL && n > 0) {
        fz_fill(f, px, w, h, stride);
    }
    v.px = (fz_u8(f) == 0xFFu) ? NULL : px;
    v.w = w;
    v.h = h;
    v.stride = stride;
    return v;
}

/* A read-only 8-bit view, mostly 1..48 square. */
static inline vt_image_u8 fz_image_u8(fz *f, int32_t maxw, int32_t maxh)
{
    return fz_image_u8_small(f, 48, maxw, maxh);
}

/* A writable output view of `elem`-byte pixels, exactly spanning its geometry. */
static inline void *fz_out_view(fz *f, int32_t maxw, int32_t maxh, size_t elem, int32_t *w,
                                int32_t *h, int32_t *stride)
{
    size_t n = fz_geom(f, maxw, maxh, w, h, stride, elem);
    void *px = fz_alloc(f, n * elem);
    return fz_u8(f) == 0xFFu ? NULL : px;
}

/* Every public function returns a vt_status in its enum's range. */
static inline void fz_status(vt_status s)
{
    if (s != VT_OK && s != VT_E_ARG && s != VT_E_SIZE && s != VT_E_CAPACITY &&
        s != VT_E_SINGULAR) {
        abort();
    }
}

/* Overwrite a few int32 fields of a configuration struct with edge or nearby
 * values: the configuration is mostly valid, so the stage behind its check is
 * reached, and sometimes each field sits on or past the edge of its domain. */
static inline void fz_mutate_i32s(fz *f, void *cfg, size_t bytes)
{
    int32_t n = (int32_t)(bytes / 4), k, i, v;
    uint8_t *p = (uint8_t *)cfg;
    k = fz_u8(f) & 7;
    for (i = 0; i < k && n > 0; i++) {
        int32_t idx = fz_range(f, 0, n - 1);
        uint8_t how = fz_u8(f);
        memcpy(&v, p + (size_t)idx * 4u, 4);
        if (how < 128) {
            v = (int32_t)((int64_t)v + (int8_t)fz_u8(f)); /* near the current value */
            if (v < -100000 || v > 100000) {
                v = 0;
            }
        } else {
            v = fz_edge(f, v > 0 ? v : 1);
        }
        memcpy(p + (size_t)idx * 4u, &v, 4);
    }
}

/* A box near a w x h frame: corner in [-4, w] x [-4, h], right / bottom within
 * -1 .. span_w / span_h of it (inverted boxes included). */
static inline vt_box fz_box_near(fz *f, int32_t w, int32_t h, int32_t span_w, int32_t span_h)
{
    vt_box b;
    b.left = fz_range(f, -4, w);
    b.top = fz_range(f, -4, h);
    b.right = fz_near(f, b.left, -1, span_w);
    b.bottom = fz_near(f, b.top, -1, span_h);
    return b;
}

/* A box of edge values (0, +-1, the frame's size, INT32 extremes...). */
static inline vt_box fz_box_edge(fz *f, int32_t w, int32_t h)
{
    vt_box b;
    b.left = fz_edge(f, w);
    b.top = fz_edge(f, h);
    b.right = fz_edge(f, w);
    b.bottom = fz_edge(f, h);
    return b;
}

/* A road area for a w x h frame: mostly plausible (a trapezoid-free band with
 * the lane's middle half), sometimes every field from the bytes (rows out of
 * the frame, crossed boundaries, a height not the frame's, valid not 0/1). */
static inline void fz_road(fz *f, vt_road_area *road, int32_t w, int32_t h)
{
    int32_t y;
    uint8_t plausible = fz_u8(f) < 200;
    w = w > 0 && w <= VT_MAX_WIDTH ? w : 1;
    h = h > 0 && h <= VT_MAX_HEIGHT ? h : 1;
    road->valid = plausible ? 1 : fz_edge(f, 1);
    road->height = plausible ? h : fz_edge(f, h);
    road->y_top = plausible ? fz_range(f, 0, h - 1) : fz_edge(f, h);
    road->y_bottom = plausible ? fz_range(f, road->y_top, h - 1) : fz_edge(f, h);
    if (plausible) {
        for (y = 0; y < VT_MAX_HEIGHT; y++) {
            road->x_left[y] = (int16_t)(w / 4);
            road->x_right[y] = (int16_t)(w - 1 - w / 4);
            road->lane_width[y] = (int16_t)(w / 2);
        }
        return;
    }
    {
        /* Three values repeated: per-row noise would cost 3 * VT_MAX_HEIGHT draws. */
        int16_t l = (int16_t)fz_raw_i32(f), r = (int16_t)fz_raw_i32(f), lw = (int16_t)fz_raw_i32(f);
        for (y = 0; y < VT_MAX_HEIGHT; y++) {
            road->x_left[y] = l;
            road->x_right[y] = r;
            road->lane_width[y] = lw;
        }
    }
}

#define FZ_ASSERT(c) \
    do {             \
        if (!(c)) {  \
            abort(); \
        }            \
    } while (0)

#endif /* VT_FUZZ_H */
