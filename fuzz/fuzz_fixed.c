/* fuzz_fixed.c -- the fixed-point vocabulary (vehtrack/fixed.h), sin/cos
 * (vehtrack/trig.h) and vt_status_name: every helper is total, so any int32 /
 * int64 argument must give a defined result; each is checked against the exact
 * value computed here in 128 bits. */
#include "fuzz.h"
#include "vehtrack/fixed.h"
#include "vehtrack/trig.h"

static int64_t raw64(fz *f)
{
    uint64_t u = (uint64_t)fz_u32(f) | ((uint64_t)fz_u32(f) << 32);
    switch (fz_u8(f) & 7u) {
    case 0: return INT64_MIN;
    case 1: return INT64_MAX;
    case 2: return -1;
    case 3: return (int64_t)(int32_t)u;
    default: return u <= (uint64_t)INT64_MAX ? (int64_t)u : -(int64_t)(~u) - 1;
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    int32_t a = fz_edge(&f, VT_Q16_ONE), b = fz_edge(&f, VT_Q16_ONE);
    int64_t x = raw64(&f), d = raw64(&f), q = 0;
    int n = fz_u8(&f) & 63;
    vt_q16 r = 0;
    vt_q14 sn = 0, cs = 0;
    const char *name = NULL;
    __int128 e;
    vt_status s;

    /* floor(x / 2^n), exact for every int64 (issue 11: INT64_MIN). */
    q = vt__floor_shr64(x, n);
    e = (__int128)q * ((__int128)1 << n);
    FZ_ASSERT(e <= (__int128)x && (__int128)x < e + ((__int128)1 << n));

    e = (__int128)a * b + (1 << 15);
    e = e >= 0 ? e >> 16 : -((-e + 65535) >> 16);
    e = e > INT32_MAX ? INT32_MAX : (e < INT32_MIN ? INT32_MIN : e);
    FZ_ASSERT(vt_q16_mul_sat(a, b) == (int32_t)e);
    (void)vt_q16_add_sat(a, b);
    (void)vt_q16_sub_sat(a, b);
    (void)vt_q16_mul_q14(a, (vt_q14)b);
    (void)vt_q14_mul_sat((vt_q14)a, (vt_q14)b);
    (void)vt_q16_round(a);
    (void)vt_q16_from_int(a);
    (void)vt_sat_s16(a);
    FZ_ASSERT((uint64_t)vt_isqrt_u32((uint32_t)a) * vt_isqrt_u32((uint32_t)a) <= (uint32_t)a);
    {
        uint64_t u = (uint64_t)x, rt = vt_isqrt_u64(u);
        FZ_ASSERT(rt * rt <= u && (unsigned __int128)(rt + 1) * (rt + 1) > u);
    }
    s = vt_div_round_s64(x, d, fz_u8(&f) == 0xFF ? NULL : &q);
    fz_status(s);
    s = vt_q16_div(a, b, fz_u8(&f) == 0xFF ? NULL : &r);
    fz_status(s);
    s = vt_q16_recip(a, fz_u8(&f) == 0xFF ? NULL : &r);
    fz_status(s);
    s = vt_sincos_q14(a, fz_u8(&f) == 0xFF ? NULL : &sn, fz_u8(&f) == 0xFF ? NULL : &cs);
    fz_status(s);
    if (s == VT_OK) {
        FZ_ASSERT(sn >= -VT_Q14_ONE && sn <= VT_Q14_ONE && cs >= -VT_Q14_ONE && cs <= VT_Q14_ONE);
    }
    s = vt_status_name(b, fz_u8(&f) == 0xFF ? NULL : &name);
    fz_status(s);
    fz_close(&f);
    return 0;
}
