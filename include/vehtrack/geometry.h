/* vehtrack/geometry.h -- the small geometry types the stages hand to each other
 * (thesis sec. 2.4.2: a shadow hypothesis is a bottom edge, a verified vehicle a
 * box; sec. 2.5: the tracker takes boxes in). They live here, not in the stage
 * that first made them, so a stage that only passes boxes on need not include the
 * verification stage.
 *
 * Cost: no code, no storage; a vt_box is 16 bytes, a vt_hypothesis 12. */
#ifndef VEHTRACK_GEOMETRY_H
#define VEHTRACK_GEOMETRY_H

#include <stdint.h>

/* A vehicle box, inclusive pixel coordinates: columns left..right, rows
 * top..bottom (bottom = the shadow edge's row). The tracker takes these in. */
typedef struct {
    int32_t left;
    int32_t top;
    int32_t right;
    int32_t bottom;
} vt_box;

/* A hypothesis: the vehicle's bottom edge at image row `row`, columns
 * x_start..x_end inclusive. */
typedef struct {
    int32_t row;
    int32_t x_start;
    int32_t x_end;
} vt_hypothesis;

#endif /* VEHTRACK_GEOMETRY_H */
