/* cnn.c -- the appearance stage as a small CNN detector: a CenterNet-style heat
 * map + box sides at stride 8 (the model's out_stride), replacing the sliding-window
 * classifier of the GIST paper sec. III for full-frame hypotheses. Quantised int8
 * weights, uint8 activations, int32 accumulators, per-channel requantisation; the
 * arithmetic is stated in cnn.h, pyvehtrack/reference/cnn.py is its bit-exact twin. */
#include <stddef.h>
#include <stdint.h>

#include "vehtrack/cnn.h"
#include "vehtrack/fixed.h"
#include "internal.h"

/* SSE2 (every x86-64) does the dot products 8 int16 pairs at a time (pmaddwd); every
 * other target, and builds with -DVT_NO_SIMD, take the portable loop. Both are exact:
 * integer sums in any order (vt__cnn_layer's bound). */
#if defined(__SSE2__) && !defined(VT_NO_SIMD)
#define VT_CNN_SSE2 1
#include <emmintrin.h>
#else
#define VT_CNN_SSE2 0
#endif
/* AVX2, where the CPU has it (asked at run time, so the library still runs on any
 * x86-64): two neighbouring output pixels share each widened weight vector and
 * sixteen int16 products go into one vpmaddwd. gcc and clang only (a per-function
 * target attribute); -DVT_NO_AVX2 keeps the SSE2 path, which `make test`'s gcc
 * sanitized suite runs. The same bits again: integer sums in any order. */
#if VT_CNN_SSE2 && defined(__x86_64__) && defined(__GNUC__) && !defined(VT_NO_AVX2)
#define VT_CNN_AVX2 1
#define VT__CNN_FIRST8_MAX_CH 32 /* vt__cnn_first8's weight pairs: 768 B of stack */
#include <immintrin.h>
#else
#define VT_CNN_AVX2 0
#endif
/* AVX-VNNI on top (Intel since Alder Lake, AMD since Zen 4): vpdpbusd sums four
 * uint8 x int8 products into each int32 lane with no widening and no saturation
 * (each product fits int16, the sum wraps only past int32, which cnn.h's bound
 * excludes): 32 products per instruction. Compilers that know the target: gcc 11,
 * clang 12 on. -DVT_NO_AVXVNNI keeps plain AVX2 (both VNNI kinds off: `make test`'s
 * clang sanitized suite); valgrind does not report the feature, so callgrind counts
 * the AVX2 path. */
#if VT_CNN_AVX2 && !defined(VT_NO_AVXVNNI) &&                                            \
    ((defined(__clang__) && __clang_major__ >= 12) || (!defined(__clang__) && __GNUC__ >= 11))
#define VT_CNN_VNNI 1
#include <cpuid.h>
#else
#define VT_CNN_VNNI 0
#endif
/* AVX-512 with VNNI on top of that (Intel servers since Cascade Lake, AMD since Zen 4):
 * 64 products per vpdpbusd and 32 registers, for the channels-in-lanes passes
 * (vt__cnn_cil_pass; a layer with cin not a multiple of 4 takes the pixel pairs below).
 * -DVT_NO_AVX512 keeps AVX-VNNI on 256 bits (`make test` runs the CNN tests once that
 * way); valgrind reports neither. */
#if VT_CNN_VNNI && !defined(VT_NO_AVX512)
#define VT_CNN_AVX512 1
#else
#define VT_CNN_AVX512 0
#endif

vt_status vt_cnn_check_model(const vt_cnn_model *m)
{
    int32_t i, c, prod = 1;
    if (m == NULL || m->n_layers < 1 || m->n_layers > VT_CNN_MAX_LAYERS || m->side_lut == NULL ||
        m->heat_scale_q16 < 1 || m->heat_scale_q16 > VT_CNN_HEAT_SCALE_MAX) {
        return VT_E_ARG;
    }
    for (i = 0; i < m->n_layers; ++i) {
        const vt_cnn_layer *L = &m->layer[i];
        int last = i == m->n_layers - 1;
        if ((L->ksize != 1 && L->ksize != 3) || (L->stride != 1 && L->stride != 2) ||
            (L->dilation != 1 && L->dilation != 2) || (L->ksize == 1 && L->dilation != 1) ||
            L->relu != (last ? 0 : 1) || L->cin < 1 || L->cin > VT_CNN_MAX_CH || L->cout < 1 ||
            L->cout > VT_CNN_MAX_CH || (last && L->cout != VT_CNN_OUT_CH) ||
            L->cin != (i == 0 ? 1 : m->layer[i - 1].cout) || L->w == NULL || L->bias == NULL ||
            L->mult == NULL || L->shift == NULL) {
            return VT_E_ARG;
        }
        for (c = 0; c < L->cout; ++c) {
            if (L->bias[c] < -VT_CNN_BIAS_MAX || L->bias[c] > VT_CNN_BIAS_MAX || L->mult[c] < 1 ||
                L->shift[c] < 1 || L->shift[c] > 62) {
                return VT_E_ARG;
            }
        }
        prod *= L->stride;
    }
    return prod == m->out_stride ? VT_OK : VT_E_ARG;
}

/* Checks shared by the size queries and the forward pass; sizes[i] = the bytes of
 * layer i's output, *gw, *gh the last layer's grid. */
static vt_status vt__cnn_plan(const vt_cnn_model *m, int32_t w, int32_t h, size_t *sizes,
                              int32_t *gw, int32_t *gh)
{
    int32_t i;
    vt_status s = vt_cnn_check_model(m);
    if (s != VT_OK) {
        return s;
    }
    if (w < 1 || h < 1 || w > VT_MAX_WIDTH || h > VT_MAX_HEIGHT) {
        return VT_E_SIZE;
    }
    for (i = 0; i < m->n_layers; ++i) {
        int32_t st = m->layer[i].stride;
        w = (w + st - 1) / st;
        h = (h + st - 1) / st;
        sizes[i] = (size_t)w * (size_t)h * (size_t)m->layer[i].cout;
    }
    *gw = w;
    *gh = h;
    return VT_OK;
}

/* The two ping-pong regions: *r0 the largest even-indexed, *r1 the largest
 * odd-indexed output of the layers before the last. */
static void vt__cnn_regions(const vt_cnn_model *m, const size_t *sizes, size_t *r0, size_t *r1)
{
    int32_t i;
    *r0 = 0;
    *r1 = 0;
    for (i = 0; i + 1 < m->n_layers; ++i) {
        size_t *r = (i & 1) ? r1 : r0;
        if (sizes[i] > *r) {
            *r = sizes[i];
        }
    }
}

vt_status vt_cnn_out_size(const vt_cnn_model *m, int32_t w, int32_t h, int32_t *gw, int32_t *gh)
{
    size_t sizes[VT_CNN_MAX_LAYERS];
    if (gw == NULL || gh == NULL) {
        return VT_E_ARG;
    }
    return vt__cnn_plan(m, w, h, sizes, gw, gh);
}

vt_status vt_cnn_work_bytes(const vt_cnn_model *m, int32_t w, int32_t h, size_t *bytes)
{
    size_t sizes[VT_CNN_MAX_LAYERS], r0, r1;
    int32_t gw, gh;
    vt_status s;
    if (bytes == NULL) {
        return VT_E_ARG;
    }
    s = vt__cnn_plan(m, w, h, sizes, &gw, &gh);
    if (s != VT_OK) {
        return s;
    }
    vt__cnn_regions(m, sizes, &r0, &r1);
    *bytes = r0 + r1;
    return VT_OK;
}

/* q = acc mult / 2^shift rounded half up (cnn.h), in int64; |acc| < 2^31 and
 * mult < 2^31, so the sum stays below 2^63. */
static int64_t vt__cnn_requant(int32_t acc, int32_t mult, int32_t shift)
{
    return vt__floor_shr64((int64_t)acc * mult + ((int64_t)1 << (shift - 1)), shift);
}

/* Requantise acc into output channel co of the pixel at o (relu: uint8; last: int8). */
static void vt__cnn_store(const vt_cnn_layer *L, int32_t acc, int32_t co, size_t o, uint8_t *out_u8,
                          int8_t *out_s8)
{
    int64_t q = vt__cnn_requant(acc, L->mult[co], L->shift[co]);
    if (out_s8 != NULL) {
        out_s8[o + (size_t)co] = (int8_t)(q < -128 ? -128 : (q > 127 ? 127 : q));
    } else {
        out_u8[o + (size_t)co] = (uint8_t)(q < 0 ? 0 : (q > 255 ? 255 : q));
    }
}

/* acc[j] = the sum over the nt taps of tlen[t] products of output channel j's
 * weights (w0 + j wtaps + woff[t]) and the input bytes (in + ioff[t]), j = 0..3.
 * Each input byte is loaded once for the four channels. */
static void vt__cnn_dot4(const int8_t *w0, size_t wtaps, const uint8_t *in, const size_t *ioff,
                         const size_t *woff, const int32_t *tlen, int32_t nt, int32_t *acc)
{
    const int8_t *w1 = w0 + wtaps, *w2 = w1 + wtaps, *w3 = w2 + wtaps;
    int32_t a0 = 0, a1 = 0, a2 = 0, a3 = 0, t, ci;
#if VT_CNN_SSE2
    /* int8 weights and uint8 inputs widened to int16: each pmaddwd lane is
     * x y + x' y', |.| <= 2 x 128 x 255, exact in int32 */
    const __m128i zero = _mm_setzero_si128();
    __m128i v0 = zero, v1 = zero, v2 = zero, v3 = zero;
    int32_t lane[4];
#endif
    for (t = 0; t < nt; ++t) {
        const int8_t *p0 = w0 + woff[t], *p1 = w1 + woff[t], *p2 = w2 + woff[t], *p3 = w3 + woff[t];
        const uint8_t *ap = in + ioff[t];
        int32_t n = tlen[t];
        ci = 0;
#if VT_CNN_SSE2
        for (; ci + 16 <= n; ci += 16) {
            __m128i x = _mm_loadu_si128((const __m128i *)(const void *)(ap + ci));
            __m128i xl = _mm_unpacklo_epi8(x, zero), xh = _mm_unpackhi_epi8(x, zero), w, sg;
#define VT__CNN_MADD16(p, v)                                                                  \
    w = _mm_loadu_si128((const __m128i *)(const void *)((p) + ci));                           \
    sg = _mm_cmpgt_epi8(zero, w);                                                              \
    v = _mm_add_epi32(v, _mm_add_epi32(_mm_madd_epi16(xl, _mm_unpacklo_epi8(w, sg)),          \
                                       _mm_madd_epi16(xh, _mm_unpackhi_epi8(w, sg))))
            VT__CNN_MADD16(p0, v0);
            VT__CNN_MADD16(p1, v1);
            VT__CNN_MADD16(p2, v2);
            VT__CNN_MADD16(p3, v3);
#undef VT__CNN_MADD16
        }
        for (; ci + 8 <= n; ci += 8) {
            __m128i xl = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)(const void *)(ap + ci)), zero), w;
#define VT__CNN_MADD8(p, v)                                                                   \
    w = _mm_loadl_epi64((const __m128i *)(const void *)((p) + ci));                            \
    v = _mm_add_epi32(v, _mm_madd_epi16(xl, _mm_unpacklo_epi8(w, _mm_cmpgt_epi8(zero, w))))
            VT__CNN_MADD8(p0, v0);
            VT__CNN_MADD8(p1, v1);
            VT__CNN_MADD8(p2, v2);
            VT__CNN_MADD8(p3, v3);
#undef VT__CNN_MADD8
        }
#endif
        for (; ci < n; ++ci) {
            int32_t a = ap[ci];
            a0 += (int32_t)p0[ci] * a;
            a1 += (int32_t)p1[ci] * a;
            a2 += (int32_t)p2[ci] * a;
            a3 += (int32_t)p3[ci] * a;
        }
    }
#if VT_CNN_SSE2
    _mm_storeu_si128((__m128i *)(void *)lane, v0);
    a0 += lane[0] + lane[1] + lane[2] + lane[3];
    _mm_storeu_si128((__m128i *)(void *)lane, v1);
    a1 += lane[0] + lane[1] + lane[2] + lane[3];
    _mm_storeu_si128((__m128i *)(void *)lane, v2);
    a2 += lane[0] + lane[1] + lane[2] + lane[3];
    _mm_storeu_si128((__m128i *)(void *)lane, v3);
    a3 += lane[0] + lane[1] + lane[2] + lane[3];
#endif
    acc[0] = a0;
    acc[1] = a1;
    acc[2] = a2;
    acc[3] = a3;
}

