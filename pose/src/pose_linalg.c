/* 3x3 SVD (one-sided Jacobi), weighted absolute orientation and the perspective
 * image of a circle's centre. Single precision throughout.
 */
#include "pose/pose_linalg.h"

#include <math.h>

/* Columns p and q are treated as orthogonal once |a_p . a_q| <= this * |a_p| |a_q|. */
#define SVD_ORTHO_TOL 1e-6f
/* Singular values below this fraction of the largest are treated as zero. */
#define SVD_RANK_TOL 1e-6f

const char *pose_err_name(int err) {
    switch (err) {
    case POSE_OK:
        return "OK";
    case POSE_ERR_INVALID:
        return "INVALID";
    case POSE_ERR_FRAME:
        return "FRAME";
    case POSE_ERR_DEGENERATE:
        return "DEGENERATE";
    case POSE_ERR_NO_CONVERGE:
        return "NO_CONVERGE";
    default:
        return "UNKNOWN";
    }
}

static void cross3(const float a[3], const float b[3], float out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static float det3(const float m[3][3]) {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

static void get_col(const float m[3][3], int c, float out[3]) {
    for (int k = 0; k < 3; ++k) {
        out[k] = m[k][c];
    }
}

static void set_col(float m[3][3], int c, const float in[3]) {
    for (int k = 0; k < 3; ++k) {
        m[k][c] = in[k];
    }
}

static void swap_cols(float m[3][3], int a, int b) {
    for (int k = 0; k < 3; ++k) {
        float tmp = m[k][a];
        m[k][a] = m[k][b];
        m[k][b] = tmp;
    }
}

/* A unit vector orthogonal to unit vector a. */
static void any_orthogonal(const float a[3], float out[3]) {
    /* Cross with the axis least aligned with a, so the result is well conditioned. */
    float axis[3] = {0.0f, 0.0f, 0.0f};
    float ax = fabsf(a[0]);
    float ay = fabsf(a[1]);
    float az = fabsf(a[2]);
    if (ax <= ay && ax <= az) {
        axis[0] = 1.0f;
    } else if (ay <= az) {
        axis[1] = 1.0f;
    } else {
        axis[2] = 1.0f;
    }
    cross3(a, axis, out);
    float n = sqrtf(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
    for (int k = 0; k < 3; ++k) {
        out[k] /= n;
    }
}

/*
 * One-sided (Hestenes) Jacobi: rotate column pairs of a working copy W = A*V until
 * all columns are mutually orthogonal; then the column norms are the singular
 * values and the normalised columns form U. Accurate in float because it never
 * forms A^T A.
 */
int pose_svd3(const float a[3][3], float u[3][3], float s[3], float v[3][3]) {
    float w[3][3];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            w[i][j] = a[i][j];
            v[i][j] = (i == j) ? 1.0f : 0.0f;
        }
    }
    static const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    int sweeps = 0;
    bool converged = false;
    while (!converged && sweeps < POSE_SVD_MAX_SWEEPS) {
        ++sweeps;
        converged = true;
        for (int k = 0; k < 3; ++k) {
            int p = pairs[k][0];
            int q = pairs[k][1];
            float alpha = 0.0f;
            float beta = 0.0f;
            float gamma = 0.0f;
            for (int i = 0; i < 3; ++i) {
                alpha += w[i][p] * w[i][p];
                beta += w[i][q] * w[i][q];
                gamma += w[i][p] * w[i][q];
            }
            if (fabsf(gamma) <= SVD_ORTHO_TOL * sqrtf(alpha * beta) || gamma == 0.0f) {
                continue;
            }
            converged = false;
            /* Rotation angle that zeroes the (p,q) entry of W^T W (Golub & Van Loan 8.6.3). */
            float zeta = (beta - alpha) / (2.0f * gamma);
            float t = 1.0f / (fabsf(zeta) + sqrtf(1.0f + zeta * zeta));
            if (zeta < 0.0f) {
                t = -t;
            }
            float c = 1.0f / sqrtf(1.0f + t * t);
            float sn = c * t;
            for (int i = 0; i < 3; ++i) {
                float wp = w[i][p];
                float wq = w[i][q];
                w[i][p] = c * wp - sn * wq;
                w[i][q] = sn * wp + c * wq;
                float vp = v[i][p];
                float vq = v[i][q];
                v[i][p] = c * vp - sn * vq;
                v[i][q] = sn * vp + c * vq;
            }
        }
    }
    for (int c = 0; c < 3; ++c) {
        s[c] = sqrtf(w[0][c] * w[0][c] + w[1][c] * w[1][c] + w[2][c] * w[2][c]);
    }
    /* Sort descending (three elements: a fixed bubble pass of three compares). */
    static const int order[3][2] = {{0, 1}, {1, 2}, {0, 1}};
    for (int k = 0; k < 3; ++k) {
        int i = order[k][0];
        int j = order[k][1];
        if (s[j] > s[i]) {
            float tmp = s[i];
            s[i] = s[j];
            s[j] = tmp;
            swap_cols(w, i, j);
            swap_cols(v, i, j);
        }
    }
    /* U columns: normalised W columns; rank-deficient ones completed by cross products. */
    float col0[3];
    float col1[3];
    float col2[3];
    if (s[0] <= 0.0f) {
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                u[i][j] = (i == j) ? 1.0f : 0.0f;
            }
        }
        return sweeps;
    }
    get_col(w, 0, col0);
    for (int k = 0; k < 3; ++k) {
        col0[k] /= s[0];
    }
    if (s[1] > SVD_RANK_TOL * s[0]) {
        get_col(w, 1, col1);
        for (int k = 0; k < 3; ++k) {
            col1[k] /= s[1];
        }
    } else {
        any_orthogonal(col0, col1);
    }
    if (s[2] > SVD_RANK_TOL * s[0]) {
        get_col(w, 2, col2);
        for (int k = 0; k < 3; ++k) {
            col2[k] /= s[2];
        }
    } else {
        cross3(col0, col1, col2);
    }
    set_col(u, 0, col0);
    set_col(u, 1, col1);
    set_col(u, 2, col2);
    return converged ? sweeps : POSE_ERR_NO_CONVERGE;
}

