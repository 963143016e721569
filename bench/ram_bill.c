/* ram_bill.c -- the library's RAM bill for one build: sizeof(vt_pipeline) (the
 * whole state) and its parts, sizeof(vt_frame_out) (one frame's output), and,
 * given an 8-bit PGM frame, one vt_pipeline_step on it to show the build's
 * capacities suffice for that frame size (status, lane status, boxes, tracks).
 * `make bench` compiles it once per build configuration (bench/bench.mk) and
 * prints the table; tests/test_bench.py checks it against cffi's sizeof.
 * A host tool, not part of the core: it may use stdio.
 *
 *   ram_bill NAME [FRAME.pgm]   ->   one line of key=value pairs */
#include <stdio.h>
#include <string.h>

#include "vehtrack/vehtrack.h"

static vt_pipeline g_pipe;
static vt_pipeline_cfg g_cfg;
static vt_frame_out g_out;
static uint8_t g_frame[VT_MAX_WIDTH * VT_MAX_HEIGHT];

static int read_int(FILE *f, long *out)
{
    int c = fgetc(f), digits = 0;
    long v = 0;
    while (c == ' ' || c == '\n' || c == '\r' || c == '\t') {
        c = fgetc(f);
    }
    while (c >= '0' && c <= '9' && v < 100000) {
        v = v * 10 + (c - '0');
        ++digits;
        c = fgetc(f);
    }
    *out = v;
    return digits > 0;
}

/* A P5 PGM (no comments) within the build's maximum, or -1. */
static int read_pgm(const char *path, vt_image_u8 *img)
{
    FILE *f = fopen(path, "rb");
    long w = 0, h = 0, maxval = 0;
    size_t n;
    if (f == NULL) {
        return -1;
    }
    if (fgetc(f) != 'P' || fgetc(f) != '5' || !read_int(f, &w) || !read_int(f, &h) ||
        !read_int(f, &maxval) || maxval != 255 || w < 1 || h < 1 || w > VT_MAX_WIDTH ||
        h > VT_MAX_HEIGHT) {
        fclose(f);
        return -1;
    }
    n = (size_t)w * (size_t)h;
    if (fread(g_frame, 1, n, f) != n) {
        fclose(f);
        return -1;
    }
    fclose(f);
    img->px = g_frame;
    img->w = (int32_t)w;
    img->h = (int32_t)h;
    img->stride = (int32_t)w;
    return 0;
}

int main(int argc, char **argv)
{
    vt_image_u8 img;
    if (argc < 2) {
        fprintf(stderr, "usage: %s NAME [FRAME.pgm]\n", argv[0]);
        return 2;
    }
    printf("build=%s max_width=%d max_height=%d max_tracks=%d kf=%dx%d lane_work=%dx%d "
           "lane_acc_cells=%d lane_marks=%d",
           argv[1], VT_MAX_WIDTH, VT_MAX_HEIGHT, VT_MAX_TRACKS, VT_KF_MAX_X, VT_KF_MAX_Z,
           VT_LANE_MAX_WORK_W, VT_LANE_MAX_WORK_H, VT_LANE_ACC_CELLS, VT_LANE_MAX_MARKS);
    printf(" vt_pipeline=%lu vt_lane_state=%lu vt_tracker=%lu vt_track=%lu vt_detect_state=%lu "
           "vt_detect_result=%lu vt_pipeline_cfg=%lu vt_frame_out=%lu vt_road_area=%lu "
           "vt_lane_result=%lu vt_range_state=%lu vt_edge_ws=%lu vt_edge_template=%lu",
           (unsigned long)sizeof(vt_pipeline), (unsigned long)sizeof(vt_lane_state),
           (unsigned long)sizeof(vt_tracker), (unsigned long)sizeof(vt_track),
           (unsigned long)sizeof(vt_detect_state), (unsigned long)sizeof(vt_detect_result),
           (unsigned long)sizeof(vt_pipeline_cfg), (unsigned long)sizeof(vt_frame_out),
           (unsigned long)sizeof(vt_road_area), (unsigned long)sizeof(vt_lane_result),
           (unsigned long)sizeof(vt_range_state), (unsigned long)sizeof(vt_edge_ws),
           (unsigned long)sizeof(vt_edge_template));
    printf(" vt_pipe_cls_ws=%lu vt_flow_state=%lu", (unsigned long)sizeof(vt_pipe_cls_ws),
           (unsigned long)sizeof(vt_flow_state));
    printf(" vt_ttc_state=%lu", (unsigned long)sizeof(vt_ttc_state));
    if (argc > 2) {
        int32_t s;
        if (read_pgm(argv[2], &img) != 0) {
            printf(" frame=unreadable-or-too-large\n");
            return 0;
        }
        s = vt_pipeline_cfg_default(&g_cfg);
        if (s == VT_OK) {
            s = vt_pipeline_init(&g_pipe, &g_cfg, NULL, NULL);
        }
        if (s == VT_OK) {
            s = vt_pipeline_step(&g_pipe, &img, &g_out);
        }
        printf(" frame=%dx%d status=%d lane_status=%d road_source=%d boxes=%d tracks=%d",
               (int)img.w, (int)img.h, (int)s, (int)g_out.lane_status, (int)g_out.road_source,
               (int)g_out.n_boxes, (int)g_out.n_tracks);
    }
    printf("\n");
    return 0;
}
