/* kalman.h: fixed-point Kalman filter and the two motion models. */
#define VT_KF_MAX_X ...
#define VT_KF_MAX_Z ...
#define VT_Q32_ONE ...
#define VT_KF_DT_MIN ...
#define VT_KF_DT_MAX ...
#define VT_KF_ACCEL_MAX ...
#define VT_KF_MEAS_SIGMA_MIN ...
#define VT_KF_MEAS_SIGMA_MAX ...
#define VT_KF_POS_SIGMA_MAX ...
#define VT_KF_VEL_SIGMA_MAX ...
#define VT_KF_BE_DIM_X ...
#define VT_KF_BE_DIM_Z ...
#define VT_KF_CV_DIM_X ...
#define VT_KF_CV_DIM_Z ...

typedef int64_t vt_q32;

typedef struct {
    int32_t dim_x;
    int32_t dim_z;
    vt_q16 x[...];
    vt_q16 y[...];
    vt_q32 P[...][...];
    vt_q32 F[...][...];
    vt_q32 Q[...][...];
    vt_q32 H[...][...];
    vt_q32 R[...][...];
    vt_q32 K[...][...];
    vt_q32 S[...][...];
} vt_kf;

typedef struct {
    vt_q16 dt;
    vt_q16 accel_x;
    vt_q16 accel_y;
    vt_q16 p_max;
    vt_q16 p_zero;
    vt_q16 meas_sigma_x;
    vt_q16 meas_sigma_y;
    vt_q16 init_sigma_pos;
    vt_q16 init_sigma_vel;
} vt_kf_model_cfg;

vt_status vt_kf_init(vt_kf *kf, int32_t dim_x, int32_t dim_z);
vt_status vt_kf_predict(vt_kf *kf);
vt_status vt_kf_update(vt_kf *kf, const vt_q16 *z);
vt_status vt_kf_update_r(vt_kf *kf, const vt_q16 *z, const vt_q32 *r);
vt_status vt_kf_accel_var(vt_q16 accel, vt_q16 p_max, vt_q16 p_zero, vt_q32 *var);
vt_status vt_kf_model_cfg_default(vt_kf_model_cfg *cfg);
vt_status vt_kf_model_cfg_check(const vt_kf_model_cfg *cfg);
vt_status vt_kf_init_bottom_edge(vt_kf *kf, const vt_kf_model_cfg *cfg, vt_q16 x1, vt_q16 y1,
                                 vt_q16 x2);
vt_status vt_kf_init_cv(vt_kf *kf, const vt_kf_model_cfg *cfg, vt_q16 x, vt_q16 y);
