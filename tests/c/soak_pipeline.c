/* soak_pipeline.c -- the whole per-frame pipeline (vehtrack/pipeline.h: lanes ->
 * shadow detection -> tracker -> geometry, thesis fig. 4.1; plus the overtaking
 * flow stage and its hand-over, IVVI paper sec. 3) over a long run of synthetic
 * frames, C only (issue 11, item 7). Usage: soak_pipeline [frames] [seed].
 *
 * Scene: a 160x120 road (a vertical ramp) with up to VT_MAX_TRACKS + 8 vehicles
 * (so the tracker's slots fill): dark bodies over a darker shadow row, appearing,
 * drifting, leaving, hidden for stretches and overlapping; a quarter of them are
 * cars beside the ego lane: "passed" ones that grow, come down and leave by a
 * side, as a car the ego car overtakes does (the hand-over to the flow stage),
 * and overtaking ones coming in from a side border (the flow stage's hypotheses). The pipeline runs shadow
 * detection every 5th frame on its own, and on every 7th frame takes the visible
 * vehicles' boxes (+-1 px jitter, an occasional false one) as the caller's
 * detections (vt_pipeline_step_dets); a camera is attached (distance, TTC, FCW).
 *
 * Checked on every frame, exit status 1 and a message at the first failure:
 *   - the step returns VT_OK; out.n_tracks <= VT_MAX_TRACKS; out.frame counts
 *     frames (wrapping to 0 only after INT32_MAX, as pipeline.c documents);
 *   - ids: distinct within a frame, > 0, and an id that was not live (in a tracker
 *     slot or a hand-over) after the previous frame is larger than every id seen
 *     before (a hand-over keeps its track's id; nothing is reused or wraps);
 *   - the tracker inside: live slots == the tracker tracks reported, counters
 *     >= 0 and dropped_full never decreasing, every live track's P exactly
 *     symmetric with a non-negative diagonal and 2x2 minors (as soak.c);
 *   - every reported box is ordered and meets the frame (the tracker expires a
 *     track whose box leaves it; a hand-over box is clipped to it).
 * Then a saturation phase: the tracker's frame counter, next id and live tracks'
 * counters and the pipeline's frame counter are moved a few steps below INT32_MAX
 * and the run goes on for 2000 frames: the tracker's counters stop at INT32_MAX,
 * the ids run out without reuse, the pipeline's counter wraps to 0 as documented.
 * Prints one summary line. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "vehtrack/pipeline.h"

#define W 160
#define H 120
#define NV (VT_MAX_TRACKS + 8)
#define DET_EVERY 5
#define DETS_EVERY 7

#include "soak_scene.h"

static uint8_t g_px[W * H];
static vt_pipeline g_p;
static vt_flow_state g_flow;
static vt_frame_out g_out;
static vt_camera_cfg g_cam;

static void render(void)
{
    int32_t i, x, y;
    for (y = 0; y < H; y++) {
        memset(g_px + y * W, 90 + y, W);
    }
    for (i = 0; i < NV; i++) {
        const vehicle *v = &g_v[i];
        if (!v->alive || v->hidden) {
            continue;
        }
        for (y = v->y - v->h + 1; y <= v->y + 1; y++) {
            for (x = v->x; x < v->x + v->w; x++) {
                if (x >= 0 && x < W && y >= 0 && y < H) {
                    /* a body with a vertical stripe texture (flow needs texture) */
                    g_px[y * W + x] = (uint8_t)(y >= v->y ? 12 : 50 + 5 * i + ((x - v->x) % 6 < 3 ? 25 : 0));
                }
            }
        }
    }
}

