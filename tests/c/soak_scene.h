/* soak_scene.h -- what the two soak drivers (soak.c: the tracker; soak_pipeline.c:
 * the whole pipeline) share (issue 11, item 7): the synthetic vehicles, the random
 * numbers, the detections a caller would pass, and the per-frame checks of the
 * tracker's slots and of the ids. Included once, by one driver, after it defines
 * W, H and NV; the driver owns g_v, g_rng and g_frame. */
#ifndef SOAK_SCENE_H
#define SOAK_SCENE_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include "vehtrack/tracker.h"

typedef struct {
    int32_t alive, hidden, passer; /* passer (pipeline only): 1 passed by the ego car, 2 overtaking */
    int32_t x, y, w, h;            /* px; x, y: bottom-left */
    int32_t vx, vy;                /* px per 8 frames (a passer: per frame) */
    int32_t life;
} vehicle;

static vehicle g_v[NV];
static uint32_t g_rng;
static long g_frame;

static uint32_t rnd(void)
{
    g_rng = g_rng * 1664525u + 1013904223u;
    return g_rng >> 8;
}

static void fail(const char *what, long a, long b)
{
    printf("SOAK FAIL frame %ld: %s (%ld, %ld)\n", g_frame, what, a, b);
    exit(1);
}

/* The visible vehicles' boxes with +-1 px jitter, and one time in ten a false box
 * anywhere: d holds NV + 1. */
static int32_t detections(vt_box *d)
{
    int32_t i, n = 0;
    for (i = 0; i < NV; i++) {
        const vehicle *v = &g_v[i];
        if (!v->alive || v->hidden) {
            continue;
        }
        d[n].left = v->x + (int32_t)(rnd() % 3) - 1;
        d[n].right = v->x + v->w - 1 + (int32_t)(rnd() % 3) - 1;
        d[n].bottom = v->y + (int32_t)(rnd() % 3) - 1;
        d[n].top = d[n].bottom - v->h + 1;
        n++;
    }
    if (rnd() % 10 == 0) {
        d[n].left = (int32_t)(rnd() % W);
        d[n].top = (int32_t)(rnd() % H);
        d[n].right = d[n].left + (int32_t)(rnd() % 30);
        d[n].bottom = d[n].top + (int32_t)(rnd() % 20);
        n++;
    }
    return n;
}

/* P exactly symmetric, diagonal >= 0, and every 2x2 principal minor
 * P_ii P_jj - P_ij^2 >= 0 (necessary for positive semi-definiteness), exactly in
 * 128 bits; 2^-20 relative covers the LSB rounding kalman.h documents. */
static void check_p(const vt_kf *kf)
{
    int32_t i, j;
    for (i = 0; i < kf->dim_x; i++) {
        if (kf->P[i][i] < 0) {
            fail("P diagonal < 0", i, (long)(kf->P[i][i] >> 32));
        }
        for (j = 0; j < kf->dim_x; j++) {
            if (kf->P[i][j] != kf->P[j][i]) {
                fail("P not symmetric", i, j);
            }
            if (j > i) {
                __int128 a = (__int128)kf->P[i][i] * kf->P[j][j];
                __int128 b = (__int128)kf->P[i][j] * kf->P[i][j];
                if (a < b - (b >> 20) - 4096) {
                    fail("P 2x2 minor < 0", i, j);
                }
            }
        }
    }
}

/* The tracker's live slots: counters >= 0, dropped_full not decreased, P valid.
 * Returns the number of live slots. */
static int32_t check_slots(const vt_tracker *tr, int32_t dropped_before)
{
    int32_t i, live = 0;
    if (tr->dropped_full < dropped_before) {
        fail("dropped_full decreased", dropped_before, tr->dropped_full);
    }
    for (i = 0; i < VT_MAX_TRACKS; i++) {
        const vt_track *t = &tr->tracks[i];
        if (t->state == VT_TRACK_FREE) {
            continue;
        }
        live++;
        if (t->hits < 0 || t->misses < 0 || t->age < 0) {
            fail("negative counter", t->id, t->age);
        }
        check_p(&t->kf);
    }
    return live;
}

/* This frame's ids[0..n): in range, distinct, and one not live after the previous
 * frame (prev[0..n_prev)) larger than every id seen before (*max_id): never reused,
 * never wrapped. */
static void check_ids(const int32_t *ids, int32_t n, const int32_t *prev, int32_t n_prev, int32_t *max_id)
{
    int32_t i, j;
    for (i = 0; i < n; i++) {
        int32_t was_live = 0;
        if (ids[i] <= 0 || ids[i] >= INT32_MAX) {
            fail("id out of range", ids[i], 0);
        }
        for (j = 0; j < i; j++) {
            if (ids[j] == ids[i]) {
                fail("duplicate id", ids[i], 0);
            }
        }
        for (j = 0; j < n_prev; j++) {
            was_live |= prev[j] == ids[i];
        }
        if (!was_live) {
            if (ids[i] <= *max_id) {
                fail("id reused", ids[i], *max_id);
            }
            *max_id = ids[i];
        }
    }
}

#endif