#if VT_CNN_SSE2
/* vt__cnn_dot4 for a single-channel input whose nine taps are all in the frame (the
 * first layer away from the borders): taps 0..7 of the four channels in one pmaddwd
 * each, the four sums gathered by two transposing adds, tap 8 by hand. px[9]: the
 * taps' input bytes in weight order. */
static void vt__cnn_dot4_k9(const int8_t *w0, const int32_t *px, int32_t *acc)
{
    const __m128i zero = _mm_setzero_si128();
    const __m128i x = _mm_setr_epi16((short)px[0], (short)px[1], (short)px[2], (short)px[3],
                                     (short)px[4], (short)px[5], (short)px[6], (short)px[7]);
    __m128i m[4], s01, s23;
    int32_t j;
    for (j = 0; j < 4; ++j) {
        __m128i w = _mm_loadl_epi64((const __m128i *)(const void *)(w0 + 9 * j));
        m[j] = _mm_madd_epi16(x, _mm_unpacklo_epi8(w, _mm_cmpgt_epi8(zero, w)));
    }
    s01 = _mm_add_epi32(_mm_unpacklo_epi32(m[0], m[1]), _mm_unpackhi_epi32(m[0], m[1]));
    s23 = _mm_add_epi32(_mm_unpacklo_epi32(m[2], m[3]), _mm_unpackhi_epi32(m[2], m[3]));
    _mm_storeu_si128((__m128i *)(void *)acc,
                     _mm_add_epi32(_mm_unpacklo_epi64(s01, s23), _mm_unpackhi_epi64(s01, s23)));
    for (j = 0; j < 4; ++j) {
        acc[j] += (int32_t)w0[9 * j + 8] * px[8];
    }
}
#endif

#if VT_CNN_AVX2
/* What this CPU runs, as bits: VT__ISA_AVX2; VT__ISA_VNNI, AVX-VNNI (cpuid leaf 7
 * sub-leaf 1, EAX bit 4; AVX2 already means the OS saves the ymm registers);
 * VT__ISA_512, AVX-512 F, BW and VNNI (the compiler's runtime checks that the OS saves
 * the zmm state). The two VNNI kinds are independent: Intel's Cascade and Ice Lake
 * have the 512-bit one only, its Alder Lake clients the 256-bit one only. */
#define VT__ISA_AVX2 1
#define VT__ISA_VNNI 2
#define VT__ISA_512 4
#define VT__ISA_VBMI 8 /* AVX-512 VBMI, with VT__ISA_512: the stretch's table lookups */
static int vt__cnn_isa(void)
{
    int isa = 0;
    if (!__builtin_cpu_supports("avx2")) {
        return 0;
    }
    isa = VT__ISA_AVX2;
#if VT_CNN_VNNI
    {
        unsigned int a, b, c, d;
        if (__get_cpuid_count(7, 1, &a, &b, &c, &d) && ((a >> 4) & 1u) != 0) {
            isa |= VT__ISA_VNNI;
        }
    }
#endif
#if VT_CNN_AVX512
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512vnni")) {
        isa |= VT__ISA_512;
        if (__builtin_cpu_supports("avx512vbmi")) {
            isa |= VT__ISA_VBMI;
        }
    }
#endif
    return isa;
}

/* vt__cnn_store's last steps on four int64 lanes: p (the product plus 2^(shift - 1))
 * floor-shifted by sh (per lane), then clamped to -128..127 (s8) or 0..255. The floor
 * shift of a negative p is ~((~p) >> sh) with a logical shift, as vt__floor_shr64's
 * -1 - ((-1 - p) >> n). */
__attribute__((target("avx2"))) static inline __m256i vt__cnn_shift_clamp(__m256i p, __m256i sh,
                                                                           int s8)
{
    const __m256i lo = _mm256_set1_epi64x(s8 ? -128 : 0), hi = _mm256_set1_epi64x(s8 ? 127 : 255);
    __m256i sg = _mm256_cmpgt_epi64(_mm256_setzero_si256(), p);
    __m256i q = _mm256_xor_si256(_mm256_srlv_epi64(_mm256_xor_si256(p, sg), sh), sg);
    q = _mm256_blendv_epi8(q, lo, _mm256_cmpgt_epi64(lo, q));
    return _mm256_blendv_epi8(q, hi, _mm256_cmpgt_epi64(q, hi));
}

/* vt__cnn_store for output channels co .. co + 3 of the pixel at o, acc (four int32
 * lanes) without the bias: the same q in 64-bit lanes. The sums stay in registers:
 * reloading lanes just written one by one would stall on store forwarding.
 * |acc + bias| <= 2^31 and mult < 2^31 keep (acc + bias) mult + 2^(shift - 1) inside
 * int63. */
__attribute__((target("avx2"))) static inline void vt__cnn_store4(const vt_cnn_layer *L,
                                                                   __m128i acc, int32_t co,
                                                                   size_t o, uint8_t *out_u8,
                                                                   int8_t *out_s8)
{
    const __m256i one = _mm256_set1_epi64x(1);
    __m128i a32 = _mm_add_epi32(acc, _mm_loadu_si128((const __m128i *)(const void *)(L->bias + co)));
    __m256i p = _mm256_mul_epi32(_mm256_cvtepi32_epi64(a32),
                                 _mm256_cvtepi32_epi64(
                                     _mm_loadu_si128((const __m128i *)(const void *)(L->mult + co))));
    __m256i sh, q;
    int32_t sh4, b4;
    memcpy(&sh4, L->shift + co, 4);
    sh = _mm256_cvtepu8_epi64(_mm_cvtsi32_si128(sh4));
    p = _mm256_add_epi64(p, _mm256_sllv_epi64(one, _mm256_sub_epi64(sh, one)));
    q = vt__cnn_shift_clamp(p, sh, out_s8 != NULL);
    /* each lane's low byte (the value, -128..255) into bytes 0..3 */
    q = _mm256_permutevar8x32_epi32(q, _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6));
    b4 = _mm_cvtsi128_si32(_mm_shuffle_epi8(_mm256_castsi256_si128(q),
                                            _mm_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1,
                                                          -1, -1, -1, -1, -1, -1)));
    memcpy(out_s8 != NULL ? (void *)(out_s8 + o + (size_t)co) : (void *)(out_u8 + o + (size_t)co),
           &b4, 4);
}

/* The two pair kernels below share their 16-byte steps, tail and store as macros over
 * named locals (p0..p3 the four channels' weights at this tap, ap / bp the two pixels'
 * input bytes, a0..a3 / b0..b3 their running sums, tail[8]): written as inline
 * functions over arrays, gcc kept the sums in memory and the frame took 10-70% longer.
 *
 * VT__CNN_PAIR16: bytes ci .. n - 1 of one tap, 16 a step widened to int16, each
 * vpmaddwd lane x y + x' y' (|.| <= 2 x 128 x 255); the bytes past the last step into
 * tail[4 p + j]. Every lane's running sum is a part of one accumulator's sum (cnn.h's
 * int32 bound). */
#define VT__CNN_MADD2(p, a, b)                                                                \
    w = _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)((p) + ci)));      \
    a = _mm256_add_epi32(a, _mm256_madd_epi16(x, w));                                          \
    b = _mm256_add_epi32(b, _mm256_madd_epi16(y, w))
#define VT__CNN_PAIR16()                                                                      \
    for (; ci + 16 <= n; ci += 16) {                                                           \
        __m256i x = _mm256_cvtepu8_epi16(_mm_loadu_si128((const __m128i *)(const void *)(ap + ci))); \
        __m256i y = _mm256_cvtepu8_epi16(_mm_loadu_si128((const __m128i *)(const void *)(bp + ci))); \
        __m256i w;                                                                             \
        VT__CNN_MADD2(p0, a0, b0);                                                             \
        VT__CNN_MADD2(p1, a1, b1);                                                             \
        VT__CNN_MADD2(p2, a2, b2);                                                             \
        VT__CNN_MADD2(p3, a3, b3);                                                             \
    }                                                                                          \
    for (; ci < n; ++ci) {                                                                     \
        int32_t x = ap[ci], y = bp[ci];                                                        \
        tail[0] += (int32_t)p0[ci] * x;                                                        \
        tail[1] += (int32_t)p1[ci] * x;                                                        \
        tail[2] += (int32_t)p2[ci] * x;                                                        \
        tail[3] += (int32_t)p3[ci] * x;                                                        \
        tail[4] += (int32_t)p0[ci] * y;                                                        \
        tail[5] += (int32_t)p1[ci] * y;                                                        \
        tail[6] += (int32_t)p2[ci] * y;                                                        \
        tail[7] += (int32_t)p3[ci] * y;                                                        \
    }
/* VT__CNN_PAIR_STORE: hadd twice leaves channel j's sums of each 128-bit half in lane
 * j of that half; plus the tails; vt__cnn_store4 at o and o + cout. */
#define VT__CNN_PAIR_STORE()                                                                  \
    do {                                                                                       \
        __m256i ha = _mm256_hadd_epi32(_mm256_hadd_epi32(a0, a1), _mm256_hadd_epi32(a2, a3));  \
        __m256i hb = _mm256_hadd_epi32(_mm256_hadd_epi32(b0, b1), _mm256_hadd_epi32(b2, b3));  \
        __m128i s0 = _mm_add_epi32(_mm256_castsi256_si128(ha), _mm256_extracti128_si256(ha, 1)); \
        __m128i s1 = _mm_add_epi32(_mm256_castsi256_si128(hb), _mm256_extracti128_si256(hb, 1)); \
        s0 = _mm_add_epi32(s0, _mm_setr_epi32(tail[0], tail[1], tail[2], tail[3]));          \
        s1 = _mm_add_epi32(s1, _mm_setr_epi32(tail[4], tail[5], tail[6], tail[7]));          \
        vt__cnn_store4(L, s0, co, o, out_u8, out_s8);                                          \
        vt__cnn_store4(L, s1, co, o + (size_t)L->cout, out_u8, out_s8);                        \
    } while (0)
/* The locals both kernels start from. */
#define VT__CNN_PAIR_LOCALS()                                                                 \
    const int8_t *w0 = L->w + (size_t)co * wtaps, *w1 = w0 + wtaps, *w2 = w1 + wtaps;         \
    const int8_t *w3 = w2 + wtaps;                                                             \
    __m256i a0 = _mm256_setzero_si256(), a1 = a0, a2 = a0, a3 = a0;                            \
    __m256i b0 = a0, b1 = a0, b2 = a0, b3 = a0;                                                \
    int32_t t, ci, tail[8] = {0, 0, 0, 0, 0, 0, 0, 0}
#define VT__CNN_PAIR_TAP()                                                                    \
    const int8_t *p0 = w0 + woff[t], *p1 = w1 + woff[t], *p2 = w2 + woff[t], *p3 = w3 + woff[t]; \
    const uint8_t *ap = in + ioff[t], *bp = ap + dx;                                           \
    int32_t n = tlen[t]

/* Output channels co .. co + 3 of two output pixels whose taps are the same runs dx
 * bytes apart (two interior neighbours; pixel 1's input bytes at in + ioff[t] + dx,
 * its output at o + cout): the sums of vt__cnn_dot4, stored as vt__cnn_store4 does. */
__attribute__((target("avx2"))) static void
vt__cnn_dot4x2(const vt_cnn_layer *L, int32_t co, size_t wtaps, const uint8_t *in, size_t dx,
               const size_t *ioff, const size_t *woff, const int32_t *tlen, int32_t nt, size_t o,
               uint8_t *out_u8, int8_t *out_s8)
{
    VT__CNN_PAIR_LOCALS();
    for (t = 0; t < nt; ++t) {
        VT__CNN_PAIR_TAP();
        ci = 0;
        VT__CNN_PAIR16()
    }
    VT__CNN_PAIR_STORE();
}

#if VT_CNN_VNNI
/* vt__cnn_dot4x2 with AVX-VNNI: 32 bytes a step, each vpdpbusd lane adding four
 * uint8 x int8 products to its running sum; then the 16-byte steps and the tail. */
