/* kalman_r.c -- a Kalman update with a per-measurement R (IVVI paper sec. 4, eq. 6: the
 * distance error of a flat-road measurement grows with the distance, and the paper uses it
 * as the measurement covariance of the tracking filter). Kept apart from kalman.c so the
 * filter itself stays untouched: this only swaps R in, and back out on an error. */
#include "vehtrack/kalman.h"
#include <stddef.h>

vt_status vt_kf_update_r(vt_kf *kf, const vt_q16 *z, const vt_q32 *r)
{
    vt_q32 old[VT_KF_MAX_Z][VT_KF_MAX_Z];
    int32_t i, j, m;
    vt_status s;
    if (kf == NULL || z == NULL || r == NULL) {
        return VT_E_ARG;
    }
    m = kf->dim_z;
    if (m < 1 || m > VT_KF_MAX_Z || kf->dim_x < 1 || kf->dim_x > VT_KF_MAX_X) {
        return VT_E_SIZE;
    }
    for (i = 0; i < m; i++) {
        if (r[i * m + i] < 0) {
            return VT_E_ARG;
        }
        for (j = 0; j < i; j++) {
            if (r[i * m + j] != r[j * m + i]) {
                return VT_E_ARG;
            }
        }
    }
    for (i = 0; i < m; i++) {
        for (j = 0; j < m; j++) {
            old[i][j] = kf->R[i][j];
            kf->R[i][j] = r[i * m + j];
        }
    }
    s = vt_kf_update(kf, z);
    if (s != VT_OK) {
        for (i = 0; i < m; i++) {
            for (j = 0; j < m; j++) {
                kf->R[i][j] = old[i][j];
            }
        }
    }
    return s;
}
