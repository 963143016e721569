/* vehtrack/vehtrack.h -- umbrella header: camera-based vehicle detection and
 * tracking in C99 fixed point, static memory only. Include this, or one module's
 * header. */
#ifndef VEHTRACK_VEHTRACK_H
#define VEHTRACK_VEHTRACK_H

#include "vehtrack/config.h"
#include "vehtrack/status.h"
#include "vehtrack/fixed.h"
#include "vehtrack/trig.h"
#include "vehtrack/image.h"
#include "vehtrack/road.h"

#define VT_VERSION_MAJOR 0
#define VT_VERSION_MINOR 1
#define VT_VERSION_PATCH 0

#endif /* VEHTRACK_VEHTRACK_H */
