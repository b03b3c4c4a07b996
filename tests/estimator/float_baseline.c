/* The benchmark's float baseline: the estimator's algorithms written plainly in float. */
#include "float_baseline.h"

#include <math.h>
#include <string.h>

#define RAD_TO_DEG 57.29577951f

void flt_window_init(struct flt_window *w, float arm_mm) {
    memset(w, 0, sizeof *w);
    w->arm_mm = arm_mm;
}

/* Eq. 1 of the first paper and its β counterpart (docs/explanation/architecture.md). */
static void angles(const float x[4], float a, float alpha[5], float beta[5]) {
    alpha[0] = atan2f(x[1] - x[0], a) * RAD_TO_DEG;
    alpha[1] = atan2f(x[3] - x[0], a) * RAD_TO_DEG;
    alpha[2] = atan2f(x[2] - x[1], a) * RAD_TO_DEG;
    alpha[3] = atan2f(x[2] - x[3], a) * RAD_TO_DEG;
    alpha[4] = atan2f(x[2] - x[0], 2.0f * a) * RAD_TO_DEG;
    beta[0] = atan2f(x[0] - x[3], a) * RAD_TO_DEG;
    beta[1] = atan2f(x[2] - x[3], a) * RAD_TO_DEG;
    beta[2] = atan2f(x[1] - x[0], a) * RAD_TO_DEG;
    beta[3] = atan2f(x[1] - x[2], a) * RAD_TO_DEG;
    beta[4] = atan2f(x[1] - x[3], 2.0f * a) * RAD_TO_DEG;
}

void flt_window_push(struct flt_window *w, const uint16_t range_mm[4]) {
    float x[4];
    for (unsigned k = 0; k < 4; ++k) {
        x[k] = (float)range_mm[k];
        w->sum_x[k] += x[k];
        w->sum_xx[k] += x[k] * x[k];
    }
    float a[5], b[5];
    angles(x, w->arm_mm, a, b);
    for (unsigned i = 0; i < 5; ++i) {
        w->sum_a[i] += a[i];
        w->sum_b[i] += b[i];
        for (unsigned j = i; j < 5; ++j) {
            w->sum_aa[i][j] += a[i] * a[j];
            w->sum_bb[i][j] += b[i] * b[j];
        }
    }
    ++w->n;
}

/* One axis: compensated slopes v, weights π from the sensor variances (the product
 * rule of estimator/consensus.h), then P = I/2 + 1πᵀ/2 iterated to tolerance. */
static float axis(const float mean[4], const float var_mean[4], unsigned lo, unsigned r1,
                  unsigned hi, unsigned r2, float a, float tol_deg, unsigned *iterations) {
    const float m = 0.25f * (var_mean[r1] + var_mean[r2]);
    const float t_other = (mean[r1] - mean[r2]) / (2.0f * a);
    float v[5] = {(mean[r1] - mean[lo]) / a - t_other, (mean[r2] - mean[lo]) / a + t_other,
                  (mean[hi] - mean[r1]) / a + t_other, (mean[hi] - mean[r2]) / a - t_other,
                  (mean[hi] - mean[lo]) / (2.0f * a)};
    /* Inverse-variance weights of the two halves (estimator/consensus.h, fact 3):
     * the low side's share is the high side's variance and vice versa. */
    const float w_low = 2.0f * m + var_mean[hi];
    const float w_high = 2.0f * m + var_mean[lo];
    float pi[5] = {0.5f * w_low, 0.5f * w_low, 0.5f * w_high, 0.5f * w_high, 0.0f};
    const float total = w_low + w_high;
    for (unsigned i = 0; i < 5; ++i) {
        pi[i] /= total;
    }
    /* the stopping test of the fixed-point rule (estimator/consensus.c): the spread of the
     * slopes against the tolerance in radians, |Δatan| <= |Δt| */
    const float tol_slope = tol_deg / RAD_TO_DEG;
    unsigned k = 0;
    for (; k < 64u; ++k) {
        float lo_v = v[0], hi_v = v[0];
        for (unsigned i = 1; i < 5; ++i) {
            lo_v = fminf(lo_v, v[i]);
            hi_v = fmaxf(hi_v, v[i]);
        }
        if (hi_v - lo_v <= tol_slope) {
            break;
        }
        float c = 0.0f;
        for (unsigned i = 0; i < 5; ++i) {
            c += pi[i] * v[i];
        }
        for (unsigned i = 0; i < 5; ++i) {
            v[i] = 0.5f * v[i] + 0.5f * c;
        }
    }
    *iterations += k;
    float c = 0.0f;
    for (unsigned i = 0; i < 5; ++i) {
        c += pi[i] * v[i];
    }
    return atan2f(c, 1.0f) * RAD_TO_DEG;
}