__attribute__((target("avx2,avxvnni"))) static void
vt__cnn_dot4x2_vnni(const vt_cnn_layer *L, int32_t co, size_t wtaps, const uint8_t *in, size_t dx,
                    const size_t *ioff, const size_t *woff, const int32_t *tlen, int32_t nt,
                    size_t o, uint8_t *out_u8, int8_t *out_s8)
{
    VT__CNN_PAIR_LOCALS();
    for (t = 0; t < nt; ++t) {
        VT__CNN_PAIR_TAP();
        for (ci = 0; ci + 32 <= n; ci += 32) {
            __m256i x = _mm256_loadu_si256((const __m256i *)(const void *)(ap + ci));
            __m256i y = _mm256_loadu_si256((const __m256i *)(const void *)(bp + ci));
            __m256i w;
#define VT__CNN_DP2(p, a, b)                                                                  \
    w = _mm256_loadu_si256((const __m256i *)(const void *)((p) + ci));                         \
    a = _mm256_dpbusd_avx_epi32(a, x, w);                                                      \
    b = _mm256_dpbusd_avx_epi32(b, y, w)
            VT__CNN_DP2(p0, a0, b0);
            VT__CNN_DP2(p1, a1, b1);
            VT__CNN_DP2(p2, a2, b2);
            VT__CNN_DP2(p3, a3, b3);
#undef VT__CNN_DP2
        }
        VT__CNN_PAIR16()
    }
    VT__CNN_PAIR_STORE();
}
#endif
#undef VT__CNN_PAIR_TAP
#undef VT__CNN_PAIR_LOCALS
#undef VT__CNN_PAIR_STORE
#undef VT__CNN_PAIR16
#undef VT__CNN_MADD2
#endif

#if VT_CNN_AVX2
/* The first layer's usual shape (cin 1, 3x3, stride 2, dilation 1) across eight
 * output pixels ox .. ox + 7 of row oy, all nine taps of each in the frame and
 * input column 2 ox + 16 still in the row (the last 16-byte load's end). Output
 * pixel x's taps on one kernel row are the input bytes (2x - 1, 2x) and (2x + 1,
 * 2x + 2): two neighbouring int16 pairs, so one vpmaddwd against the broadcast
 * weight pairs (w0, w1) and (w2, 0) sums a kernel row for eight pixels at once.
 * wp[6 j + 2 ky + h]: channel j's pair h of kernel row ky, two int16 in an int32.
 * The requantisation is vt__cnn_store's, on eight 64-bit products (even and odd
 * lanes); the same bits as the per-pixel path. */
__attribute__((target("avx2"))) static void vt__cnn_first8(const vt_cnn_layer *L,
                                                            const int32_t *wp, const uint8_t *in,
                                                            size_t rs, int32_t ox, int32_t oy,
                                                            int32_t ow, uint8_t *out_u8,
                                                            int8_t *out_s8)
{
    __m256i r0[3], r1[3];
    int32_t ky, j, i, cout = L->cout, v[8];
    size_t o = ((size_t)oy * (size_t)ow + (size_t)ox) * (size_t)cout;
    for (ky = 0; ky < 3; ++ky) {
        const uint8_t *row = in + (size_t)(2 * oy - 1 + ky) * rs + (size_t)(2 * ox);
        r0[ky] = _mm256_cvtepu8_epi16(_mm_loadu_si128((const __m128i *)(const void *)(row - 1)));
        r1[ky] = _mm256_cvtepu8_epi16(_mm_loadu_si128((const __m128i *)(const void *)(row + 1)));
    }
    for (j = 0; j < cout; ++j) {
        const int32_t *q = wp + 6 * j;
        int32_t sh = L->shift[j];
        __m256i a = _mm256_set1_epi32(L->bias[j]), m = _mm256_set1_epi32(L->mult[j]);
        __m256i half = _mm256_set1_epi64x((int64_t)1 << (sh - 1)), shv = _mm256_set1_epi64x(sh);
        __m256i pe, po;
        for (ky = 0; ky < 3; ++ky) {
            a = _mm256_add_epi32(a, _mm256_madd_epi16(r0[ky], _mm256_set1_epi32(q[2 * ky])));
            a = _mm256_add_epi32(a, _mm256_madd_epi16(r1[ky], _mm256_set1_epi32(q[2 * ky + 1])));
        }
        /* lanes 0, 2, 4, 6 and 1, 3, 5, 7 as int64 products, each floor-shifted */
        pe = _mm256_add_epi64(_mm256_mul_epi32(a, m), half);
        po = _mm256_add_epi64(_mm256_mul_epi32(_mm256_srli_epi64(a, 32), m), half);
        pe = vt__cnn_shift_clamp(pe, shv, out_s8 != NULL);
        po = vt__cnn_shift_clamp(po, shv, out_s8 != NULL);
        /* -128..255 fits the low dword: even pixels' from pe, odd pixels' from po */
        _mm256_storeu_si256((__m256i *)(void *)v,
                            _mm256_blend_epi32(pe, _mm256_slli_epi64(po, 32), 0xAA));
        for (i = 0; i < 8; ++i) {
            size_t at = o + (size_t)i * (size_t)cout + (size_t)j;
            if (out_s8 != NULL) {
                out_s8[at] = (int8_t)v[i];
            } else {
                out_u8[at] = (uint8_t)v[i];
            }
        }
    }
}
#endif

#if VT_CNN_VNNI
static inline int32_t vt__cnn_ld32(const uint8_t *p)
{
    int32_t v;
    memcpy(&v, p, 4);
    return v;
}

/* The channels-in-lanes weights of one pass (below): for blocks of bw channels (16:
 * zmm, 8: ymm), nb blocks, n channels from co0 (lanes past n repeat channel co0),
 * wr[((t ng + g) nb + b) 4 bw + 4 j + i] = weight of channel co0 + bw b + j, tap t,
 * input channel 4 g + i; nt taps of ng steps (first: a kernel row and a zero byte). */
static void vt__cnn_cil_repack(const vt_cnn_layer *L, int32_t co0, int32_t n, int32_t bw,
                               int32_t nb, int32_t first, int32_t nt, int32_t ng, int8_t *wr)
{
    size_t wtaps = (size_t)L->ksize * (size_t)L->ksize * (size_t)L->cin;
    int32_t t, g, b, j, i;
    for (t = 0; t < nt; ++t) {
        for (g = 0; g < ng; ++g) {
            for (b = 0; b < nb; ++b) {
                for (j = 0; j < bw; ++j) {
                    int32_t c = bw * b + j;
                    const int8_t *src = L->w + (size_t)(co0 + (c < n ? c : 0)) * wtaps +
                                        (size_t)t * (first ? 3 : (size_t)L->cin) + 4 * (size_t)g;
                    int8_t *dst = wr + ((size_t)(t * ng + g) * (size_t)nb + (size_t)b) * 4 * (size_t)bw +
                                  4 * (size_t)j;
                    for (i = 0; i < 4; ++i) {
                        dst[i] = first && i == 3 ? 0 : src[i];
                    }
                }
            }
        }
    }
}

/* Channel co0 + c's shift and 2^(shift - 1) for c = 0..nc - 1 (channel co0's past n). */
static void vt__cnn_cil_shifts(const vt_cnn_layer *L, int32_t co0, int32_t n, int32_t nc,
                               int64_t *sh, int64_t *hf)
{
    int32_t c;
    for (c = 0; c < nc; ++c) {
        int32_t ch = c < n ? co0 + c : co0;
        sh[c] = L->shift[ch];
        hf[c] = (int64_t)1 << (L->shift[ch] - 1);
    }
}

/* A pass's taps (first: the first layer's three rows of four bytes): tap t's row and
 * column from the pixel's top-left tap (ky[t], kx[t]) and its byte offset along the row
 * (coff[t]); the tiles' columns cx0 .. cx1 - 1 (every tap's column in the frame, first:
 * the fourth byte too). Returns the number of taps. */
static int32_t vt__cnn_cil_taps(const vt_cnn_layer *L, int32_t first, int32_t iw, size_t *coff,
                                int32_t *ky, int32_t *kx, int32_t *cx0, int32_t *cx1)
{
    int32_t k = L->ksize, d = L->dilation, st = L->stride, r = (k / 2) * d, t;
    int32_t nt = first ? 3 : k * k;
    for (t = 0; t < nt; ++t) {
        ky[t] = first ? t : (t / k) * d;
        kx[t] = first ? 0 : (t % k) * d;
        coff[t] = (size_t)kx[t] * (size_t)L->cin;
    }
    *cx0 = (r + st - 1) / st;
    *cx1 = iw - 1 - r - first < 0 ? 0 : (iw - 1 - r - first) / st + 1;
    return nt;
}
#endif

#if VT_CNN_AVX512
/* Channels in lanes (AVX-512 VNNI): for a layer with cin a multiple of 4, a zmm holds
 * 16 output channels' int32 sums of one pixel, and one vpdpbusd adds the products of
 * 4 input channels (their bytes broadcast to every lane) with those 16 channels'
 * weights. Each tap's weights for a pass of VT__CNN_CIL_NB blocks of 16 channels are
 * repacked once per layer so that the 64 bytes one vpdpbusd needs lie together:
 * wr[((t ng + g) nb + b) 64 + 4 j + i] = weight of channel co0 + 16 b + j, tap t, input
 * channel 4 g + i (ng = cin / 4). A tile of VT__CNN_CIL_P pixels of one row
 * shares every weight vector, so a step loads nb weight vectors and P broadcasts for
 * nb P vpdpbusd, and no sum needs a horizontal add. The sums are those of the other
 * paths (cnn.h's int32 bound covers every partial sum in any order). */
#define VT__CNN_CIL_NB 2
#define VT__CNN_CIL_P 8
#define VT__CNN_CIL_WR (9 * VT_CNN_MAX_CH * 16 * VT__CNN_CIL_NB) /* 36,864 B of stack */

/* Requantise 16 channels' sums (bias not yet added) of one pixel and store them: the
 * 64-bit product of even and odd lanes, plus 2^(shift - 1), arithmetic (floor) shift
 * right by shift, clamp; vt__cnn_store's q exactly. The per-block constants: bias,
 * mult (16 lanes), half and shift of the even (he, se) and odd (ho, so) channels in
 * 64-bit lanes. */
#define VT__CNN_CIL_STORE(acc, dst)                                                           \
    do {                                                                                       \
        __m512i s_ = _mm512_add_epi32(acc, bias);                                              \
        __m512i pe_ = _mm512_add_epi64(_mm512_mul_epi32(s_, mult), he);                        \
        __m512i po_ = _mm512_add_epi64(                                                        \
            _mm512_mul_epi32(_mm512_srli_epi64(s_, 32), _mm512_srli_epi64(mult, 32)), ho);     \
        pe_ = _mm512_min_epi64(_mm512_max_epi64(_mm512_srav_epi64(pe_, se), lo), hi);          \
        po_ = _mm512_min_epi64(_mm512_max_epi64(_mm512_srav_epi64(po_, so), lo), hi);          \
        _mm512_mask_cvtepi32_storeu_epi8((void *)(dst), (__mmask16)sm,                         \
                                         _mm512_mask_blend_epi32((__mmask16)0xAAAA, pe_,       \
                                                                 _mm512_slli_epi64(po_, 32))); \
    } while (0)

/* One pass over every output pixel of the layer (ow x oh) for output channels co0 ..
 * co0 + n - 1 (n = 1..32, so nb = 1 or 2 blocks; a block's lanes past n repeat
 * channel co0 and are not stored). Tiles of VT__CNN_CIL_P pixels where every tap's
 * column lies in the frame (a kernel row outside it is skipped for the whole tile); one
 * pixel at a time elsewhere, over its in-frame taps only.
 * The first layer's shape (cin 1, 3x3, dilation 1) is taken as three taps of four
 * bytes, a kernel row and the byte after it, whose weight is 0: tiles only where that
 * byte is inside the row, and single pixels build the four bytes with 0 for the
 * bytes outside the frame (0 x weight adds nothing). */
