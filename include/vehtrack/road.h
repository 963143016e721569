/* vehtrack/road.h -- the road area: the hand-over from the lane stage to the
 * hypothesis stage (thesis sec. 2.4.1.3: the lanes found are grouped into one road
 * area, so a marking missing in one frame does not lose the road).
 *
 * Cost: 3 * 2 * VT_MAX_HEIGHT + 16 bytes (6.5 KB at the default 1080 rows). */
#ifndef VEHTRACK_ROAD_H
#define VEHTRACK_ROAD_H

#include <stdint.h>
#include "vehtrack/config.h"

/* Per-row extent of the road area in image columns. Rows outside
 * [y_top, y_bottom] are not road; inside, the road spans columns
 * x_left[y]..x_right[y] inclusive (x_left[y] <= x_right[y]), and lane_width[y]
 * is the width in pixels of one lane at that row (the ego lane), from which the
 * expected vehicle width at that row follows. `valid` is 0 when no road area is
 * known (then nothing else is meaningful). */
typedef struct {
    int32_t valid;
    int32_t y_top;
    int32_t y_bottom;
    int32_t height; /* rows of the frame the area was made for */
    int16_t x_left[VT_MAX_HEIGHT];
    int16_t x_right[VT_MAX_HEIGHT];
    int16_t lane_width[VT_MAX_HEIGHT];
} vt_road_area;

#endif /* VEHTRACK_ROAD_H */
