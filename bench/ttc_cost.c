/* ttc_cost.c -- callgrind driver for the block-scale TTC's cost per track (host tool, uses stdio).
 *
 *   make ttc-cost   (builds it with the core, runs callgrind, prints the cost)
 *   (or: valgrind --tool=callgrind --toggle-collect=cost_ttc_step build/bench/ttc_cost \
 *        A.pgm B.pgm l t r b  l t r b)
 *
 * vt_ttc_step with the default cfg but lag 1 on frame A with box 1 (stores the blocks, not
 * measured), then cost_ttc_step: one vt_ttc_step on frame B with box 2 (the lead's match of
 * every stored block, the median and the storing of B's blocks: one track's work per frame).
 * Prints the output and sizeof(vt_ttc_state). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vehtrack/vehtrack.h"

static uint8_t g_a[VT_MAX_WIDTH * VT_MAX_HEIGHT], g_b[VT_MAX_WIDTH * VT_MAX_HEIGHT];
static vt_ttc_state g_st;

void cost_ttc_step(const vt_ttc_cfg *c, const vt_image_u8 *img, const vt_track_out *t, vt_ttc_out *o,
                   int32_t *n);

void cost_ttc_step(const vt_ttc_cfg *c, const vt_image_u8 *img, const vt_track_out *t, vt_ttc_out *o,
                   int32_t *n)
{
    if (vt_ttc_step(&g_st, c, img, t, 1, o, 1, n) != VT_OK) {
        puts("ttc step failed");
    }
}

static int read_pgm(const char *path, uint8_t *px, int32_t *w, int32_t *h)
{
    FILE *f = fopen(path, "rb");
    int mx = 0, ok;
    if (f == NULL) {
        return 0;
    }
    ok = fscanf(f, "P5 %d %d %d", w, h, &mx) == 3 && mx == 255 && *w > 0 && *h > 0 &&
         *w <= VT_MAX_WIDTH && *h <= VT_MAX_HEIGHT && fgetc(f) != EOF &&
         fread(px, 1, (size_t)(*w) * (size_t)(*h), f) == (size_t)(*w) * (size_t)(*h);
    fclose(f);
    return ok;
}

int main(int argc, char **argv)
{
    vt_ttc_cfg cfg;
    vt_image_u8 a, b;
    vt_track_out t;
    vt_ttc_out o;
    int32_t n = 0, w2, h2;
    if (argc != 11 || !read_pgm(argv[1], g_a, &a.w, &a.h) || !read_pgm(argv[2], g_b, &w2, &h2) ||
        w2 != a.w || h2 != a.h) {
        fputs("usage: ttc_cost A.pgm B.pgm l t r b l t r b (same-size binary PGMs)\n", stderr);
        return 2;
    }
    a.px = g_a;
    a.stride = a.w;
    b = a;
    b.px = g_b;
    (void)vt_ttc_cfg_default(&cfg);
    cfg.lag = 1;
    (void)vt_ttc_init(&g_st);
    memset(&t, 0, sizeof t);
    t.id = 1;
    t.state = 2;
    t.box.left = atoi(argv[3]);
    t.box.top = atoi(argv[4]);
    t.box.right = atoi(argv[5]);
    t.box.bottom = atoi(argv[6]);
    if (vt_ttc_step(&g_st, &cfg, &a, &t, 1, &o, 1, &n) != VT_OK) {
        puts("first step failed");
        return 1;
    }
    t.box.left = atoi(argv[7]);
    t.box.top = atoi(argv[8]);
    t.box.right = atoi(argv[9]);
    t.box.bottom = atoi(argv[10]);
    cost_ttc_step(&cfg, &b, &t, &o, &n);
    printf("ttc_cost: n %d blocks %d matched %d pairs %d scale %d/65536 flags %d; sizeof(vt_ttc_state) %lu\n",
           (int)n, (int)o.blocks, (int)o.matched, (int)o.pairs, (int)o.scale, (int)o.flags,
           (unsigned long)sizeof(vt_ttc_state));
    return 0;
}