__attribute__((target("avx2,avx512f,avx512bw,avx512vnni"))) static void
vt__cnn_cil_pass(const vt_cnn_layer *L, int32_t co0, int32_t n, int8_t *wr, const uint8_t *in,
                 int32_t iw, int32_t ih, size_t rs, int32_t ow, int32_t oh, uint8_t *out_u8,
                 int8_t *out_s8)
{
    int32_t k = L->ksize, cin = L->cin, cout = L->cout, st = L->stride, d = L->dilation;
    size_t coff[9];
    int32_t first = cin == 1, r = (k / 2) * d, ky[9], kx[9], cx0, cx1;
    int32_t nt = vt__cnn_cil_taps(L, first, iw, coff, ky, kx, &cx0, &cx1);
    int32_t ng = first ? 1 : cin / 4, nb = n > 16 ? 2 : 1, t, g, i, ox, oy;
    /* the lanes of block 0 and 1 that hold channels */
    uint32_t m0 = n >= 16 ? 0xFFFFu : (1u << n) - 1u, m1 = n >= 32 ? 0xFFFFu : (1u << (n - 16 > 0 ? n - 16 : 0)) - 1u;
    size_t ps = (size_t)st * (size_t)cin, wstep = (size_t)nb * 64;
    __m512i bias0, bias1, mult0, mult1, he0, he1, ho0, ho1, se0, se1, so0, so1;
    const __m512i lo = _mm512_set1_epi64(out_s8 != NULL ? -128 : 0);
    const __m512i hi = _mm512_set1_epi64(out_s8 != NULL ? 127 : 255);
    uint8_t *ob = out_s8 != NULL ? (uint8_t *)(void *)out_s8 : out_u8;
    vt__cnn_cil_repack(L, co0, n, 16, nb, first, nt, ng, wr);
    {
        /* per-block constants: channel c's shift and 2^(shift - 1) in the 64-bit lane
         * of its pair (even channels: lanes' low halves, odd: high halves) */
        int64_t sh[32], hf[32];
        vt__cnn_cil_shifts(L, co0, n, 32, sh, hf);
#define VT__CNN_CIL_EO(v, a, par)                                                             \
    v = _mm512_setr_epi64(a[par], a[par + 2], a[par + 4], a[par + 6], a[par + 8], a[par + 10], \
                          a[par + 12], a[par + 14])
        VT__CNN_CIL_EO(se0, sh, 0);
        VT__CNN_CIL_EO(so0, sh, 1);
        VT__CNN_CIL_EO(he0, hf, 0);
        VT__CNN_CIL_EO(ho0, hf, 1);
        VT__CNN_CIL_EO(se1, sh, 16);
        VT__CNN_CIL_EO(so1, sh, 17);
        VT__CNN_CIL_EO(he1, hf, 16);
        VT__CNN_CIL_EO(ho1, hf, 17);
#undef VT__CNN_CIL_EO
        bias0 = _mm512_maskz_loadu_epi32((__mmask16)m0, (const void *)(L->bias + co0));
        mult0 = _mm512_maskz_loadu_epi32((__mmask16)m0, (const void *)(L->mult + co0));
        bias1 = _mm512_maskz_loadu_epi32((__mmask16)m1, (const void *)(L->bias + co0 + 16));
        mult1 = _mm512_maskz_loadu_epi32((__mmask16)m1, (const void *)(L->mult + co0 + 16));
    }
#define VT__CNN_CIL_BC(p) _mm512_set1_epi32(vt__cnn_ld32(x + (size_t)(p) * ps))
    for (oy = 0; oy < oh; ++oy) {
        uint8_t *orow = ob + (size_t)oy * (size_t)ow * (size_t)cout + (size_t)co0;
        for (ox = 0; ox < ow;) {
            if (ox >= cx0 && ox < cx1 && cx1 - cx0 >= VT__CNN_CIL_P) {
                /* the row's last tile ends at cx1 and may overlap the one before: its
                 * pixels are computed twice, to the same bytes */
                __m512i a0 = _mm512_setzero_si512(), a1 = a0, a2 = a0, a3 = a0, a4 = a0, a5 = a0;
                __m512i a6 = a0, a7 = a0, c0 = a0, c1 = a0, c2 = a0, c3 = a0, c4 = a0, c5 = a0;
                __m512i c6 = a0, c7 = a0;
                if (ox > cx1 - VT__CNN_CIL_P) {
                    ox = cx1 - VT__CNN_CIL_P;
                }
                for (t = 0; t < nt; ++t) {
                    int32_t iy = oy * st - r + ky[t];
                    const uint8_t *x;
                    const int8_t *wp = wr + (size_t)t * (size_t)ng * wstep;
                    if (iy < 0 || iy >= ih) {
                        continue;
                    }
                    x = in + (size_t)iy * rs + (size_t)(ox * st - r) * (size_t)cin + coff[t];
                    if (nb == 2) {
                        for (g = 0; g < ng; ++g, x += 4, wp += 128) {
                            __m512i w0 = _mm512_loadu_si512((const void *)wp);
                            __m512i w1 = _mm512_loadu_si512((const void *)(wp + 64)), v;
#define VT__CNN_CIL_DP2(p, a, c)                                                              \
    v = VT__CNN_CIL_BC(p);                                                                     \
    a = _mm512_dpbusd_epi32(a, v, w0);                                                         \
    c = _mm512_dpbusd_epi32(c, v, w1)
                            VT__CNN_CIL_DP2(0, a0, c0);
                            VT__CNN_CIL_DP2(1, a1, c1);
                            VT__CNN_CIL_DP2(2, a2, c2);
                            VT__CNN_CIL_DP2(3, a3, c3);
                            VT__CNN_CIL_DP2(4, a4, c4);
                            VT__CNN_CIL_DP2(5, a5, c5);
                            VT__CNN_CIL_DP2(6, a6, c6);
                            VT__CNN_CIL_DP2(7, a7, c7);
#undef VT__CNN_CIL_DP2
                        }
                    } else {
                        for (g = 0; g < ng; ++g, x += 4, wp += 64) {
                            __m512i w0 = _mm512_loadu_si512((const void *)wp);
                            a0 = _mm512_dpbusd_epi32(a0, VT__CNN_CIL_BC(0), w0);
                            a1 = _mm512_dpbusd_epi32(a1, VT__CNN_CIL_BC(1), w0);
                            a2 = _mm512_dpbusd_epi32(a2, VT__CNN_CIL_BC(2), w0);
                            a3 = _mm512_dpbusd_epi32(a3, VT__CNN_CIL_BC(3), w0);
                            a4 = _mm512_dpbusd_epi32(a4, VT__CNN_CIL_BC(4), w0);
                            a5 = _mm512_dpbusd_epi32(a5, VT__CNN_CIL_BC(5), w0);
                            a6 = _mm512_dpbusd_epi32(a6, VT__CNN_CIL_BC(6), w0);
                            a7 = _mm512_dpbusd_epi32(a7, VT__CNN_CIL_BC(7), w0);
                        }
                    }
                }
                {
                    uint8_t *o = orow + (size_t)ox * (size_t)cout;
                    size_t oc = (size_t)cout;
                    __m512i bias = bias0, mult = mult0, he = he0, ho = ho0, se = se0, so = so0;
                    uint32_t sm = m0;
                    VT__CNN_CIL_STORE(a0, o);
                    VT__CNN_CIL_STORE(a1, o + oc);
                    VT__CNN_CIL_STORE(a2, o + 2 * oc);
                    VT__CNN_CIL_STORE(a3, o + 3 * oc);
                    VT__CNN_CIL_STORE(a4, o + 4 * oc);
                    VT__CNN_CIL_STORE(a5, o + 5 * oc);
                    VT__CNN_CIL_STORE(a6, o + 6 * oc);
                    VT__CNN_CIL_STORE(a7, o + 7 * oc);
                    if (nb == 2) {
                        bias = bias1, mult = mult1, he = he1, ho = ho1, se = se1, so = so1, sm = m1;
                        o += 16;
                        VT__CNN_CIL_STORE(c0, o);
                        VT__CNN_CIL_STORE(c1, o + oc);
                        VT__CNN_CIL_STORE(c2, o + 2 * oc);
                        VT__CNN_CIL_STORE(c3, o + 3 * oc);
                        VT__CNN_CIL_STORE(c4, o + 4 * oc);
                        VT__CNN_CIL_STORE(c5, o + 5 * oc);
                        VT__CNN_CIL_STORE(c6, o + 6 * oc);
                        VT__CNN_CIL_STORE(c7, o + 7 * oc);
                    }
                }
                ox += VT__CNN_CIL_P;
            } else {
                /* one pixel, over its in-frame taps; even and odd steps in separate sums
                 * so that each waits on half the vpdpbusd latency chain */
                __m512i a0 = _mm512_setzero_si512(), c0 = a0, a1 = a0, c1 = a0;
                for (t = 0; t < nt; ++t) {
                    int32_t iy = oy * st - r + ky[t], ix = ox * st - r + kx[t];
                    const int8_t *wp = wr + (size_t)t * (size_t)ng * wstep;
                    const uint8_t *x;
                    uint8_t q[4] = {0, 0, 0, 0};
                    if (iy < 0 || iy >= ih || (!first && (ix < 0 || ix >= iw))) {
                        continue;
                    }
                    x = in + (size_t)iy * rs;
                    if (first) {
                        for (i = 0; i < 3; ++i) {
                            q[i] = ix + i >= 0 && ix + i < iw ? x[ix + i] : 0;
                        }
                        x = q;
                    } else {
                        x += (size_t)ix * (size_t)cin;
                    }
                    for (g = 0; g + 2 <= ng; g += 2, x += 8, wp += 2 * wstep) {
                        __m512i v = VT__CNN_CIL_BC(0), u = _mm512_set1_epi32(vt__cnn_ld32(x + 4));
                        a0 = _mm512_dpbusd_epi32(a0, v, _mm512_loadu_si512((const void *)wp));
                        a1 = _mm512_dpbusd_epi32(a1, u, _mm512_loadu_si512((const void *)(wp + wstep)));
                        if (nb == 2) {
                            c0 = _mm512_dpbusd_epi32(c0, v, _mm512_loadu_si512((const void *)(wp + 64)));
                            c1 = _mm512_dpbusd_epi32(c1, u, _mm512_loadu_si512((const void *)(wp + wstep + 64)));
                        }
                    }
                    if (g < ng) {
                        __m512i v = VT__CNN_CIL_BC(0);
                        a0 = _mm512_dpbusd_epi32(a0, v, _mm512_loadu_si512((const void *)wp));
                        if (nb == 2) {
                            c0 = _mm512_dpbusd_epi32(c0, v, _mm512_loadu_si512((const void *)(wp + 64)));
                        }
                    }
                }
                a0 = _mm512_add_epi32(a0, a1);
                c0 = _mm512_add_epi32(c0, c1);
                {
                    uint8_t *o = orow + (size_t)ox * (size_t)cout;
                    __m512i bias = bias0, mult = mult0, he = he0, ho = ho0, se = se0, so = so0;
                    uint32_t sm = m0;
                    VT__CNN_CIL_STORE(a0, o);
                    if (nb == 2) {
                        bias = bias1, mult = mult1, he = he1, ho = ho1, se = se1, so = so1, sm = m1;
                        VT__CNN_CIL_STORE(c0, o + 16);
                    }
                }
                ++ox;
            }
        }
    }
#undef VT__CNN_CIL_BC
}
#undef VT__CNN_CIL_STORE
#endif

#if VT_CNN_VNNI
/* vt__cnn_cil_pass with AVX-VNNI on 256 bits (CPUs without AVX-512): blocks of 8
 * channels, two a pass, tiles of VT__CNN_CIL256_P pixels (12 sums, two weight vectors
 * and a broadcast in the 16 ymm registers); layers with cin a multiple of 4 (the first
 * layer keeps vt__cnn_first8). The sums and the requantisation are the same as there. */
#define VT__CNN_CIL256_P 6

/* 8 channels' sums (bias not yet added) of one pixel requantised (vt__cnn_store's q)
 * and their nv (1..8) low bytes stored at dst. */
__attribute__((target("avx2"))) static inline void
vt__cnn_cil_store8(__m256i acc, __m256i bias, __m256i mult, __m256i he, __m256i ho, __m256i se,
                   __m256i so, int s8, uint8_t *dst, int32_t nv)
{
    __m256i sm = _mm256_add_epi32(acc, bias);
    __m256i pe = _mm256_add_epi64(_mm256_mul_epi32(sm, mult), he);
    __m256i po = _mm256_add_epi64(
        _mm256_mul_epi32(_mm256_srli_epi64(sm, 32), _mm256_srli_epi64(mult, 32)), ho);
    __m256i v = _mm256_blend_epi32(vt__cnn_shift_clamp(pe, se, s8),
                                   _mm256_slli_epi64(vt__cnn_shift_clamp(po, so, s8), 32), 0xAA);
    uint64_t q;
    /* each lane's low byte: bytes 0..3 of each 128-bit half */
    v = _mm256_shuffle_epi8(v, _mm256_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1,
                                                -1, -1, -1, 0, 4, 8, 12, -1, -1, -1, -1, -1, -1,
                                                -1, -1, -1, -1, -1, -1));
    q = (uint64_t)(uint32_t)_mm_cvtsi128_si32(_mm256_castsi256_si128(v)) |
        ((uint64_t)(uint32_t)_mm_cvtsi128_si32(_mm256_extracti128_si256(v, 1)) << 32);
    if (nv == 8) {
        memcpy(dst, &q, 8);
    } else {
        int32_t i;
        for (i = 0; i < nv; ++i) {
            dst[i] = (uint8_t)(q >> (8 * i));
        }
    }
}

