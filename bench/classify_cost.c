/* classify_cost.c -- callgrind driver for the classifier's costs (host tool, uses stdio).
 *
 *   make classify-cost   (builds it with the core, runs callgrind, prints the costs)
 *   (or: valgrind --tool=callgrind --toggle-collect=cost_X build/bench/classify_cost FRAME.pgm W H)
 *
 * Runs once each, on a band of the frame: cost_hog_prepare (a W x H band),
 * cost_hog_scan (every window position of the default HOG model on that band),
 * cost_classify_box_hog / cost_classify_box_gist (one 120x100 box). Prints sizeof of
 * the workspaces and the default model's weights. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vehtrack/vehtrack.h"

static uint8_t g_frame[VT_MAX_WIDTH * VT_MAX_HEIGHT];
static vt_hog_ws g_hog;
static vt_cls_box_ws g_box;
static int32_t g_scores[(VT_CLS_MAX_W / 8) * (VT_CLS_MAX_H / 8)];

void cost_hog_prepare(const vt_image_u8 *band);
void cost_hog_scan(const vt_svm_model *m, int32_t ncx, int32_t ncy);
void cost_classify_box(const vt_svm_model *m, const vt_image_u8 *img, const vt_box *b, int32_t *s);

void cost_hog_prepare(const vt_image_u8 *band)
{
    if (vt_hog_prepare(&g_hog, band) != VT_OK) {
        puts("prepare failed");
    }
}

void cost_hog_scan(const vt_svm_model *m, int32_t ncx, int32_t ncy)
{
    if (vt_hog_scan(&g_hog, m, 0, 0, ncx, ncy, g_scores, ncx * ncy) != VT_OK) {
        puts("scan failed");
    }
}

void cost_classify_box(const vt_svm_model *m, const vt_image_u8 *img, const vt_box *b, int32_t *s)
{
    if (vt_classify_box(&g_box, m, img, b, s) != VT_OK) {
        puts("box failed");
    }
}

int main(int argc, char **argv)
{
    FILE *f;
    int w, h, maxv, bw, bh, y0;
    vt_image_u8 frame, band;
    const vt_svm_model *mh = NULL, *mg = NULL;
    vt_box box;
    int32_t s1 = 0, s2 = 0, ncx, ncy;
    if (argc < 2 || (f = fopen(argv[1], "rb")) == NULL) {
        fprintf(stderr, "usage: %s FRAME.pgm [band_w band_h]\n", argv[0]);
        return 2;
    }
    if (fscanf(f, "P5 %d %d %d", &w, &h, &maxv) != 3 || w > VT_MAX_WIDTH || h > VT_MAX_HEIGHT) {
        return 2;
    }
    fgetc(f);
    if (fread(g_frame, 1, (size_t)w * (size_t)h, f) != (size_t)w * (size_t)h) {
        return 2;
    }
    fclose(f);
    bw = argc > 3 ? atoi(argv[2]) : w;
    bh = argc > 3 ? atoi(argv[3]) : 192;
    frame.px = g_frame;
    frame.w = w;
    frame.h = h;
    frame.stride = w;
    y0 = h / 2 - bh / 2;
    band.px = g_frame + (size_t)y0 * (size_t)w;
    band.w = bw;
    band.h = bh;
    band.stride = w;
    vt_svm_default_model(VT_DESC_HOG, &mh);
    vt_svm_default_model(VT_DESC_GIST, &mg);
    cost_hog_prepare(&band);
    ncx = g_hog.cells_x - mh->win_w / 8 + 1;
    ncy = g_hog.cells_y - mh->win_h / 8 + 1;
    cost_hog_scan(mh, ncx, ncy);
    box.left = w / 2 - 60;
    box.top = h / 2 - 50;
    box.right = w / 2 + 59;
    box.bottom = h / 2 + 49;
    cost_classify_box(mh, &frame, &box, &s1);
    if (mg != NULL) {
        cost_classify_box(mg, &frame, &box, &s2);
    }
    printf("band %dx%d (%d px), windows %d (%dx%d), box scores hog %d gist %d\n", bw, bh, bw * bh,
           (int)(ncx * ncy), (int)mh->win_w, (int)mh->win_h, (int)s1, (int)s2);
    printf("sizeof vt_hog_ws %lu, vt_gist_ws %lu, vt_cls_box_ws %lu, vt_svm_model %lu, "
           "default hog weights %lu bytes, gist %lu bytes\n",
           (unsigned long)sizeof(vt_hog_ws), (unsigned long)sizeof(vt_gist_ws),
           (unsigned long)sizeof(vt_cls_box_ws), (unsigned long)sizeof(vt_svm_model),
           (unsigned long)(2 * mh->dim), (unsigned long)(mg != NULL ? 2 * mg->dim : 0));
    return 0;
}
