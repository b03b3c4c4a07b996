/*
 * The float baseline of the on-target benchmark (docs/reference/performance.md): the same
 * algorithms as the fixed-point estimator, written plainly in single precision
 * with the C library's atan2f, the way a user would write them without our
 * fixed-point work. Lives in tests/: firmware code never uses float.
 */
#ifndef TESTS_BENCH_FLOAT_BASELINE_H
#define TESTS_BENCH_FLOAT_BASELINE_H

#include <stdint.h>

struct flt_window {
    float arm_mm;
    unsigned n;
    float sum_x[4], sum_xx[4];    /* per sensor */
    float sum_a[5], sum_aa[5][5]; /* α1..α5 and their cross products */
    float sum_b[5], sum_bb[5][5]; /* β1..β5 */
};

struct flt_kalman {
    float x[3];    /* x̄, tan α, tan β */
    float p[3][3]; /* covariance */
    float r[4];    /* measurement noise per sensor, mm² */
    float q[3];    /* process noise per update (x̄ mm², tan² α, tan² β); 0: static */
    float arm_mm;
};

struct flt_result {
    float alpha_deg, beta_deg;
    unsigned iterations;
};

/* Start an empty window for arm `arm_mm`. */
void flt_window_init(struct flt_window *w, float arm_mm);

/* One sample: four ranges, ten angles (atan2f), window sums. */
void flt_window_push(struct flt_window *w, const uint16_t range_mm[4]);

/* One window's consensus: per-sensor variances -> weights -> P, v <- P v to tolerance. */
void flt_consensus(const struct flt_window *w, float tol_deg, struct flt_result *out);

/* Start the filter at a diffuse prior. */
void flt_kalman_init(struct flt_kalman *k, float arm_mm, float r_mm2);

/* Process noise added to P's diagonal before each update (the tracking filter). */
void flt_kalman_set_process_noise(struct flt_kalman *k, float q_mean, float q_alpha, float q_beta);

/* One four-measurement update (identity dynamics: P += Q, then scalar updates, Joseph
 * form). */
void flt_kalman_update(struct flt_kalman *k, const uint16_t range_mm[4]);

#endif /* TESTS_BENCH_FLOAT_BASELINE_H */