static void spawn(vehicle *v)
{
    v->alive = 1;
    v->hidden = 0;
    v->passer = rnd() % 4 == 0;
    v->w = 14 + (int32_t)(rnd() % 30);
    v->h = v->w * 3 / 4;
    if (v->passer) {
        /* beside the ego lane: a car the ego car passes comes closer (down,
         * outward) until it leaves by the side; an overtaking one comes in from
         * the side border and goes away (up, inward) */
        int32_t left = rnd() % 2 == 0, overtakes = rnd() % 2 == 0;
        v->passer = overtakes ? 2 : 1;
        if (overtakes) {
            v->w = 40 + (int32_t)(rnd() % 10);
            v->x = left ? -v->w / 2 : W - v->w / 2;
            v->y = 100 + (int32_t)(rnd() % 10);
            v->vx = left ? 2 : -2;
            v->vy = -1;
        } else {
            v->x = left ? 10 + (int32_t)(rnd() % 20) : W - 10 - v->w - (int32_t)(rnd() % 20);
            v->y = 70 + (int32_t)(rnd() % 20);
            v->vx = left ? -1 : 1;
            v->vy = 1;
        }
        v->h = v->w * 3 / 4;
        v->life = 200;
    } else {
        v->x = (int32_t)(rnd() % (W - 8)) - 4;
        v->y = 40 + (int32_t)(rnd() % (H - 42));
        v->vx = (int32_t)(rnd() % 7) - 3;
        v->vy = (int32_t)(rnd() % 3) - 1;
        v->life = 20 + (int32_t)(rnd() % 400);
    }
}

static void move(void)
{
    int32_t i;
    for (i = 0; i < NV; i++) {
        vehicle *v = &g_v[i];
        if (!v->alive) {
            if (rnd() % 16 == 0) {
                spawn(v);
            }
            continue;
        }
        if (v->passer) {
            v->x += v->vx;
            if (g_frame % 2 == 0) {
                int32_t grow = v->passer == 1 ? 1 : (v->w > 12 ? -1 : 0);
                v->y += v->vy;
                v->w += grow;
                v->x -= v->vx < 0 ? grow : 0;
                v->h = v->w * 3 / 4;
            }
        } else if (g_frame % 8 == 0) {
            v->x += v->vx;
            v->y += v->vy;
        }
        if (v->hidden > 0) {
            v->hidden -= 1;
        } else if (!v->passer && rnd() % 200 == 0) {
            v->hidden = 1 + (int32_t)(rnd() % 40); /* occluded for a while */
        }
        v->life -= 1;
        if (v->life <= 0 || v->x > W || v->x + v->w < 0 || v->y < 4 || v->y >= H + 4) {
            v->alive = 0;
        }
    }
}

static int32_t g_prev_ids[VT_MAX_TRACKS + VT_FLOW_MAX_SEEDS], g_n_prev;
static int32_t g_max_id, g_peak;
static long g_handover_frames, g_flow_boxes;

static void step(void)
{
    vt_box dets[NV + 1];
    const vt_image_u8 img = {g_px, W, H, W};
    const vt_tracker *tr = &g_p.tracker;
    int32_t ids[VT_MAX_TRACKS];
    int32_t i, live, n_trk = 0, ho = 0;
    int32_t frame_before = g_p.frame, dropped_before = tr->dropped_full;
    vt_status s;
    if (g_frame % DETS_EVERY == 3) {
        int32_t n = detections(dets);
        s = vt_pipeline_step_dets(&g_p, &img, dets, n, &g_out);
    } else {
        s = vt_pipeline_step(&g_p, &img, &g_out);
    }
    if (s != VT_OK) {
        fail("step status", s, 0);
    }
    if (g_out.frame != frame_before || g_p.frame != (frame_before < INT32_MAX ? frame_before + 1 : 0)) {
        fail("frame counter", frame_before, g_p.frame);
    }
    if (g_out.n_tracks < 0 || g_out.n_tracks > VT_MAX_TRACKS) {
        fail("n_tracks", g_out.n_tracks, 0);
    }
    live = check_slots(tr, dropped_before);
    for (i = 0; i < g_out.n_boxes; i++) {
        g_flow_boxes += g_out.boxes[i].source == VT_SRC_FLOW;
    }
    for (i = 0; i < g_out.n_tracks; i++) {
        const vt_pipe_track *t = &g_out.tracks[i];
        if (t->state == VT_PIPE_HANDOVER) {
            ho = 1;
        } else {
            n_trk++;
        }
        if (t->box.right < 0 || t->box.bottom < 0 || t->box.left >= W || t->box.top >= H ||
            t->box.right < t->box.left || t->box.bottom < t->box.top) {
            fail("box not ordered or off the frame", t->box.left, t->box.bottom);
        }
        ids[i] = t->id;
    }
    check_ids(ids, g_out.n_tracks, g_prev_ids, g_n_prev, &g_max_id);
    if (live != n_trk) {
        fail("live slots != tracker tracks reported", live, n_trk);
    }
    g_handover_frames += ho;
    g_peak = live > g_peak ? live : g_peak;
    /* The live set for the next frame: the tracker's slots and the hand-overs (a
     * hand-over that did not fit in out.tracks lives on unreported, pipeline.h). */
    g_n_prev = 0;
    for (i = 0; i < VT_MAX_TRACKS; i++) {
        if (tr->tracks[i].state != VT_TRACK_FREE) {
            g_prev_ids[g_n_prev++] = tr->tracks[i].id;
        }
    }
    for (i = 0; i < g_p.n_ho; i++) {
        g_prev_ids[g_n_prev++] = g_p.ho_id[i];
    }
}

