/* Cramér-Rao bound of the linear four-sensor model (crb.h). */
#include "scene/crb.h"

#include <math.h>
#include <string.h>

#include "scene/geometry.h"

/* Rows of H (Eq. 5 of the first paper, docs/explanation/architecture.md) in units of a for columns
 * 2, 3. */
static const double unit_rows[SCENE_SENSORS][3] = {
    {1.0, -1.0, 0.0}, /* A */
    {1.0, 0.0, 1.0},  /* B */
    {1.0, 1.0, 0.0},  /* C */
    {1.0, 0.0, -1.0}, /* D */
};

/* Adds weight·h hᵀ for sensor k to the information matrix j. */
static void add_information(double j[3][3], double arm_mm, unsigned k, double weight) {
    const double h[3] = {unit_rows[k][0], unit_rows[k][1] * arm_mm, unit_rows[k][2] * arm_mm};
    for (unsigned r = 0; r < 3u; ++r) {
        for (unsigned c = 0; c < 3u; ++c) {
            j[r][c] += weight * h[r] * h[c];
        }
    }
}

/* Diagonal of j⁻¹ by cofactors; -1 if j is (numerically) singular. */
static int inverse_diagonal(const double j[3][3], double diag[3]) {
    const double c00 = j[1][1] * j[2][2] - j[1][2] * j[2][1];
    const double c11 = j[0][0] * j[2][2] - j[0][2] * j[2][0];
    const double c22 = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    const double det = j[0][0] * c00 - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0]) +
                       j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
    /* Singular for fewer than three sensors: det is then exactly 0 up to rounding
     * of terms of size trace³; compare relative to that scale. */
    const double scale = j[0][0] * j[1][1] * j[2][2];
    if (!(det > 1e-9 * scale) || !isfinite(det)) {
        return -1;
    }
    diag[0] = c00 / det;
    diag[1] = c11 / det;
    diag[2] = c22 / det;
    return 0;
}

static int finish(const double j[3][3], double alpha_deg, double beta_deg, struct scene_crb *out) {
    double diag[3];
    if (inverse_diagonal(j, diag) != 0) {
        return -1;
    }
    const double ta = tan(scene_deg_to_rad(alpha_deg));
    const double tb = tan(scene_deg_to_rad(beta_deg));
    out->sd_mean_mm = sqrt(diag[0]);
    out->sd_tan_alpha = sqrt(diag[1]);
    out->sd_tan_beta = sqrt(diag[2]);
    /* α = atan(t): dα/dt = 1/(1 + t²), so sd(α) ≥ sd(t)/(1 + t²) to first order. */
    out->sd_alpha_deg = scene_rad_to_deg(out->sd_tan_alpha / (1.0 + ta * ta));
    out->sd_beta_deg = scene_rad_to_deg(out->sd_tan_beta / (1.0 + tb * tb));
    return 0;
}

int scene_crb(double arm_mm, const double sigma_mm[SCENE_SENSORS],
              const uint32_t n_valid[SCENE_SENSORS], double alpha_deg, double beta_deg,
              struct scene_crb *out) {
    if (!(arm_mm > 0.0) || !isfinite(arm_mm) || !isfinite(alpha_deg) || !isfinite(beta_deg)) {
        return -1;
    }
    double j[3][3];
    memset(j, 0, sizeof j);
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        if (n_valid[k] == 0u) {
            continue;
        }
        if (!(sigma_mm[k] > 0.0) || !isfinite(sigma_mm[k])) {
            return -1;
        }
        add_information(j, arm_mm, k, (double)n_valid[k] / (sigma_mm[k] * sigma_mm[k]));
    }
    return finish(j, alpha_deg, beta_deg, out);
}

int scene_crb_with_offset(double arm_mm, const double sigma_mm[SCENE_SENSORS],
                          const double offset_sd_mm[SCENE_SENSORS],
                          const uint32_t n_valid[SCENE_SENSORS], double alpha_deg, double beta_deg,
                          struct scene_crb *out) {
    if (!(arm_mm > 0.0) || !isfinite(arm_mm) || !isfinite(alpha_deg) || !isfinite(beta_deg)) {
        return -1;
    }
    double j[3][3];
    memset(j, 0, sizeof j);
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        if (n_valid[k] == 0u) {
            continue;
        }
        if (!(sigma_mm[k] > 0.0) || !isfinite(sigma_mm[k]) || !(offset_sd_mm[k] >= 0.0) ||
            !isfinite(offset_sd_mm[k])) {
            return -1;
        }
        const double var_mean =
            sigma_mm[k] * sigma_mm[k] / (double)n_valid[k] + offset_sd_mm[k] * offset_sd_mm[k];
        add_information(j, arm_mm, k, 1.0 / var_mean);
    }
    return finish(j, alpha_deg, beta_deg, out);
}

int scene_crb_rows(double arm_mm, const struct scene_row *rows,
                   const double (*sigma_mm)[SCENE_SENSORS], size_t n, struct scene_crb *out) {
    if (!(arm_mm > 0.0) || !isfinite(arm_mm) || n == 0u) {
        return -1;
    }
    double j[3][3];
    memset(j, 0, sizeof j);
    double alpha_sum = 0.0;
    double beta_sum = 0.0;
    for (size_t i = 0; i < n; ++i) {
        if (!rows[i].has_alpha || !rows[i].has_beta) {
            return -1;
        }
        alpha_sum += rows[i].alpha_deg;
        beta_sum += rows[i].beta_deg;
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            if (!scene_row_valid(&rows[i], k)) {
                continue;
            }
            const double s = sigma_mm[i][k];
            if (!(s > 0.0) || !isfinite(s)) {
                return -1;
            }
            add_information(j, arm_mm, k, 1.0 / (s * s));
        }
    }
    return finish(j, alpha_sum / (double)n, beta_sum / (double)n, out);
}
