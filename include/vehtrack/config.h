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

/* Kalman filter sizes (vt_kf): states and measurements. The thesis's
 * bottom-edge model needs 6 and 3; 8 and 4 leave room for a full box model.
 * sizeof(vt_kf) = 8 + 4 (MX + MZ) (padded to 8) + 8 (3 MX^2 + 2 MX MZ + 2 MZ^2)
 * bytes, 2360 with these values. */
#ifndef VT_KF_MAX_X
#define VT_KF_MAX_X 8
#endif
#ifndef VT_KF_MAX_Z
#define VT_KF_MAX_Z 4
#endif

/* Shadow hypothesis stage (vt_shadow_state): open shadow-edge groups while
 * merging rows, closed groups that passed the width check, 12 bytes each. A run
 * or group past these is dropped and counted, never written out of bounds. */
#ifndef VT_MAX_SHADOW_ACTIVE
#define VT_MAX_SHADOW_ACTIVE 64
#endif
#ifndef VT_MAX_SHADOW_CAND
#define VT_MAX_SHADOW_CAND 64
#endif
/* Vehicle hypotheses (bottom edges) and verified boxes per frame in
 * vt_detect_result (12 and 16 bytes each). */
#ifndef VT_MAX_HYPOTHESES
#define VT_MAX_HYPOTHESES 32
#endif
#ifndef VT_MAX_BOXES
#define VT_MAX_BOXES 32
#endif
#if VT_MAX_SHADOW_ACTIVE < 1 || VT_MAX_SHADOW_CAND < 1 || VT_MAX_HYPOTHESES < 1 || \
    VT_MAX_BOXES < 1 || VT_MAX_SHADOW_ACTIVE > 32767 || VT_MAX_SHADOW_CAND > 32767
#error "shadow/detect capacities must be in 1..32767"
#endif

/* Lane stage (vt_lane_state, vehtrack/lane.h). The frame is box-downscaled to a
 * working frame of at most VT_LANE_MAX_WORK_W x VT_LANE_MAX_WORK_H; the row buffers
 * (4 bytes per column) and per-row indices (4 bytes per row) follow from these.
 * Marking centres (2 bytes each) are kept per frame up to VT_LANE_MAX_MARKS, at most
 * VT_LANE_MAX_ROW_MARKS per row. The Hough accumulator of one half holds
 * VT_LANE_ACC_CELLS uint16 cells (64 KB): 77 theta bins x ~400 rho bins, the worst
 * case of a 640x480 working frame at 1 degree and 1 px. Candidate lines per half:
 * VT_LANE_MAX_PEAKS; polyline vertices per lane: VT_LANE_MAX_VERTS. */
#ifndef VT_LANE_MAX_WORK_W
#define VT_LANE_MAX_WORK_W 640
#endif
#ifndef VT_LANE_MAX_WORK_H
#define VT_LANE_MAX_WORK_H 480
#endif
#ifndef VT_LANE_MAX_MARKS
#define VT_LANE_MAX_MARKS 4096
#endif
#ifndef VT_LANE_MAX_ROW_MARKS
#define VT_LANE_MAX_ROW_MARKS 32
#endif
#ifndef VT_LANE_MAX_THETA
#define VT_LANE_MAX_THETA 181
#endif
#ifndef VT_LANE_ACC_CELLS
#define VT_LANE_ACC_CELLS 32768
#endif
#ifndef VT_LANE_MAX_PEAKS
#define VT_LANE_MAX_PEAKS 8
#endif
#ifndef VT_LANE_MAX_VERTS
#define VT_LANE_MAX_VERTS 24
#endif
/* Every lane line of a frame (vt_lane_result.lines_all): the four slots plus the
 * further outer lines through the vanishing point; beyond this many, the weakest
 * further lines are left out (counted in lines_all_dropped). */
