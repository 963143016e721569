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
#include "vehtrack/geometry.h"
#include "vehtrack/road.h"
#include "vehtrack/lane.h"
#include "vehtrack/shadow.h"
#include "vehtrack/verify.h"
#include "vehtrack/detect.h"
#include "vehtrack/windows.h"
#include "vehtrack/hood.h"
#include "vehtrack/fulldet.h"
#include "vehtrack/acf.h"
#include "vehtrack/cnn.h"
#include "vehtrack/kalman.h"
#include "vehtrack/track_search.h"
#include "vehtrack/edge_track.h"
#include "vehtrack/tracker.h"
#include "vehtrack/camera.h"
#include "vehtrack/ttc_scale.h"
#include "vehtrack/classify.h"
#include "vehtrack/flow.h"
#include "vehtrack/vehicle_model.h"
#include "vehtrack/pipeline.h"

#define VT_VERSION_MAJOR 0
#define VT_VERSION_MINOR 1
#define VT_VERSION_PATCH 0

#endif /* VEHTRACK_VEHTRACK_H */