void flt_consensus(const struct flt_window *w, float tol_deg, struct flt_result *out) {
    float mean[4], var_mean[4];
    const float n = (float)w->n;
    for (unsigned k = 0; k < 4; ++k) {
        mean[k] = w->sum_x[k] / n;
        float var = (w->sum_xx[k] - n * mean[k] * mean[k]) / (n - 1.0f);
        var = fmaxf(var, 1.0f / 12.0f); /* quantisation floor, as the fixed-point rule */
        var_mean[k] = var / n;
    }
    out->iterations = 0;
    /* α: low A, references B and D, high C; β: low D, references A and C, high B. */
    out->alpha_deg = axis(mean, var_mean, 0, 1, 2, 3, w->arm_mm, tol_deg, &out->iterations);
    out->beta_deg = axis(mean, var_mean, 3, 0, 1, 2, w->arm_mm, tol_deg, &out->iterations);
}

void flt_kalman_init(struct flt_kalman *k, float arm_mm, float r_mm2) {
    memset(k, 0, sizeof *k);
    k->arm_mm = arm_mm;
    for (unsigned i = 0; i < 3; ++i) {
        k->p[i][i] = 1.0e6f;
    }
    for (unsigned s = 0; s < 4; ++s) {
        k->r[s] = r_mm2;
    }
}

void flt_kalman_set_process_noise(struct flt_kalman *k, float q_mean, float q_alpha, float q_beta) {
    k->q[0] = q_mean;
    k->q[1] = q_alpha;
    k->q[2] = q_beta;
}

void flt_kalman_update(struct flt_kalman *k, const uint16_t range_mm[4]) {
    for (unsigned i = 0; i < 3; ++i) {
        k->p[i][i] += k->q[i];
    }
    /* Rows of H (Eq. 5): A [1 -a 0], B [1 0 a], C [1 a 0], D [1 0 -a]. */
    const float a = k->arm_mm;
    const float h[4][3] = {{1.0f, -a, 0.0f}, {1.0f, 0.0f, a}, {1.0f, a, 0.0f}, {1.0f, 0.0f, -a}};
    for (unsigned s = 0; s < 4; ++s) {
        float ph[3];
        for (unsigned i = 0; i < 3; ++i) {
            ph[i] = k->p[i][0] * h[s][0] + k->p[i][1] * h[s][1] + k->p[i][2] * h[s][2];
        }
        const float sv = h[s][0] * ph[0] + h[s][1] * ph[1] + h[s][2] * ph[2] + k->r[s];
        float gain[3];
        for (unsigned i = 0; i < 3; ++i) {
            gain[i] = ph[i] / sv;
        }
        const float innovation =
            (float)range_mm[s] - (h[s][0] * k->x[0] + h[s][1] * k->x[1] + h[s][2] * k->x[2]);
        for (unsigned i = 0; i < 3; ++i) {
            k->x[i] += gain[i] * innovation;
        }
        /* Joseph form: P = (I − K h) P (I − K h)ᵀ + K r Kᵀ. */
        float ikh[3][3], tmp[3][3];
        for (unsigned i = 0; i < 3; ++i) {
            for (unsigned j = 0; j < 3; ++j) {
                ikh[i][j] = (i == j ? 1.0f : 0.0f) - gain[i] * h[s][j];
            }
        }
        for (unsigned i = 0; i < 3; ++i) {
            for (unsigned j = 0; j < 3; ++j) {
                tmp[i][j] =
                    ikh[i][0] * k->p[0][j] + ikh[i][1] * k->p[1][j] + ikh[i][2] * k->p[2][j];
            }
        }
        for (unsigned i = 0; i < 3; ++i) {
            for (unsigned j = 0; j < 3; ++j) {
                k->p[i][j] = tmp[i][0] * ikh[j][0] + tmp[i][1] * ikh[j][1] + tmp[i][2] * ikh[j][2] +
                             gain[i] * k->r[s] * gain[j];
            }
        }
    }
}