int pose_kabsch(const float (*model)[3], const float (*observed)[3], const float *w, size_t n,
                float r[3][3], float t[3]) {
    if (model == NULL || observed == NULL || r == NULL || t == NULL || n < 3u) {
        return POSE_ERR_INVALID;
    }
    float wsum = 0.0f;
    float pbar[3] = {0.0f, 0.0f, 0.0f};
    float qbar[3] = {0.0f, 0.0f, 0.0f};
    for (size_t i = 0; i < n; ++i) {
        float wi = (w != NULL) ? w[i] : 1.0f;
        if (!(wi >= 0.0f)) { /* also rejects NaN */
            return POSE_ERR_INVALID;
        }
        wsum += wi;
        for (int k = 0; k < 3; ++k) {
            pbar[k] += wi * model[i][k];
            qbar[k] += wi * observed[i][k];
        }
    }
    if (!(wsum > 0.0f)) {
        return POSE_ERR_INVALID;
    }
    for (int k = 0; k < 3; ++k) {
        pbar[k] /= wsum;
        qbar[k] /= wsum;
    }
    /* Cross-covariance H = sum w (p - pbar)(q - qbar)^T (paper Eq. 42). */
    float h[3][3] = {{0.0f}};
    for (size_t i = 0; i < n; ++i) {
        float wi = (w != NULL) ? w[i] : 1.0f;
        float dp[3];
        float dq[3];
        for (int k = 0; k < 3; ++k) {
            dp[k] = model[i][k] - pbar[k];
            dq[k] = observed[i][k] - qbar[k];
        }
        for (int a = 0; a < 3; ++a) {
            for (int b = 0; b < 3; ++b) {
                h[a][b] += wi * dp[a] * dq[b];
            }
        }
    }
    float u[3][3];
    float s[3];
    float v[3][3];
    if (pose_svd3(h, u, s, v) < 0) {
        return POSE_ERR_NO_CONVERGE;
    }
    if (!(s[0] > 0.0f) || s[1] <= SVD_RANK_TOL * s[0]) {
        return POSE_ERR_DEGENERATE;
    }
    /*
     * R = V diag(1, 1, d) U^T with d = det(V U^T): the reflection guard (Arun et
     * al. 1987; the paper's Eq. 45 omits it, and without it a noisy or planar
     * configuration can return a mirror image with det R = -1).
     */
    float d = (det3(v) * det3(u) < 0.0f) ? -1.0f : 1.0f;
    for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) {
            r[a][b] = v[a][0] * u[b][0] + v[a][1] * u[b][1] + d * v[a][2] * u[b][2];
        }
    }
    for (int a = 0; a < 3; ++a) {
        t[a] = qbar[a] - (r[a][0] * pbar[0] + r[a][1] * pbar[1] + r[a][2] * pbar[2]);
    }
    return POSE_OK;
}

float pose_rotation_angle(const float a[3][3], const float b[3][3]) {
    /* m = a^T b; angle from both its trace (cos) and skew part (sin): accurate near 0. */
    float m[3][3];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            m[i][j] = a[0][i] * b[0][j] + a[1][i] * b[1][j] + a[2][i] * b[2][j];
        }
    }
    float cos2 = m[0][0] + m[1][1] + m[2][2] - 1.0f;
    float sx = m[2][1] - m[1][2];
    float sy = m[0][2] - m[2][0];
    float sz = m[1][0] - m[0][1];
    float sin2 = sqrtf(sx * sx + sy * sy + sz * sz);
    return atan2f(sin2, cos2);
}

int pose_circle_image_centre(const float centre[3], const float normal[3], float radius_mm,
                             float out_xy[2]) {
    /*
     * Circle in its plane: dual conic diag(r^2, r^2, -1); plane-to-image map M = [e1 e2 C].
     * The image ellipse centre is the pole of the image line at infinity:
     * c = M Q* M^T (0,0,1)^T ~ C_z C - r^2 (z - n_z n), since e1 e1^T + e2 e2^T = I - n n^T.
     */
    float r2 = radius_mm * radius_mm;
    float nz = normal[2];
    float vx = centre[2] * centre[0] + r2 * nz * normal[0];
    float vy = centre[2] * centre[1] + r2 * nz * normal[1];
    float vz = centre[2] * centre[2] - r2 * (1.0f - nz * nz);
    if (!(centre[2] > 0.0f) || !(vz > 0.0f)) {
        return POSE_ERR_DEGENERATE;
    }
    out_xy[0] = vx / vz;
    out_xy[1] = vy / vz;
    return POSE_OK;
}