/* Output channels co0 .. co0 + n - 1 (n = 1..16) of every pixel, as vt__cnn_cil_pass. */
__attribute__((target("avx2,avxvnni"))) static void
vt__cnn_cil_pass256(const vt_cnn_layer *L, int32_t co0, int32_t n, int8_t *wr, const uint8_t *in,
                    int32_t iw, int32_t ih, size_t rs, int32_t ow, int32_t oh, uint8_t *out_u8,
                    int8_t *out_s8)
{
    int32_t k = L->ksize, cin = L->cin, cout = L->cout, st = L->stride, d = L->dilation;
    size_t coff[9];
    int32_t r = (k / 2) * d, ky[9], kx[9], cx0, cx1;
    int32_t nt = vt__cnn_cil_taps(L, 0, iw, coff, ky, kx, &cx0, &cx1), ng = cin / 4, nb = n > 8 ? 2 : 1;
    int32_t n0 = n < 8 ? n : 8, n1 = n - n0, s8 = out_s8 != NULL, t, g, p, ox, oy;
    size_t ps = (size_t)st * (size_t)cin, wstep = (size_t)nb * 32;
    uint8_t *ob = s8 ? (uint8_t *)(void *)out_s8 : out_u8;
    __m256i bias0, bias1, mult0, mult1, he0, he1, ho0, ho1, se0, se1, so0, so1;
    vt__cnn_cil_repack(L, co0, n, 8, nb, 0, nt, ng, wr);
    {
        int64_t sh[16], hf[16];
        int32_t bi[16], mu[16], c;
        vt__cnn_cil_shifts(L, co0, n, 16, sh, hf);
        for (c = 0; c < 16; ++c) {
            bi[c] = L->bias[c < n ? co0 + c : co0];
            mu[c] = L->mult[c < n ? co0 + c : co0];
        }
#define VT__CNN_CIL_EO4(v, a, par) v = _mm256_setr_epi64x(a[par], a[par + 2], a[par + 4], a[par + 6])
        VT__CNN_CIL_EO4(se0, sh, 0);
        VT__CNN_CIL_EO4(so0, sh, 1);
        VT__CNN_CIL_EO4(he0, hf, 0);
        VT__CNN_CIL_EO4(ho0, hf, 1);
        VT__CNN_CIL_EO4(se1, sh, 8);
        VT__CNN_CIL_EO4(so1, sh, 9);
        VT__CNN_CIL_EO4(he1, hf, 8);
        VT__CNN_CIL_EO4(ho1, hf, 9);
#undef VT__CNN_CIL_EO4
        bias0 = _mm256_loadu_si256((const __m256i *)(const void *)bi);
        bias1 = _mm256_loadu_si256((const __m256i *)(const void *)(bi + 8));
        mult0 = _mm256_loadu_si256((const __m256i *)(const void *)mu);
        mult1 = _mm256_loadu_si256((const __m256i *)(const void *)(mu + 8));
    }
#define VT__CNN_CIL_BC8(q) _mm256_set1_epi32(vt__cnn_ld32(x + (size_t)(q) * ps))
#define VT__CNN_CIL_ST8(acc, b, dst, nv)                                                      \
    vt__cnn_cil_store8(acc, bias##b, mult##b, he##b, ho##b, se##b, so##b, s8, dst, nv)
    for (oy = 0; oy < oh; ++oy) {
        uint8_t *orow = ob + (size_t)oy * (size_t)ow * (size_t)cout + (size_t)co0;
        for (ox = 0; ox < ow;) {
            uint8_t *o;
            if (ox >= cx0 && ox < cx1 && cx1 - cx0 >= VT__CNN_CIL256_P) {
                /* as vt__cnn_cil_pass: kernel rows outside the frame skipped, the row's
                 * last tile overlapping the one before */
                __m256i a0 = _mm256_setzero_si256(), a1 = a0, a2 = a0, a3 = a0, a4 = a0, a5 = a0;
                __m256i c0 = a0, c1 = a0, c2 = a0, c3 = a0, c4 = a0, c5 = a0;
                if (ox > cx1 - VT__CNN_CIL256_P) {
                    ox = cx1 - VT__CNN_CIL256_P;
                }
                for (t = 0; t < nt; ++t) {
                    int32_t iy = oy * st - r + ky[t];
                    const uint8_t *x;
                    const int8_t *wp = wr + (size_t)t * (size_t)ng * wstep;
                    if (iy < 0 || iy >= ih) {
                        continue;
                    }
                    x = in + (size_t)iy * rs + (size_t)(ox * st - r) * (size_t)cin + coff[t];
                    for (g = 0; g < ng; ++g, x += 4, wp += wstep) {
                        __m256i w0 = _mm256_loadu_si256((const __m256i *)(const void *)wp);
                        __m256i w1 = _mm256_loadu_si256((const __m256i *)(const void *)(wp + 32)), v;
#define VT__CNN_CIL_DP8(q, a, c)                                                              \
    v = VT__CNN_CIL_BC8(q);                                                                    \
    a = _mm256_dpbusd_avx_epi32(a, v, w0);                                                     \
    c = _mm256_dpbusd_avx_epi32(c, v, w1)
                        VT__CNN_CIL_DP8(0, a0, c0);
                        VT__CNN_CIL_DP8(1, a1, c1);
                        VT__CNN_CIL_DP8(2, a2, c2);
                        VT__CNN_CIL_DP8(3, a3, c3);
                        VT__CNN_CIL_DP8(4, a4, c4);
                        VT__CNN_CIL_DP8(5, a5, c5);
#undef VT__CNN_CIL_DP8
                    }
                }
                o = orow + (size_t)ox * (size_t)cout;
                VT__CNN_CIL_ST8(a0, 0, o, n0);
                VT__CNN_CIL_ST8(a1, 0, o + (size_t)cout, n0);
                VT__CNN_CIL_ST8(a2, 0, o + 2 * (size_t)cout, n0);
                VT__CNN_CIL_ST8(a3, 0, o + 3 * (size_t)cout, n0);
                VT__CNN_CIL_ST8(a4, 0, o + 4 * (size_t)cout, n0);
                VT__CNN_CIL_ST8(a5, 0, o + 5 * (size_t)cout, n0);
                if (nb == 2) {
                    o += 8;
                    VT__CNN_CIL_ST8(c0, 1, o, n1);
                    VT__CNN_CIL_ST8(c1, 1, o + (size_t)cout, n1);
                    VT__CNN_CIL_ST8(c2, 1, o + 2 * (size_t)cout, n1);
                    VT__CNN_CIL_ST8(c3, 1, o + 3 * (size_t)cout, n1);
                    VT__CNN_CIL_ST8(c4, 1, o + 4 * (size_t)cout, n1);
                    VT__CNN_CIL_ST8(c5, 1, o + 5 * (size_t)cout, n1);
                }
                ox += VT__CNN_CIL256_P;
            } else {
                /* one pixel, over its in-frame taps, even and odd steps in separate sums */
                __m256i a0 = _mm256_setzero_si256(), a1 = a0, c0 = a0, c1 = a0;
                for (t = 0; t < nt; ++t) {
                    int32_t iy = oy * st - r + ky[t], ix = ox * st - r + kx[t];
                    const int8_t *wp = wr + (size_t)t * (size_t)ng * wstep;
                    const uint8_t *x;
                    if (iy < 0 || iy >= ih || ix < 0 || ix >= iw) {
                        continue;
                    }
                    x = in + (size_t)iy * rs + (size_t)ix * (size_t)cin;
                    for (g = 0, p = 0; g < ng; ++g, x += 4, wp += wstep, p ^= 1) {
                        __m256i v = VT__CNN_CIL_BC8(0);
                        __m256i w0 = _mm256_loadu_si256((const __m256i *)(const void *)wp);
                        __m256i w1 = _mm256_loadu_si256((const __m256i *)(const void *)(wp + 32));
                        if (p == 0) {
                            a0 = _mm256_dpbusd_avx_epi32(a0, v, w0);
                            c0 = _mm256_dpbusd_avx_epi32(c0, v, w1);
                        } else {
                            a1 = _mm256_dpbusd_avx_epi32(a1, v, w0);
                            c1 = _mm256_dpbusd_avx_epi32(c1, v, w1);
                        }
                    }
                }
                o = orow + (size_t)ox * (size_t)cout;
                VT__CNN_CIL_ST8(_mm256_add_epi32(a0, a1), 0, o, n0);
                if (nb == 2) {
                    VT__CNN_CIL_ST8(_mm256_add_epi32(c0, c1), 1, o + 8, n1);
                }
                ++ox;
            }
        }
    }
#undef VT__CNN_CIL_ST8
#undef VT__CNN_CIL_BC8
}
#endif

vt_status vt_cnn_simd_path(int32_t *path)
{
    if (path == NULL) {
        return VT_E_ARG;
    }
#if VT_CNN_AVX2
    {
        int isa = vt__cnn_isa();
        *path = (isa & VT__ISA_512) != 0    ? VT_CNN_SIMD_AVX512VNNI
                : (isa & VT__ISA_VNNI) != 0 ? VT_CNN_SIMD_AVXVNNI
                : isa != 0                  ? VT_CNN_SIMD_AVX2
                                            : VT_CNN_SIMD_SSE2;
    }
#elif VT_CNN_SSE2
    *path = VT_CNN_SIMD_SSE2;
#else
    *path = VT_CNN_SIMD_PORTABLE;
#endif
    return VT_OK;
}

/* The in-frame taps of output pixel (ox, oy): runs of tlen[t] input bytes at
 * ioff[t] against the weights at woff[t] (per output channel); returns how many. A
 * 3x3 layer of dilation 1 away from the left and right borders reads each kernel
 * row as one run of k cin bytes. */
static int32_t vt__cnn_taps(const vt_cnn_layer *L, int32_t iw, int32_t ih, size_t rs, int32_t ox,
                            int32_t oy, size_t *ioff, size_t *woff, int32_t *tlen)
{
    int32_t k = L->ksize, st = L->stride, d = L->dilation, cin = L->cin;
    int32_t half = k / 2, ky, kx, nt = 0;
    for (ky = 0; ky < k; ++ky) {
        int32_t iy = oy * st + (ky - half) * d;
        if (iy < 0 || iy >= ih) {
            continue;
        }
        if (d == 1 && ox * st - half >= 0 && ox * st + half < iw) {
            ioff[nt] = (size_t)iy * rs + (size_t)(ox * st - half) * (size_t)cin;
            woff[nt] = (size_t)(ky * k) * (size_t)cin;
            tlen[nt] = k * cin;
            ++nt;
            continue;
        }
        for (kx = 0; kx < k; ++kx) {
            int32_t ix = ox * st + (kx - half) * d;
            if (ix < 0 || ix >= iw) {
                continue;
            }
            ioff[nt] = (size_t)iy * rs + (size_t)ix * (size_t)cin;
            woff[nt] = (size_t)(ky * k + kx) * (size_t)cin;
            tlen[nt] = cin;
            ++nt;
        }
    }
    return nt;
}

/* Output channel co's sum over the taps, bias included (the channels past the last
 * block of four). */
static int32_t vt__cnn_dot1(const vt_cnn_layer *L, int32_t co, size_t wtaps, const uint8_t *in,
                            const size_t *ioff, const size_t *woff, const int32_t *tlen,
                            int32_t nt)
{
    const int8_t *wc = L->w + (size_t)co * wtaps;
    int32_t acc = L->bias[co], t, ci;
    for (t = 0; t < nt; ++t) {
        const int8_t *wp = wc + woff[t];
        const uint8_t *ap = in + ioff[t];
        for (ci = 0; ci < tlen[t]; ++ci) {
            acc += (int32_t)wp[ci] * (int32_t)ap[ci];
        }
    }
    return acc;
}

/* One layer (arguments checked): input iw x ih x cin at in, row stride rs bytes
 * (pixel stride cin); output ow x oh x cout to out_u8 (relu) or out_s8 (last); isa
 * vt__cnn_isa()'s bits (0 without AVX2).
 * Loop order: output pixel -> its in-bounds taps (found once per pixel, so the
 * border test is per tap, not per multiply-add) -> four output channels at a time
 * (each input byte loaded once for four multiply-adds) -> a dot product over cin,
 * which is contiguous in both the [cout][ky][kx][cin] weights and the HWC input.
 * The order of the integer sums does not change them: |bias| <= 2^30 and at most
 * 9 x VT_CNN_MAX_CH (128) products of at most 128 x 255 keep every partial sum inside int32. */
static void vt__cnn_layer(const vt_cnn_layer *L, const uint8_t *in, int32_t iw, int32_t ih,
                          size_t rs, int32_t ow, int32_t oh, uint8_t *out_u8, int8_t *out_s8,
                          int isa)
{
    int32_t k = L->ksize, cin = L->cin, cout = L->cout;
    int32_t ox, oy, co;
    size_t wtaps = (size_t)k * (size_t)k * (size_t)cin;
    size_t ioff[9], woff[9];
    int32_t tlen[9];
#if VT_CNN_SSE2
    int32_t px[9], k9, t, ci;
#endif
#if !VT_CNN_AVX2
    (void)isa;
#endif
#if VT_CNN_AVX2
    /* pixel ox + 1's taps: when they are pixel ox's kernel positions in the same runs
     * (two interior neighbours), its input offsets are pixel ox's plus dx = st cin
     * bytes, and both pixels are summed in one pass */
    size_t ioff2[9], woff2[9], dx = (size_t)L->stride * (size_t)cin;
    int32_t tlen2[9], avx2 = isa != 0;
    /* the first layer's usual shape, eight pixels at a time (vt__cnn_first8) */
    int32_t wp[6 * VT__CNN_FIRST8_MAX_CH];
    int32_t first8 = avx2 && cin == 1 && k == 3 && L->stride == 2 && L->dilation == 1 &&
                     cout <= VT__CNN_FIRST8_MAX_CH;
    if (first8) {
        for (co = 0; co < cout; ++co) {
            const int8_t *w = L->w + 9 * co;
            int32_t ky;
            for (ky = 0; ky < 3; ++ky) {
                wp[6 * co + 2 * ky] = (int32_t)((uint32_t)(uint16_t)w[3 * ky] |
                                                ((uint32_t)(uint16_t)w[3 * ky + 1] << 16));
                wp[6 * co + 2 * ky + 1] = (int32_t)(uint32_t)(uint16_t)w[3 * ky + 2];
            }
        }
    }
#endif
    /* AVX-512 VNNI: every pixel and channel by channels in lanes (vt__cnn_cil_pass) where
     * the layer's cin is a multiple of 4 or it has the first layer's shape */
#if VT_CNN_AVX512
    if ((isa & VT__ISA_512) != 0 && (cin % 4 == 0 || (cin == 1 && k == 3 && L->dilation == 1))) {
        int8_t wr[VT__CNN_CIL_WR];
        for (co = 0; co < cout; co += 16 * VT__CNN_CIL_NB) {
            vt__cnn_cil_pass(L, co, cout - co < 32 ? cout - co : 32, wr, in, iw, ih, rs, ow, oh,
                             out_u8, out_s8);
        }
        return;
    }
#endif
#if VT_CNN_VNNI
    if ((isa & VT__ISA_512) == 0 && (isa & VT__ISA_VNNI) != 0 && cin % 4 == 0) {
        int8_t wr[9 * VT_CNN_MAX_CH * 16]; /* 18,432 B of stack */
        for (co = 0; co < cout; co += 16) {
            vt__cnn_cil_pass256(L, co, cout - co < 16 ? cout - co : 16, wr, in, iw, ih, rs, ow, oh,
                                out_u8, out_s8);
        }
        return;
    }
#endif
    for (oy = 0; oy < oh; ++oy) {
        for (ox = 0; ox < ow; ++ox) {
            size_t o = ((size_t)oy * (size_t)ow + (size_t)ox) * (size_t)cout;
            int32_t nt;
#if VT_CNN_AVX2
            if (first8 && ox >= 1 && 2 * ox + 16 < iw && oy >= 1 && 2 * oy + 1 < ih) {
                vt__cnn_first8(L, wp, in, rs, ox, oy, ow, out_u8, out_s8);
                ox += 7;
                continue;
            }
#endif
            nt = vt__cnn_taps(L, iw, ih, rs, ox, oy, ioff, woff, tlen);
#if VT_CNN_AVX2
            if (avx2 && cin > 1 && ox + 1 < ow &&
                vt__cnn_taps(L, iw, ih, rs, ox + 1, oy, ioff2, woff2, tlen2) == nt) {
                int32_t same = 1;
                for (t = 0; t < nt; ++t) {
                    same &= woff2[t] == woff[t] && tlen2[t] == tlen[t];
                }
                if (same) {
                    size_t o2 = o + (size_t)cout;
                    co = 0;
                    for (; co + 4 <= cout; co += 4) {
#if VT_CNN_VNNI
                        if ((isa & VT__ISA_VNNI) != 0) {
                            vt__cnn_dot4x2_vnni(L, co, wtaps, in, dx, ioff, woff, tlen, nt, o,
                                                out_u8, out_s8);
                            continue;
                        }
#endif
                        vt__cnn_dot4x2(L, co, wtaps, in, dx, ioff, woff, tlen, nt, o, out_u8,
                                       out_s8);
                    }
                    for (; co < cout; ++co) {
                        vt__cnn_store(L, vt__cnn_dot1(L, co, wtaps, in, ioff, woff, tlen, nt), co,
                                      o, out_u8, out_s8);
                        vt__cnn_store(L, vt__cnn_dot1(L, co, wtaps, in, ioff2, woff2, tlen2, nt),
                                      co, o2, out_u8, out_s8);
                    }
                    ++ox;
                    continue;
                }
            }
#endif
#if VT_CNN_SSE2
            /* a single-channel input with all nine taps in the frame: the first layer
             * away from the borders (d = 1: three merged rows; d = 2: nine taps) */
            k9 = cin == 1 && k == 3 && ((nt == 3 && tlen[0] == 3) || nt == 9);
            if (k9) {
                int32_t n = 0;
                for (t = 0; t < nt; ++t) {
                    for (ci = 0; ci < tlen[t]; ++ci) {
                        px[n++] = in[ioff[t] + (size_t)ci];
                    }
                }
            }
#endif
            for (co = 0; co + 4 <= cout; co += 4) {
                int32_t acc[4];
#if VT_CNN_SSE2
                if (k9) {
                    vt__cnn_dot4_k9(L->w + (size_t)co * wtaps, px, acc);
                } else
#endif
                {
                    vt__cnn_dot4(L->w + (size_t)co * wtaps, wtaps, in, ioff, woff, tlen, nt, acc);
                }
                vt__cnn_store(L, L->bias[co] + acc[0], co, o, out_u8, out_s8);
                vt__cnn_store(L, L->bias[co + 1] + acc[1], co + 1, o, out_u8, out_s8);
                vt__cnn_store(L, L->bias[co + 2] + acc[2], co + 2, o, out_u8, out_s8);
                vt__cnn_store(L, L->bias[co + 3] + acc[3], co + 3, o, out_u8, out_s8);
            }
            for (; co < cout; ++co) {
                vt__cnn_store(L, vt__cnn_dot1(L, co, wtaps, in, ioff, woff, tlen, nt), co, o,
                              out_u8, out_s8);
            }
        }
    }
}

/* vt__cnn_isa()'s bits, 0 in a build without the AVX2 loops. Asked once a forward pass
 * (once a frame in vt_cnn_detect_frame), not once a layer: cpuid is slow under a
 * hypervisor. */
static int vt__cnn_cpu(void)
{
#if VT_CNN_AVX2
    return vt__cnn_isa();
#else
    return 0;
#endif
}

/* vt_cnn_forward with the CPU's bits given. */
static vt_status vt__cnn_forward(const vt_cnn_model *m, const uint8_t *img, int32_t w, int32_t h,
                                 int32_t stride, uint8_t *work, size_t work_bytes, int8_t *out,
                                 size_t out_len, int isa)
{
    size_t sizes[VT_CNN_MAX_LAYERS], r0, r1, rs;
    int32_t gw, gh, i, iw, ih;
    const uint8_t *in;
    vt_status s;
    if (img == NULL || out == NULL) {
        return VT_E_ARG;
    }
    s = vt__cnn_plan(m, w, h, sizes, &gw, &gh);
    if (s != VT_OK) {
        return s;
    }
    if (stride < w) {
        return VT_E_SIZE;
    }
    vt__cnn_regions(m, sizes, &r0, &r1);
    if (work == NULL && r0 + r1 > 0) {
        return VT_E_ARG;
    }
    if (work_bytes < r0 + r1 || out_len < sizes[m->n_layers - 1]) {
        return VT_E_CAPACITY;
    }
    in = img;
    iw = w;
    ih = h;
    rs = (size_t)stride;
    for (i = 0; i < m->n_layers; ++i) {
        const vt_cnn_layer *L = &m->layer[i];
        int32_t ow = (iw + L->stride - 1) / L->stride, oh = (ih + L->stride - 1) / L->stride;
        if (i == m->n_layers - 1) {
            vt__cnn_layer(L, in, iw, ih, rs, ow, oh, NULL, out, isa);
        } else {
            uint8_t *dst = (i & 1) ? work + r0 : work;
            vt__cnn_layer(L, in, iw, ih, rs, ow, oh, dst, NULL, isa);
            in = dst;
            rs = (size_t)ow * (size_t)L->cout;
        }
        iw = ow;
        ih = oh;
    }
    return VT_OK;
}

vt_status vt_cnn_forward(const vt_cnn_model *m, const uint8_t *img, int32_t w, int32_t h,
                         int32_t stride, uint8_t *work, size_t work_bytes, int8_t *out,
                         size_t out_len)
{
    return vt__cnn_forward(m, img, w, h, stride, work, work_bytes, out, out_len, vt__cnn_cpu());
}

/* 1 if cell (x, y) is a peak: heat >= thr and >= every in-grid neighbour's. */
static int vt__cnn_is_peak(const int8_t *out, int32_t gw, int32_t gh, int32_t x, int32_t y,
                           int32_t thr)
{
    int32_t hv = out[((size_t)y * (size_t)gw + (size_t)x) * VT_CNN_OUT_CH], dx, dy;
    if (hv < thr) {
        return 0;
    }
    for (dy = -1; dy <= 1; ++dy) {
        int32_t ny = y + dy;
        if (ny < 0 || ny >= gh) {
            continue;
        }
        for (dx = -1; dx <= 1; ++dx) {
            int32_t nx = x + dx;
            if (nx < 0 || nx >= gw || (dx == 0 && dy == 0)) {
                continue;
            }
            if (out[((size_t)ny * (size_t)gw + (size_t)nx) * VT_CNN_OUT_CH] > hv) {
                return 0;
            }
        }
    }
    return 1;
}

/* Q4 level px -> full-frame px: floor((v 2^ss + 8) / 16); ss = -1 (the upsampled
 * band, half scale): floor((v + 16) / 32), the same rule with 2^-1. */
static int32_t vt__cnn_px(int64_t v_q4, int32_t ss)
{
    if (ss < 0) {
        return (int32_t)vt__floor_shr64(v_q4 + 16, 5);
    }
    return (int32_t)vt__floor_shr64(v_q4 * ((int64_t)1 << ss) + 8, 4);
}

/* The box of the peak at (x, y) (cnn.h's decode). */
static void vt__cnn_box(const vt_cnn_model *m, const int8_t *cell, int32_t x, int32_t y,
                        int32_t ss, vt_cnn_box *b)
{
    const uint16_t *lut = m->side_lut;
    int32_t S = m->out_stride;
    int64_t cx = ((int64_t)x * S + S / 2) * 16, cy = ((int64_t)y * S + S / 2) * 16;
    b->l = vt__cnn_px(cx - lut[0 * 256 + cell[1] + 128], ss);
    b->t = vt__cnn_px(cy - lut[1 * 256 + cell[2] + 128], ss);
    b->r = vt__cnn_px(cx + lut[2 * 256 + cell[3] + 128], ss) - 1;
    b->b = vt__cnn_px(cy + lut[3 * 256 + cell[4] + 128], ss) - 1;
    b->score = cell[0];
}

/* vt_cnn_decode after its checks; scale_shift -1..VT_CNN_MAX_LEVEL (-1: the upsampled
 * band, only from vt_cnn_detect_frame). */
static void vt__cnn_decode(const vt_cnn_model *m, const int8_t *out, int32_t gw, int32_t gh,
                           int32_t thr, int32_t scale_shift, vt_cnn_box *boxes, int32_t cap,
                           int32_t *n, int32_t *n_peaks);

vt_status vt_cnn_decode(const vt_cnn_model *m, const int8_t *out, int32_t gw, int32_t gh,
                        int32_t thr, int32_t scale_shift, vt_cnn_box *boxes, int32_t cap,
                        int32_t *n, int32_t *n_peaks)
{
    vt_status s;
    if (n != NULL) {
        *n = 0;
    }
    if (n_peaks != NULL) {
        *n_peaks = 0;
    }
    if (out == NULL || boxes == NULL || n == NULL || n_peaks == NULL || cap < 1 ||
        scale_shift < 0 || scale_shift > VT_CNN_MAX_LEVEL) {
        return VT_E_ARG;
    }
    s = vt_cnn_check_model(m);
    if (s != VT_OK) {
        return s;
    }
    if (gw < 1 || gh < 1 || gw > VT_MAX_WIDTH || gh > VT_MAX_HEIGHT) {
        return VT_E_SIZE;
    }
    vt__cnn_decode(m, out, gw, gh, thr, scale_shift, boxes, cap, n, n_peaks);
    return VT_OK;
}

static void vt__cnn_decode(const vt_cnn_model *m, const int8_t *out, int32_t gw, int32_t gh,
                           int32_t thr, int32_t scale_shift, vt_cnn_box *boxes, int32_t cap,
                           int32_t *n, int32_t *n_peaks)
{
    /* pos[heat + 128]: first the peak count per heat, then the output slot of the
     * next peak of that heat (a counting sort: heat descending, raster order kept) */
    int32_t pos[256], x, y, v, run = 0;
    for (v = 0; v < 256; ++v) {
        pos[v] = 0;
    }
    for (y = 0; y < gh; ++y) {
        for (x = 0; x < gw; ++x) {
            if (vt__cnn_is_peak(out, gw, gh, x, y, thr)) {
                ++pos[out[((size_t)y * (size_t)gw + (size_t)x) * VT_CNN_OUT_CH] + 128];
            }
        }
    }
    for (v = 255; v >= 0; --v) {
        int32_t c = pos[v];
        pos[v] = run;
        run += c;
    }
    for (y = 0; y < gh; ++y) {
        for (x = 0; x < gw; ++x) {
            const int8_t *cell = out + ((size_t)y * (size_t)gw + (size_t)x) * VT_CNN_OUT_CH;
            int32_t p;
            if (!vt__cnn_is_peak(out, gw, gh, x, y, thr)) {
                continue;
            }
            p = pos[cell[0] + 128]++;
            if (p < cap) {
                vt__cnn_box(m, cell, x, y, scale_shift, &boxes[p]);
            }
        }
    }
    *n_peaks = run;
    *n = run < cap ? run : cap;
}


/* ------------------------------------------------------------ frame-level detection */

vt_status vt_cnn_cfg_default(vt_cnn_cfg *cfg)
{
    static const vt_cnn_cfg def = VT_CNN_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

/* The upsampled band is off only with all four of its fields 0. */
static int vt__cnn_up_on(const vt_cnn_cfg *cfg)
{
    return cfg->up_top_permille != 0 || cfg->up_bottom_permille != 0 ||
           cfg->up_left_permille != 0 || cfg->up_right_permille != 0;
}

vt_status vt_cnn_cfg_check(const vt_cnn_cfg *cfg)
{
    if (cfg == NULL || cfg->first_level < 0 || cfg->first_level > VT_CNN_MAX_LEVEL - 1 ||
        cfg->n_levels < 1 || cfg->n_levels > VT_CNN_MAX_RUN_LEVELS ||
        cfg->first_level + cfg->n_levels - 1 > VT_CNN_MAX_LEVEL || cfg->cap_per_level < 1 ||
        cfg->cap_per_level > VT_CNN_MAX_PEAKS ||
        (int64_t)cfg->n_levels * cfg->cap_per_level > VT_MAX_NMS_BOXES ||
        cfg->nms_iou_permille < 0 || cfg->nms_iou_permille > 1000 ||
        cfg->nms_contain_permille < 0 || cfg->nms_contain_permille > 1000 ||
        cfg->l0_top_permille < 0 || cfg->l0_top_permille >= cfg->l0_bottom_permille ||
        cfg->l0_bottom_permille > 1000 || cfg->stretch_tail_permille < 0 ||
        cfg->stretch_tail_permille > 100) {
        return VT_E_ARG;
    }
    if (vt__cnn_up_on(cfg)) {
        if (cfg->up_top_permille < 0 || cfg->up_top_permille >= cfg->up_bottom_permille ||
            cfg->up_bottom_permille > 1000 || cfg->up_left_permille < 0 ||
            cfg->up_left_permille >= cfg->up_right_permille || cfg->up_right_permille > 1000 ||
            (int64_t)(cfg->n_levels + 1) * cfg->cap_per_level > VT_MAX_NMS_BOXES) {
            return VT_E_ARG;
        }
    }
    return VT_OK;
}

/* One band's rows moved d permille, its height kept, stopped at the frame's edges (cnn.h). */
static void vt__cnn_band_move(int32_t *top, int32_t *bottom, int32_t d)
{
    int32_t span = *bottom - *top;
    int32_t t = *top + d; /* |d| <= 1459 and 0 <= top <= 1000: no overflow */
    if (t > 1000 - span) {
        t = 1000 - span;
    }
    if (t < 0) {
        t = 0;
    }
    *top = t;
    *bottom = t + span;
}

vt_status vt_cnn_cfg_at_horizon(const vt_cnn_cfg *cfg, int32_t horizon_q16, vt_cnn_cfg *out)
{
    vt_cnn_cfg c;
    int64_t num;
    int32_t d;
    if (out == NULL || vt_cnn_cfg_check(cfg) != VT_OK || horizon_q16 < -65536 ||
        horizon_q16 > 65536) {
        return VT_E_ARG;
    }
    c = *cfg;
    /* floor division by 2^16 of a signed numerator (|num| < 2^28): an arithmetic shift
     * is implementation-defined for negatives in C99, so shift a nonnegative value */
    num = ((int64_t)horizon_q16 - VT_CNN_REF_HORIZON_Q16) * 1000 + 32768 + ((int64_t)1 << 30);
    d = (int32_t)((num >> 16) - ((int64_t)1 << 14));
    vt__cnn_band_move(&c.l0_top_permille, &c.l0_bottom_permille, d);
    if (vt__cnn_up_on(&c)) {
        vt__cnn_band_move(&c.up_top_permille, &c.up_bottom_permille, d);
    }
    *out = c;
    return VT_OK;
}

/* A band's rows y0 .. y1 - 1 of an h-row frame (0 <= top < bottom <= 1000, h >= 1): cnn.h's
 * floor / ceil in int64 (h <= 4096 and permille <= 1000, so exact and nonnegative). */
static void vt__cnn_band(int32_t h, int32_t top, int32_t bottom, int32_t *y0, int32_t *y1)
{
    *y0 = (int32_t)(((int64_t)h * top) / 1000);
    *y1 = (int32_t)(((int64_t)h * bottom + 999) / 1000);
}

/* Alignment of the work buffer's box regions (int32 structs): the first region starts
 * at the first multiple of VT__CNN_ALIGN in work, so the size query adds
 * VT__CNN_ALIGN - 1 bytes for any caller's pointer (a static uint8_t array in firmware
 * has no alignment of its own). */
#define VT__CNN_ALIGN 8

/* The work buffer's regions for one frame (offsets from the aligned start). */
typedef struct {
    int32_t lw[VT_CNN_MAX_LEVEL + 1]; /* level sizes, level 0 = the frame */
    int32_t lh[VT_CNN_MAX_LEVEL + 1];
    int32_t y0;    /* level 0's band: rows y0 .. y0 + bh - 1 (bh >= 1) */
    int32_t bh;
    size_t sbox;   /* vt_scored_box[n_levels cap_per_level]          */
    size_t cbox;   /* vt_cnn_box[cap_per_level]: one level's decode  */
    size_t lvl[2]; /* level images: odd levels, even levels >= 2     */
    size_t fwd;    /* vt_cnn_forward's work                          */
    size_t out;    /* the forward output (int8)                      */
    size_t str;    /* the stretched frame (w h bytes), when stretched */
    int32_t ux0;   /* the upsampled band's source rectangle, and its 2x size (0: off) */
    int32_t uy0;
    int32_t uw;
    int32_t uh;
    size_t up;     /* its 2x image (uw uh bytes)                    */
    size_t fwd_bytes;
    size_t out_bytes;
    size_t total;  /* bytes after the aligned start                  */
} vt__cnn_frame_plan;

/* The plan for a w x h frame (m, cfg valid; w, h in range): every run level's forward
 * sizes through vt__cnn_plan, so they are the single-level functions' own. */
static vt_status vt__cnn_frame_layout(const vt_cnn_model *m, const vt_cnn_cfg *cfg, int32_t w,
                                      int32_t h, vt__cnn_frame_plan *pl)
{
    int32_t k, y1, last = cfg->first_level + cfg->n_levels - 1;
    size_t lvl_bytes[2] = {0, 0}, off;
    pl->lw[0] = w;
    pl->lh[0] = h;
    vt__cnn_band(h, cfg->l0_top_permille, cfg->l0_bottom_permille, &pl->y0, &y1);
    pl->bh = y1 - pl->y0;
    pl->ux0 = pl->uy0 = pl->uw = pl->uh = 0;
    if (vt__cnn_up_on(cfg)) {
        int32_t e;
        vt__cnn_band(w, cfg->up_left_permille, cfg->up_right_permille, &pl->ux0, &e);
        pl->uw = 2 * (e - pl->ux0);
        vt__cnn_band(h, cfg->up_top_permille, cfg->up_bottom_permille, &pl->uy0, &e);
        pl->uh = 2 * (e - pl->uy0);
    }
    for (k = 1; k <= VT_CNN_MAX_LEVEL; ++k) {
        pl->lw[k] = (pl->lw[k - 1] + 1) / 2;
        pl->lh[k] = (pl->lh[k - 1] + 1) / 2;
    }
    for (k = 1; k <= last; ++k) {
        size_t b = (size_t)pl->lw[k] * (size_t)pl->lh[k];
        size_t *r = &lvl_bytes[(k & 1) ? 0 : 1];
        *r = b > *r ? b : *r;
    }
    pl->fwd_bytes = 0;
    pl->out_bytes = 0;
    /* k = last + 1 stands for the upsampled band, when on */
    for (k = cfg->first_level; k <= last + (pl->uw > 0 ? 1 : 0); ++k) {
        size_t sizes[VT_CNN_MAX_LAYERS], r0, r1, ob;
        int32_t gw, gh;
        /* level 0 runs on its band only: the same sizes vt_cnn_detect_frame passes */
        vt_status s = k > last ? vt__cnn_plan(m, pl->uw, pl->uh, sizes, &gw, &gh)
                               : vt__cnn_plan(m, pl->lw[k], k == 0 ? pl->bh : pl->lh[k], sizes,
                                              &gw, &gh);
        if (s != VT_OK) {
            return s;
        }
        vt__cnn_regions(m, sizes, &r0, &r1);
        ob = sizes[m->n_layers - 1];
        pl->fwd_bytes = r0 + r1 > pl->fwd_bytes ? r0 + r1 : pl->fwd_bytes;
        pl->out_bytes = ob > pl->out_bytes ? ob : pl->out_bytes;
    }
    /* structs first (aligned), then the byte regions */
    pl->sbox = 0;
    off = (size_t)(cfg->n_levels + (pl->uw > 0 ? 1 : 0)) * (size_t)cfg->cap_per_level *
          sizeof(vt_scored_box);
    pl->cbox = off;
    off += (size_t)cfg->cap_per_level * sizeof(vt_cnn_box);
    pl->lvl[0] = off;
    off += lvl_bytes[0];
    pl->lvl[1] = off;
    off += lvl_bytes[1];
    pl->fwd = off;
    off += pl->fwd_bytes;
    pl->out = off;
    off += pl->out_bytes;
    pl->str = off;
    off += cfg->stretch_tail_permille > 0 ? (size_t)w * (size_t)h : 0;
    pl->up = off;
    pl->total = off + (size_t)pl->uw * (size_t)pl->uh;
    return VT_OK;
}

vt_status vt_cnn_frame_work_bytes(const vt_cnn_model *m, const vt_cnn_cfg *cfg, int32_t w,
                                  int32_t h, size_t *bytes)
{
    vt__cnn_frame_plan pl;
    vt_status s;
    if (bytes == NULL || vt_cnn_check_model(m) != VT_OK || vt_cnn_cfg_check(cfg) != VT_OK) {
        return VT_E_ARG;
    }
    if (w < 1 || h < 1 || w > VT_MAX_WIDTH || h > VT_MAX_HEIGHT) {
        return VT_E_SIZE;
    }
    s = vt__cnn_frame_layout(m, cfg, w, h, &pl);
    if (s == VT_OK) {
        *bytes = pl.total + (VT__CNN_ALIGN - 1);
    }
    return s;
}

/* The threshold heat_thr + thr_offset, exact in int64, clamped to -128..128: every
 * heat is -128..127, so a lower sum finds the same peaks as -128 and a higher one
 * none, as 128. */
static int32_t vt__cnn_thr(const vt_cnn_model *m, const vt_cnn_cfg *cfg)
{
    int64_t t = (int64_t)m->heat_thr + cfg->thr_offset;
    return (int32_t)(t < -128 ? -128 : (t > 128 ? 128 : t));
}

/* The contrast stretch (cnn.h, vt_cnn_cfg.stretch_tail_permille) of img into dst (w x h,
 * stride w). n <= 4096^2 fits the uint32 histogram; k < n / 2 (tail <= 100 permille), so
 * both scans stop at a level. */
#if VT_CNN_AVX512
/* out[x] = lut[row[x]] for x = 0 .. 64 floor(w / 64) - 1 (AVX-512 VBMI): vpermi2b looks
 * 64 bytes up in 128 entries by their low 7 bits, once in each half of the table, and
 * the high bit picks the half. Returns how many bytes it did. */
__attribute__((target("avx512f,avx512bw,avx512vbmi"))) static int32_t
vt__cnn_lut64(const uint8_t *lut, const uint8_t *row, uint8_t *out, int32_t w)
{
    const __m512i t0 = _mm512_loadu_si512((const void *)lut), t1 = _mm512_loadu_si512((const void *)(lut + 64));
    const __m512i t2 = _mm512_loadu_si512((const void *)(lut + 128)), t3 = _mm512_loadu_si512((const void *)(lut + 192));
    int32_t x;
    for (x = 0; x + 64 <= w; x += 64) {
        __m512i v = _mm512_loadu_si512((const void *)(row + x));
        __m512i lo = _mm512_permutex2var_epi8(t0, v, t1), hi = _mm512_permutex2var_epi8(t2, v, t3);
        _mm512_storeu_si512((void *)(out + x), _mm512_mask_blend_epi8(_mm512_movepi8_mask(v), lo, hi));
    }
    return x;
}
#endif

static void vt__cnn_stretch(const uint8_t *img, int32_t w, int32_t h, int32_t stride, int32_t tail,
                            uint8_t *dst, int isa)
{
    uint32_t hist[256];
    uint8_t lut[256];
    int64_t k = (int64_t)w * h * tail / 1000, c;
    int32_t x, y, lo, hi, span;
#if !VT_CNN_AVX512
    (void)isa;
#endif
#if VT_CNN_SSE2
    /* x86: four partial histograms, so that runs of equal pixels do not wait on one
     * counter's store (4 KB of stack, which the firmware's targets do not spend) */
    uint32_t h4[4][256];
    for (x = 0; x < 256; ++x) {
        h4[0][x] = h4[1][x] = h4[2][x] = h4[3][x] = 0;
    }
    for (y = 0; y < h; ++y) {
        const uint8_t *row = img + (size_t)y * (size_t)stride;
        for (x = 0; x + 4 <= w; x += 4) {
            h4[0][row[x]] += 1;
            h4[1][row[x + 1]] += 1;
            h4[2][row[x + 2]] += 1;
            h4[3][row[x + 3]] += 1;
        }
        for (; x < w; ++x) {
            h4[0][row[x]] += 1;
        }
    }
    for (x = 0; x < 256; ++x) {
        hist[x] = h4[0][x] + h4[1][x] + h4[2][x] + h4[3][x];
    }
#else
    for (x = 0; x < 256; ++x) {
        hist[x] = 0;
    }
    for (y = 0; y < h; ++y) {
        const uint8_t *row = img + (size_t)y * (size_t)stride;
        for (x = 0; x < w; ++x) {
            hist[row[x]] += 1;
        }
    }
#endif
    for (lo = 0, c = 0; lo < 255; ++lo) {
        c += hist[lo];
        if (c > k) {
            break;
        }
    }
    for (hi = 255, c = 0; hi > 0; --hi) {
        c += hist[hi];
        if (c > k) {
            break;
        }
    }
    span = hi - lo < VT_CNN_STRETCH_MIN_SPAN ? VT_CNN_STRETCH_MIN_SPAN : hi - lo;
    for (x = 0; x < 256; ++x) {
        /* (x - lo) 510 + span <= 255 * 510 + 255: no overflow */
        int32_t v = x <= lo ? 0 : ((x - lo) * 510 + span) / (2 * span);
        lut[x] = (uint8_t)(v > 255 ? 255 : v);
    }
    for (y = 0; y < h; ++y) {
        const uint8_t *row = img + (size_t)y * (size_t)stride;
        uint8_t *out = dst + (size_t)y * (size_t)w;
        x = 0;
#if VT_CNN_AVX512
        if ((isa & VT__ISA_VBMI) != 0) {
            x = vt__cnn_lut64(lut, row, out, w);
        }
#endif
        for (; x < w; ++x) {
            out[x] = lut[row[x]];
        }
    }
}

/* The upsampled band's 2x image (cnn.h, vt_cnn_cfg): dst (uw x uh, stride uw) from the
 * frame's rectangle at (x0, y0), neighbours clamped to the frame (w x h). Per axis the
 * weights are 3 and 1, so out = (3 (3 a + b) + (3 c + d) + 8) >> 4 with a the nearest
 * pixel: at most 16 x 255 + 8, no overflow, and >> 4 of a nonnegative value is the floor. */
static void vt__cnn_upsample(const uint8_t *img, int32_t w, int32_t h, int32_t stride,
                             int32_t x0, int32_t y0, int32_t uw, int32_t uh, uint8_t *dst)
{
    int32_t i, j;
    for (i = 0; i < uh; ++i) {
        int32_t cy = y0 + i / 2, ny = (i & 1) ? cy + 1 : cy - 1;
        const uint8_t *ra, *rb;
        uint8_t *o = dst + (size_t)i * (size_t)uw;
        ny = ny < 0 ? 0 : (ny > h - 1 ? h - 1 : ny);
        ra = img + (size_t)cy * (size_t)stride;
        rb = img + (size_t)ny * (size_t)stride;
        for (j = 0; j < uw; ++j) {
            int32_t cx = x0 + j / 2, nx = (j & 1) ? cx + 1 : cx - 1;
            int32_t v;
            nx = nx < 0 ? 0 : (nx > w - 1 ? w - 1 : nx);
            v = 3 * (3 * ra[cx] + ra[nx]) + (3 * rb[cx] + rb[nx]);
            o[j] = (uint8_t)((v + 8) >> 4);
        }
    }
}

vt_status vt_cnn_detect_frame(const vt_cnn_model *m, const vt_cnn_cfg *cfg, const uint8_t *img,
                              int32_t w, int32_t h, int32_t stride, uint8_t *work,
                              size_t work_bytes, vt_cnn_box *boxes, int32_t cap, int32_t *n,
                              int32_t *n_peaks)
{
    vt__cnn_frame_plan pl;
    vt_scored_box *sb;
    vt_cnn_box *cb;
    uint8_t *base;
    size_t pad;
    int32_t k, i, last, total = 0, peaks = 0, kept = 0, thr;
    int isa = vt__cnn_cpu();
    vt_image_u8 src;
    vt_status s;
    if (n != NULL) {
        *n = 0;
    }
    if (n_peaks != NULL) {
        *n_peaks = 0;
    }
    if (img == NULL || work == NULL || boxes == NULL || n == NULL || n_peaks == NULL || cap < 1 ||
        vt_cnn_check_model(m) != VT_OK || vt_cnn_cfg_check(cfg) != VT_OK) {
        return VT_E_ARG;
    }
    s = vt__check_dims(w, h, stride, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    if (s != VT_OK) {
        return s;
    }
    s = vt__cnn_frame_layout(m, cfg, w, h, &pl);
    if (s != VT_OK) {
        return s;
    }
    if (work_bytes < pl.total + (VT__CNN_ALIGN - 1)) {
        return VT_E_CAPACITY;
    }
    /* the pointer's low bits only (uintptr_t: every target this core builds for has it) */
    pad = (size_t)((VT__CNN_ALIGN - ((uintptr_t)work % VT__CNN_ALIGN)) % VT__CNN_ALIGN);
    base = work + pad;
    sb = (vt_scored_box *)(void *)(base + pl.sbox);
    cb = (vt_cnn_box *)(void *)(base + pl.cbox);
    thr = vt__cnn_thr(m, cfg);
    last = cfg->first_level + cfg->n_levels - 1;
    if (cfg->stretch_tail_permille > 0) {
        /* everything below reads the stretched copy; the boxes are the same pixels */
        vt__cnn_stretch(img, w, h, stride, cfg->stretch_tail_permille, base + pl.str, isa);
        img = base + pl.str;
        stride = w;
    }
    src.px = img;
    src.w = w;
    src.h = h;
    src.stride = stride;
    /* k = last + 1: the upsampled band, when on (after every level: the NMS order) */
    for (k = 0; k <= last + (pl.uw > 0 ? 1 : 0); ++k) {
        int32_t gw, gh, nd = 0, np = 0, dx = 0, dy = 0, ss = k;
        int8_t *out = (int8_t *)(void *)(base + pl.out);
        vt_image_u8 run = src; /* set below on every path; initialised for -O1's flow analysis */
        if (k > last) {
            /* from the (stretched) frame, not from a level */
            vt__cnn_upsample(img, w, h, stride, pl.ux0, pl.uy0, pl.uw, pl.uh, base + pl.up);
            run.px = base + pl.up;
            run.w = pl.uw;
            run.h = pl.uh;
            run.stride = pl.uw;
            dx = pl.ux0;
            dy = pl.uy0;
            ss = -1;
        } else if (k > 0) {
            /* level k from level k - 1: odd levels in the first image, even in the second */
            vt_image_u8_mut dst;
            dst.px = base + pl.lvl[(k & 1) ? 0 : 1];
            dst.w = pl.lw[k];
            dst.h = pl.lh[k];
            dst.stride = pl.lw[k];
            s = vt_pyr_down(&src, &dst);
            if (s != VT_OK) {
                return s;
            }
            src.px = dst.px;
            src.w = dst.w;
            src.h = dst.h;
            src.stride = dst.stride;
        }
        if (k < cfg->first_level) {
            continue;
        }
        if (k <= last) {
            run = src;
        }
        if (k == 0) {
            /* level 0: only the band's rows (a view into the caller's frame), its boxes
             * moved back down by y0; src stays the whole frame for the pyramid */
            dy = pl.y0;
            run.px = img + (size_t)pl.y0 * (size_t)stride;
            run.h = pl.bh;
        }
        s = vt__cnn_forward(m, run.px, run.w, run.h, run.stride, base + pl.fwd, pl.fwd_bytes, out,
                            pl.out_bytes, isa);
        if (s == VT_OK) {
            s = vt_cnn_out_size(m, run.w, run.h, &gw, &gh);
        }
        if (s != VT_OK) {
            return s; /* not reached: every argument was checked above */
        }
        vt__cnn_decode(m, out, gw, gh, thr, ss, cb, cfg->cap_per_level, &nd, &np);
        peaks += np;
        for (i = 0; i < nd; ++i) {
            /* clipped to the frame; empty after that (outside, or a zero side) dropped */
            vt_scored_box *o = &sb[total];
            /* dx, dy are nonzero at level 0 and the upsampled band only, where every
             * value is under 2^20 in magnitude (a grid cell < 4096 at stride <= 128, a
             * side < 4096 px) and dx, dy < 4096: no overflow */
            int32_t l = cb[i].l + dx, t = cb[i].t + dy, r = cb[i].r + dx, b = cb[i].b + dy;
            o->box.left = l < 0 ? 0 : l;
            o->box.top = t < 0 ? 0 : t;
            o->box.right = r > w - 1 ? w - 1 : r;
            o->box.bottom = b > h - 1 ? h - 1 : b;
            if (o->box.left > o->box.right || o->box.top > o->box.bottom) {
                continue;
            }
            o->score = cb[i].score;
            o->source = k;
            ++total;
        }
    }
    /* vt_nms' stable sort keeps level, then decode order among equal heats */
    s = vt_nms(sb, total, cfg->nms_iou_permille, cfg->nms_contain_permille, &kept);
    if (s != VT_OK) {
        return s; /* not reached: total <= VT_MAX_NMS_BOXES (cfg check), boxes in the frame */
    }
    kept = kept < cap ? kept : cap;
    for (i = 0; i < kept; ++i) {
        boxes[i].l = sb[i].box.left;
        boxes[i].t = sb[i].box.top;
        boxes[i].r = sb[i].box.right;
        boxes[i].b = sb[i].box.bottom;
        boxes[i].score = sb[i].score;
    }
    *n = kept;
    *n_peaks = peaks;
    return VT_OK;
}
