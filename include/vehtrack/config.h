/* vehtrack/config.h -- compile-time capacities, the whole RAM bill of the library.
 *
 * Every buffer the library keeps is sized from these numbers, so sizeof() of a
 * state struct is known at link time and nothing is allocated at run time.
 * Override any of them with -D on the compiler command line (e.g.
 * -DVT_MAX_WIDTH=640); cffi reads the values from C, Python never copies them. */
#ifndef VEHTRACK_CONFIG_H
#define VEHTRACK_CONFIG_H

/* Largest frame the library accepts. 1920x1080 keeps an integral image of a
 * full frame below 2^32 (1920*1080*255 < 2^29), so uint32 sums never wrap. */
#ifndef VT_MAX_WIDTH
#define VT_MAX_WIDTH 1920
#endif
#ifndef VT_MAX_HEIGHT
#define VT_MAX_HEIGHT 1080
#endif

/* Largest patch for normalised cross-correlation. 65536 pixels keeps
 * n*sum(a*b) below 2^48, which the Q1.14 normalisation in vt_ncc_u8 needs. */
#ifndef VT_MAX_PATCH_PIXELS
#define VT_MAX_PATCH_PIXELS 65536
#endif

/* Tracks the tracker can hold at once. */
#ifndef VT_MAX_TRACKS
#define VT_MAX_TRACKS 16
#endif

#if VT_MAX_WIDTH < 1 || VT_MAX_HEIGHT < 1 || VT_MAX_WIDTH > 4096 || VT_MAX_HEIGHT > 4096
#error "VT_MAX_WIDTH and VT_MAX_HEIGHT must be in 1..4096"
#endif
#if (VT_MAX_WIDTH) * (VT_MAX_HEIGHT) > 4194304
#error "VT_MAX_WIDTH*VT_MAX_HEIGHT must stay <= 2^22 so uint32 integral sums cannot wrap"
#endif
#if VT_MAX_PATCH_PIXELS < 1 || VT_MAX_PATCH_PIXELS > 65536
#error "VT_MAX_PATCH_PIXELS must be in 1..65536"
#endif

#endif /* VEHTRACK_CONFIG_H */
