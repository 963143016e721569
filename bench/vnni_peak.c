/* vnni_peak.c -- how many int8 multiply-adds one x86 core retires a second when nothing but
 * the instruction limits it: independent chains of vpdpbusd (AVX-512 VNNI on zmm, AVX-VNNI
 * on ymm), so no chain waits on its own latency. The CNN's loops (c/cnn.c) cannot beat this
 * rate; tools/cnn_macs.py --rate turns it into a floor for a model's frame.
 *
 *   cc -O2 bench/vnni_peak.c -o build/vnni_peak && build/vnni_peak
 *
 * A benchmark, not part of the library; x86-64 with gcc or clang only. It asks the CPU first
 * and skips a form the CPU lacks. */
#include <cpuid.h>
#include <immintrin.h>
#include <stdio.h>
#include <time.h>

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* 12 chains of n vpdpbusd each; the asm barrier keeps x and w opaque, and distinct starting
 * sums keep the compiler from merging the chains. */
__attribute__((target("avx512f,avx512bw,avx512vnni"), noinline)) static int zmm(long n)
{
    __m512i a0 = _mm512_set1_epi32(0), a1 = _mm512_set1_epi32(1), a2 = _mm512_set1_epi32(2);
    __m512i a3 = _mm512_set1_epi32(3), a4 = _mm512_set1_epi32(4), a5 = _mm512_set1_epi32(5);
    __m512i a6 = _mm512_set1_epi32(6), a7 = _mm512_set1_epi32(7), a8 = _mm512_set1_epi32(8);
    __m512i a9 = _mm512_set1_epi32(9), a10 = _mm512_set1_epi32(10), a11 = _mm512_set1_epi32(11);
    __m512i x = _mm512_set1_epi8(1), w = _mm512_set1_epi8(1);
    long i;
    for (i = 0; i < n; ++i) {
        __asm__ volatile("" : "+v"(x), "+v"(w));
        a0 = _mm512_dpbusd_epi32(a0, x, w);
        a1 = _mm512_dpbusd_epi32(a1, x, w);
        a2 = _mm512_dpbusd_epi32(a2, x, w);
        a3 = _mm512_dpbusd_epi32(a3, x, w);
        a4 = _mm512_dpbusd_epi32(a4, x, w);
        a5 = _mm512_dpbusd_epi32(a5, x, w);
        a6 = _mm512_dpbusd_epi32(a6, x, w);
        a7 = _mm512_dpbusd_epi32(a7, x, w);
        a8 = _mm512_dpbusd_epi32(a8, x, w);
        a9 = _mm512_dpbusd_epi32(a9, x, w);
        a10 = _mm512_dpbusd_epi32(a10, x, w);
        a11 = _mm512_dpbusd_epi32(a11, x, w);
    }
    a0 = _mm512_add_epi32(_mm512_add_epi32(a0, a1), _mm512_add_epi32(a2, a3));
    a4 = _mm512_add_epi32(_mm512_add_epi32(a4, a5), _mm512_add_epi32(a6, a7));
    a8 = _mm512_add_epi32(_mm512_add_epi32(a8, a9), _mm512_add_epi32(a10, a11));
    return _mm512_reduce_add_epi32(_mm512_add_epi32(_mm512_add_epi32(a0, a4), a8));
}

/* The same with 8 chains on ymm (the 16 ymm registers). */
__attribute__((target("avx2,avxvnni"), noinline)) static int ymm(long n)
{
    __m256i a0 = _mm256_set1_epi32(0), a1 = _mm256_set1_epi32(1), a2 = _mm256_set1_epi32(2);
    __m256i a3 = _mm256_set1_epi32(3), a4 = _mm256_set1_epi32(4), a5 = _mm256_set1_epi32(5);
    __m256i a6 = _mm256_set1_epi32(6), a7 = _mm256_set1_epi32(7);
    __m256i x = _mm256_set1_epi8(1), w = _mm256_set1_epi8(1);
    long i;
    for (i = 0; i < n; ++i) {
        __asm__ volatile("" : "+x"(x), "+x"(w));
        a0 = _mm256_dpbusd_avx_epi32(a0, x, w);
        a1 = _mm256_dpbusd_avx_epi32(a1, x, w);
        a2 = _mm256_dpbusd_avx_epi32(a2, x, w);
        a3 = _mm256_dpbusd_avx_epi32(a3, x, w);
        a4 = _mm256_dpbusd_avx_epi32(a4, x, w);
        a5 = _mm256_dpbusd_avx_epi32(a5, x, w);
        a6 = _mm256_dpbusd_avx_epi32(a6, x, w);
        a7 = _mm256_dpbusd_avx_epi32(a7, x, w);
    }
    a0 = _mm256_add_epi32(_mm256_add_epi32(a0, a1), _mm256_add_epi32(a2, a3));
    a4 = _mm256_add_epi32(_mm256_add_epi32(a4, a5), _mm256_add_epi32(a6, a7));
    return _mm256_extract_epi32(_mm256_add_epi32(a0, a4), 0);
}

int main(void)
{
    const long n = 200000000;
    unsigned int a, b, c, d;
    int has512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                 __builtin_cpu_supports("avx512vnni");
    int has256 = __builtin_cpu_supports("avx2") && __get_cpuid_count(7, 1, &a, &b, &c, &d) &&
                 ((a >> 4) & 1u) != 0;
    int r;
    for (r = 0; r < 3; ++r) {
        if (has512) {
            double t = now(), dt;
            int s = zmm(n);
            dt = now() - t;
            printf("zmm vpdpbusd: %.2f G/s = %.1f G multiply-adds/s (%d)\n", 12.0 * n / dt / 1e9,
                   12.0 * n * 64 / dt / 1e9, s);
        }
        if (has256) {
            double t = now(), dt;
            int s = ymm(n);
            dt = now() - t;
            printf("ymm vpdpbusd: %.2f G/s = %.1f G multiply-adds/s (%d)\n", 8.0 * n / dt / 1e9,
                   8.0 * n * 32 / dt / 1e9, s);
        }
    }
    if (!has512 && !has256) {
        printf("this CPU has neither AVX-512 VNNI nor AVX-VNNI\n");
    }
    return 0;
}