static void init(void)
{
    vt_pipeline_cfg cfg;
    if (vt_pipeline_cfg_default(&cfg) != VT_OK || vt_camera_cfg_default(&g_cam) != VT_OK) {
        fail("defaults", 0, 0);
    }
    cfg.sources = VT_SRC_SHADOW | VT_SRC_FLOW;
    cfg.detect_every = DET_EVERY;
    cfg.flow.sides = VT_FLOW_SIDE_BOTH;
    cfg.tracker.confirm_hits = 2;
    g_cam.img_w = W;
    g_cam.img_h = H;
    g_cam.fx = g_cam.fy = 150 * 65536;
    g_cam.cx = (W / 2) * 65536;
    g_cam.cy = (H / 2) * 65536;
    g_cam.height = 78643; /* 1.2 m */
    if (vt_pipeline_init(&g_p, &cfg, &g_cam, NULL) != VT_OK) {
        fail("init", 0, 0);
    }
    if (vt_pipeline_set_flow_ws(&g_p, &g_flow) != VT_OK) {
        fail("set_flow_ws", 0, 0);
    }
}

int main(int argc, char **argv)
{
    long frames = argc > 1 ? atol(argv[1]) : 100000L, f;
    int32_t i, dropped_before;
    g_rng = argc > 2 ? (uint32_t)atol(argv[2]) : 1u;
    init();
    for (f = 0; f < frames; f++) {
        g_frame = f;
        move();
        render();
        step();
    }
    printf("soak_pipeline: %ld frames, %d tracks started, peak live %d of %d, dropped_full %d, "
           "frames with a hand-over %ld, flow boxes %ld\n",
           frames, (int)(g_p.tracker.next_id - 1), (int)g_peak, VT_MAX_TRACKS,
           (int)g_p.tracker.dropped_full, g_handover_frames, g_flow_boxes);
    if (g_p.tracker.next_id - 1 < 10 || g_peak < VT_MAX_TRACKS || g_p.tracker.dropped_full == 0) {
        fail("the scene did not fill the slots", g_p.tracker.next_id, g_peak);
    }

    /* Saturation phase: counters a few steps below INT32_MAX. */
    g_p.tracker.frame = INT32_MAX - 100;
    g_p.tracker.next_id = INT32_MAX - 3;
    g_p.frame = INT32_MAX - 100;
    g_max_id = INT32_MAX - 4; /* ids below are "seen": any of them coming back is reuse */
    for (i = 0; i < VT_MAX_TRACKS; i++) {
        vt_track *t = &g_p.tracker.tracks[i];
        if (t->state != VT_TRACK_FREE) {
            t->age = INT32_MAX - 10;
            t->hits = INT32_MAX - 10;
        }
    }
    dropped_before = g_p.tracker.dropped_full;
    for (f = 0; f < 2000; f++) {
        g_frame = frames + f;
        move();
        render();
        step();
    }
    if (g_p.tracker.frame != INT32_MAX || g_p.tracker.next_id != INT32_MAX ||
        g_p.tracker.dropped_full <= dropped_before || g_p.frame != 2000 - 101) {
        fail("saturation phase", g_p.tracker.frame, g_p.frame);
    }
    printf("saturation: tracker frame counter %d, next id %d (exhausted), dropped_full %d, "
           "pipeline frame wrapped to %d, no id reused\n",
           (int)g_p.tracker.frame, (int)g_p.tracker.next_id, (int)g_p.tracker.dropped_full,
           (int)g_p.frame);
    printf("SOAK OK\n");
    return 0;
}