#ifndef VT_LANE_MAX_LINES
#define VT_LANE_MAX_LINES 8
#endif
#if VT_LANE_MAX_WORK_W < 16 || VT_LANE_MAX_WORK_W > 4096 || VT_LANE_MAX_WORK_H < 16 || \
    VT_LANE_MAX_WORK_H > 4096 || VT_LANE_MAX_MARKS < 1 || VT_LANE_MAX_MARKS > 65535 ||  \
    VT_LANE_MAX_ROW_MARKS < 1 || VT_LANE_MAX_THETA < 1 || VT_LANE_ACC_CELLS < 1 ||     \
    VT_LANE_ACC_CELLS > 16777216 || VT_LANE_MAX_PEAKS < 1 || VT_LANE_MAX_VERTS < 4 || \
    VT_LANE_MAX_LINES < 4 || VT_LANE_MAX_LINES > 64
#error "lane capacities out of range (see vehtrack/config.h)"
#endif

/* Classifier (vehtrack/classify.h). vt_hog_ws holds the normalised HOG blocks of
 * one prepared image (a band of a pyramid level) of at most VT_CLS_MAX_W x
 * VT_CLS_MAX_H pixels: 72 bytes per 8x8 cell, 263 KB at 1280 x 192. vt_gist_ws
 * holds 32 uint32 energies per cell of at most VT_GIST_MAX_W x VT_GIST_MAX_H
 * (GIST verifies boxes; it is not the sliding-window descriptor). Models'
 * windows are at most VT_CLS_MAX_WIN square, descriptors VT_CLS_MAX_DIM long. */
#ifndef VT_CLS_MAX_W
#define VT_CLS_MAX_W 1280
#endif
#ifndef VT_CLS_MAX_H
#define VT_CLS_MAX_H 192
#endif
#ifndef VT_CLS_MAX_WIN
#define VT_CLS_MAX_WIN 128
#endif
#ifndef VT_GIST_MAX_W
#define VT_GIST_MAX_W 128
#endif
#ifndef VT_GIST_MAX_H
#define VT_GIST_MAX_H 128
#endif
#define VT_CLS_MAX_DIM (((VT_CLS_MAX_WIN) / 8 - 1) * ((VT_CLS_MAX_WIN) / 8 - 1) * 36 > 512 ? \
                        ((VT_CLS_MAX_WIN) / 8 - 1) * ((VT_CLS_MAX_WIN) / 8 - 1) * 36 : 512)
#if VT_CLS_MAX_W < 16 || VT_CLS_MAX_H < 16 || VT_CLS_MAX_W > 4096 || VT_CLS_MAX_H > 4096 || \
    VT_CLS_MAX_WIN < 32 || VT_CLS_MAX_WIN > 256 || VT_GIST_MAX_W < VT_CLS_MAX_WIN ||         \
    VT_GIST_MAX_H < VT_CLS_MAX_WIN || VT_GIST_MAX_W > 1024 || VT_GIST_MAX_H > 1024
#error "classifier capacities out of range (see vehtrack/config.h)"
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

#if VT_KF_MAX_X < 1 || VT_KF_MAX_X > 16 || VT_KF_MAX_Z < 1 || VT_KF_MAX_Z > 8
#error "VT_KF_MAX_X must be in 1..16 and VT_KF_MAX_Z in 1..8"
#endif

/* Edge-curve tracking (vehtrack/edge_track.h): the largest crop whose edge
 * curves are computed (5 bytes per pixel of workspace: 320 KB at 65536, a
 * 256 x 256 crop) and the curve points kept per track (4 bytes each). */
#ifndef VT_EDGE_MAX_PIXELS
#define VT_EDGE_MAX_PIXELS 65536
#endif
#ifndef VT_EDGE_MAX_POINTS
#define VT_EDGE_MAX_POINTS 256
#endif
#if VT_EDGE_MAX_PIXELS < 16 || VT_EDGE_MAX_PIXELS > 1048576 || VT_EDGE_MAX_POINTS < 1 || \
    VT_EDGE_MAX_POINTS > 4096
#error "VT_EDGE_MAX_PIXELS must be in 16..2^20 and VT_EDGE_MAX_POINTS in 1..4096"
#endif

#endif /* VEHTRACK_CONFIG_H */
