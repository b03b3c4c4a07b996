/* The pose pipeline: configuration, extraction -> matching -> pose (paper §3-5). */
#include "pose/pose.h"

#include <math.h>
#include <string.h>

#include "pose/pose_linalg.h"
#include "pose_internal.h"

/* Rounds of "drop the worst match and solve again" after the first SVD and after refinement. */
#define MAX_GATE_ROUNDS 4u

const char *pose_status_name(enum pose_status status) {
    switch (status) {
    case POSE_STATUS_OK:
        return "OK";
    case POSE_STATUS_DEGRADED:
        return "DEGRADED";
    case POSE_STATUS_FEW_BLOBS:
        return "FEW_BLOBS";
    case POSE_STATUS_NO_MATCH:
        return "NO_MATCH";
    case POSE_STATUS_DEGENERATE:
        return "DEGENERATE";
    case POSE_STATUS_RESIDUAL:
        return "RESIDUAL";
    case POSE_STATUS_IMPLAUSIBLE:
        return "IMPLAUSIBLE";
    case POSE_STATUS_RUN_OVERFLOW:
        return "RUN_OVERFLOW";
    default:
        return "UNKNOWN";
    }
}

void pose_config_default(struct pose_config *cfg) {
    memset(cfg, 0, sizeof *cfg);
    /* EPC660 gray is 12-bit (epc660 datasheet: 12-bit ADC). */
    cfg->gray_full_scale = 4095u;
    /*
     * T_g = 25 % of full scale: the reflectors image at ~80 % and the black plate at
     * ~6 %; with 2 % gray noise the plate stays > 9 sigma below (the paper uses an
     * empirical fraction of the maximum gray, value not printed).
     */
    cfg->gray_threshold = 1024u;
    /* N_max: all eight markers at 0.55 m cover ~15 000 pixels; the cap bites nearer. */
    cfg->active_cap = 24000u;
    /* sigma 1 px: a 7 x 7 kernel, matched to the smallest blobs (~1-3 px at 10-15 m). */
    cfg->nlog_sigma_px = 1.0f;
    /*
     * For discs much larger than the kernel the nLoG is a rim detector: ~0 inside,
     * positive just inside the edge, negative on partially covered edge pixels.
     * The keep threshold is therefore negative, so interiors (response ~0 +- noise)
     * survive and only the faint outer fringe is trimmed.
     */
    cfg->nlog_keep = -600.0f;
    cfg->nlog_peak = 200.0f;
    cfg->gray_peak = 1600u;
    cfg->blob_min_pixels = 1u;
    cfg->blob_max_pixels = 40000u;
    /* Discs tilted 20 deg seen 26 deg off axis: axis ratio >= cos 46 deg = 0.69. */
    cfg->min_axis_ratio = 0.5f;
    /* Below ~4 px across, pixelisation dominates the moments (a 2-pixel blob has ratio 0). */
    cfg->shape_min_pixels = 12u;
    cfg->ellipse_rim_tolerance = 0.15f;
    cfg->ellipse_rim_fraction = 0.8f;
    cfg->ellipse_area_tolerance = 0.2f;
    cfg->ellipse_min_pixels = 30u;
    /*
     * Two equal touching discs have moment axis ratio r / sqrt(r^2 + D^2) <= 1/sqrt(5)
     * = 0.447 (D >= 2r): such a merged pair must never be re-admitted as one disc.
     */
    cfg->readmit_min_axis_ratio = 0.45f;

    /*
     * Centroid error model: 0.02 px floor (pixel-lock of the thresholded blob, seen
     * noise-free on the synthetic camera) plus 0.2 px / sqrt(pixels) from noise.
     */
    cfg->centroid_sigma_floor_px = 0.02f;
    cfg->centroid_sigma_one_px = 0.2f;
    /* Marker depths spread about +-150 mm about their median (heights, tilt <= 20 deg). */
    cfg->depth_spread_mm = 100.0f;
    cfg->range_sigma_fraction = 0.01f;
    /* Mean range of a tilted disc's pixels vs its centre: ~1-4 mm at 0.15-1 m. */
    cfg->range_floor_mm = 2.0f;
    pose_match_config_default(&cfg->match);
    cfg->refine_max_iterations = 200u;
    cfg->refine_optimal_translation = true;
    cfg->refine_tol_mm = 0.002f;
    cfg->reproj_gate_px = 1.5f;
    cfg->range_gate_sigmas = 5.0f;
    cfg->fuse_range = true;
    cfg->fuse_max_iterations = 10u;
    cfg->loo_gate_sigmas = 8.0f;

    cfg->perspective_correction = true;
}

void pose_camera_paper(struct pose_camera *cam) {
    /* Paper §2.1: 320 x 240 pixels, HFOV 52.4 deg, VFOV 40.6 deg; f = (N/2) / tan(FOV/2). */
    const float deg = 3.14159265f / 180.0f;
    cam->width = 320u;
    cam->height = 240u;
    cam->fx_px = 160.0f / tanf(26.2f * deg);
    cam->fy_px = 120.0f / tanf(20.3f * deg);
    cam->cx_px = 159.5f;
    cam->cy_px = 119.5f;
}

static bool config_valid(const struct pose_config *c) {
    return c->gray_full_scale > 0u && c->gray_threshold > 0u &&
           c->gray_threshold <= c->gray_full_scale && c->active_cap > 0u &&
           c->nlog_sigma_px >= 0.5f && 3.0f * c->nlog_sigma_px <= (float)POSE_NLOG_MAX_RADIUS &&
           c->blob_min_pixels >= 1u && c->blob_max_pixels >= c->blob_min_pixels &&
           c->min_axis_ratio >= 0.0f && c->min_axis_ratio <= 1.0f &&
           c->ellipse_rim_tolerance > 0.0f && c->ellipse_rim_fraction >= 0.0f &&
           c->ellipse_rim_fraction <= 1.0f && c->ellipse_area_tolerance > 0.0f &&
           c->centroid_sigma_floor_px > 0.0f && c->centroid_sigma_one_px >= 0.0f &&
           c->depth_spread_mm > 0.0f && c->range_sigma_fraction > 0.0f &&
           c->refine_max_iterations >= 1u && c->refine_tol_mm > 0.0f && c->reproj_gate_px > 0.0f &&
           c->range_gate_sigmas > 0.0f && c->range_floor_mm >= 0.0f && c->fuse_max_iterations >= 1u;
}

int pose_init(struct pose_pipeline *p, const struct pose_config *cfg, const struct pose_camera *cam,
              const struct pose_marker *markers, size_t n_markers) {
    if (p == NULL || cfg == NULL || cam == NULL || markers == NULL || n_markers < 2u ||
        n_markers > POSE_MAX_MARKERS || !config_valid(cfg) ||
        !pose_match_config_valid(&cfg->match)) {

        return POSE_ERR_INVALID;
    }
    if (cam->width == 0u || cam->height == 0u || cam->width > POSE_MAX_WIDTH ||
        cam->height > POSE_MAX_HEIGHT || !(cam->fx_px > 0.0f) || !(cam->fy_px > 0.0f)) {
        return POSE_ERR_INVALID;
    }
    for (size_t i = 0; i < n_markers; ++i) {
        if (!(markers[i].diameter_mm > 0.0f)) {
            return POSE_ERR_INVALID;
        }
    }
    memset(p, 0, sizeof *p);
    p->cfg = *cfg;
    p->cam = *cam;
    memcpy(p->markers, markers, n_markers * sizeof markers[0]);
    p->n_markers = (uint8_t)n_markers;
    pose_nlog_kernel(&p->ws, cfg->nlog_sigma_px);
    return POSE_OK;
}

static int check_frame(const struct pose_pipeline *p, const struct pose_frame *f) {
    if (f->gray == NULL || f->range_mm == NULL) {
        return POSE_ERR_INVALID;
    }
    if (f->width != p->cam.width || f->height != p->cam.height || f->stride < f->width) {
        return POSE_ERR_FRAME;
    }
    return POSE_OK;
}

int pose_extract(struct pose_pipeline *p, const struct pose_frame *frame, struct pose_result *out,
                 uint16_t *bad_x, uint16_t *bad_y) {
    if (p == NULL || frame == NULL || out == NULL) {
        return POSE_ERR_INVALID;
    }
    memset(out, 0, sizeof *out);
    int err = check_frame(p, frame);
    if (err != POSE_OK) {
        return err;
    }
    uint8_t n_comp = 0u;
    return pose_extract_frame(p, frame, out, bad_x, bad_y, &n_comp);
}

/* Unit line of sight through pixel (u, v) (paper Eqs. 7-9). */
static void line_of_sight(const struct pose_camera *cam, float u, float v, float e[3]) {
    float x = (u - cam->cx_px) / cam->fx_px;
    float y = (v - cam->cy_px) / cam->fy_px;
    float n = sqrtf(x * x + y * y + 1.0f);
    e[0] = x / n;
    e[1] = y / n;
    e[2] = 1.0f / n;
}

/* Median of up to POSE_MAX_OBS values (insertion sort of a copy). */
static float median(const float *v, size_t n) {
    float tmp[POSE_MAX_OBS];
    for (size_t i = 0; i < n; ++i) {
        float x = v[i];
        size_t j = i;
        while (j > 0u && tmp[j - 1u] > x) {
            tmp[j] = tmp[j - 1u];
            --j;
        }
        tmp[j] = x;
    }
    if (n == 0u) {
        return 0.0f;
    }
    return (n % 2u == 1u) ? tmp[n / 2u] : 0.5f * (tmp[n / 2u - 1u] + tmp[n / 2u]);
}

/*
 * 3-D point of a blob for matching and the first SVD: range along the centroid's
 * line of sight. A one-pixel blob's range is as noisy as one pixel (1 % of range
 * here); at 15 m that is 150 mm, more than the markers' depth spread, so the
 * range is shrunk toward the median of all blob ranges in proportion to its
 * variance (posterior mean with prior spread depth_spread_mm). Near range the
 * standard error is < 1 mm and the shrinkage vanishes.
 */
/* Statistical standard error of a blob's mean range: sample value, floored at one pixel's. */
static float blob_range_se(const struct pose_config *cfg, const struct pose_blob *b) {
    float floor_se = b->range_mm * cfg->range_sigma_fraction / sqrtf((float)b->pixels);
    return (b->pixels < 2u || b->range_se_mm < floor_se) ? floor_se : b->range_se_mm;
}

static void blob_point(const struct pose_pipeline *p, const struct pose_blob *b, float med,
                       float point[3], float *range_sigma_out, float *lateral_out) {
    const struct pose_config *cfg = &p->cfg;
    float se = blob_range_se(cfg, b);
    float prior2 = cfg->depth_spread_mm * cfg->depth_spread_mm;
    float k = prior2 / (prior2 + se * se);
    float range = med + k * (b->range_mm - med);
    float range_sigma = se * sqrtf(k);
    float lateral = range * b->centroid_sigma_px / p->cam.fx_px;
    float e[3];
    line_of_sight(&p->cam, b->u_px, b->v_px, e);
    for (int i = 0; i < 3; ++i) {
        point[i] = range * e[i];
    }
    *range_sigma_out = range_sigma;
    *lateral_out = lateral;
}

static void apply(const float r[3][3], const float t[3], const float x[3], float out[3]) {
    for (int i = 0; i < 3; ++i) {
        out[i] = r[i][0] * x[0] + r[i][1] * x[1] + r[i][2] * x[2] + t[i];
    }
}

/* Solver state over the (at most POSE_MAX_MARKERS) matches. */
struct solve_set {
    size_t n;
    float model[POSE_MAX_MARKERS][3];
    float point[POSE_MAX_MARKERS][3]; /* 3-D observations, then line-of-sight projections */
    float sigma[POSE_MAX_MARKERS];
    float weight[POSE_MAX_MARKERS];
    float radius[POSE_MAX_MARKERS];
    float u[POSE_MAX_MARKERS]; /* raw centroids */
    float v[POSE_MAX_MARKERS];
    float uc[POSE_MAX_MARKERS]; /* centroids after the perspective correction */
    float vc[POSE_MAX_MARKERS];
    float range[POSE_MAX_MARKERS];
    float range_sigma[POSE_MAX_MARKERS]; /* statistical and systematic */
    float centroid_sigma[POSE_MAX_MARKERS];
    uint8_t blob[POSE_MAX_MARKERS];
    uint8_t marker[POSE_MAX_MARKERS];
};

static void remove_entry(struct solve_set *s, size_t k) {
    for (size_t i = k; i + 1u < s->n; ++i) {
        memcpy(s->model[i], s->model[i + 1u], sizeof s->model[i]);
        memcpy(s->point[i], s->point[i + 1u], sizeof s->point[i]);
        s->sigma[i] = s->sigma[i + 1u];
        s->weight[i] = s->weight[i + 1u];
        s->radius[i] = s->radius[i + 1u];
        s->u[i] = s->u[i + 1u];
        s->v[i] = s->v[i + 1u];
        s->uc[i] = s->uc[i + 1u];
        s->vc[i] = s->vc[i + 1u];
        s->range[i] = s->range[i + 1u];
        s->range_sigma[i] = s->range_sigma[i + 1u];
        s->centroid_sigma[i] = s->centroid_sigma[i + 1u];
        s->blob[i] = s->blob[i + 1u];
        s->marker[i] = s->marker[i + 1u];
    }
    --s->n;
}

/*
 * Perspective correction: a tilted disc images as an ellipse whose centre (which
 * the intensity-weighted centroid estimates) is offset from the image of the disc
 * centre by ~ f r^2 sin(2 theta) / (2 Z^2): 0.5 px for an 80 mm marker at 0.55 m
 * tilted 20 deg, ten times the 0.06 px the paper reports for centroiding. With the
 * current pose the offset is predicted exactly (pose_circle_image_centre) and
 * removed. The paper does not model it.
 */
static void corrected_centroid(const struct pose_pipeline *p, const float r[3][3], const float t[3],
                               const struct solve_set *s, size_t k, float *uc, float *vc) {
    *uc = s->u[k];
    *vc = s->v[k];
    if (!p->cfg.perspective_correction) {
        return;
    }
    float c[3];
    apply(r, t, s->model[k], c);
    float normal[3] = {r[0][2], r[1][2], r[2][2]}; /* target z axis in the camera frame */
    float ell[2];
    if (c[2] <= 0.0f || pose_circle_image_centre(c, normal, s->radius[k], ell) != POSE_OK) {
        return;
    }
    *uc -= p->cam.fx_px * (ell[0] - c[0] / c[2]);
    *vc -= p->cam.fy_px * (ell[1] - c[1] / c[2]);
}

/*
 * Line-of-sight refinement (paper §5.2, Eqs. 47-48): replace each observation by
 * the point of its measured line of sight nearest the current prediction,
 * q_i = e_i e_i^T (R p_i + t), and solve the SVD again, until the pose changes by
 * less than refine_tol_mm. This is block-coordinate descent on the object-space
 * collinearity error (Lu, Hager & Mjolsness 2000), so it cannot diverge; the
 * measured ranges only seed it. Returns iterations used, or a negative pose_err.
 */
/*
 * t minimising sum_i w_i |(I - e_i e_i^T)(R p_i + t)|^2 for fixed R (Lu, Hager &
 * Mjolsness 2000, Eq. 20): t = -A^-1 sum_i w_i (I - e_i e_i^T) R p_i with
 * A = sum_i w_i (I - e_i e_i^T). False if A is singular (all lines of sight parallel).
 */
static bool optimal_translation(const struct solve_set *s, const float (*los)[3],
                                const float r[3][3], float t[3]) {
    float a[3][3] = {{0.0f}};
    float b[3] = {0.0f, 0.0f, 0.0f};
    const float zero[3] = {0.0f, 0.0f, 0.0f};
    for (size_t k = 0; k < s->n; ++k) {
        const float *e = los[k];
        float rp[3];
        apply(r, zero, s->model[k], rp);
        float along = e[0] * rp[0] + e[1] * rp[1] + e[2] * rp[2];
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                a[i][j] += s->weight[k] * (((i == j) ? 1.0f : 0.0f) - e[i] * e[j]);
            }
            b[i] += s->weight[k] * (rp[i] - along * e[i]);
        }
    }
    /* Symmetric 3x3 inverse by cofactors. */
    float c00 = a[1][1] * a[2][2] - a[1][2] * a[2][1];
    float c01 = a[1][2] * a[2][0] - a[1][0] * a[2][2];
    float c02 = a[1][0] * a[2][1] - a[1][1] * a[2][0];
    float det = a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02;
    float scale = a[0][0] + a[1][1] + a[2][2];
    if (!(fabsf(det) > 1e-12f * scale * scale * scale)) {
        return false;
    }
    float inv[3][3] = {
        {c00, a[0][2] * a[2][1] - a[0][1] * a[2][2], a[0][1] * a[1][2] - a[0][2] * a[1][1]},
        {c01, a[0][0] * a[2][2] - a[0][2] * a[2][0], a[0][2] * a[1][0] - a[0][0] * a[1][2]},
        {c02, a[0][1] * a[2][0] - a[0][0] * a[2][1], a[0][0] * a[1][1] - a[0][1] * a[1][0]}};
    for (int i = 0; i < 3; ++i) {
        t[i] = -(inv[i][0] * b[0] + inv[i][1] * b[1] + inv[i][2] * b[2]) / det;
    }
    return true;
}

/*
 * Line-of-sight refinement (paper §5.2, Eqs. 47-48): replace each observation by
 * the point of its measured line of sight nearest the current prediction,
 * q_i = e_i e_i^T (R p_i + t), and solve the SVD again, until the pose changes by
 * less than refine_tol_mm. This is block-coordinate descent on the object-space
 * collinearity error, so it cannot diverge; the measured ranges only seed it.
 * As written in the paper each SVD also supplies t, and convergence is slow
 * (~100 iterations at 0.7 m); with refine_optimal_translation, t is instead
 * re-solved in closed form for the current R before projecting (Lu, Hager &
 * Mjolsness 2000, "orthogonal iteration"): same fixed point, far fewer
 * iterations. Returns iterations used, or a negative pose_err.
 */
static int refine(const struct pose_pipeline *p, struct solve_set *s, float r[3][3], float t[3],
                  bool *converged) {
    const struct pose_config *cfg = &p->cfg;
    *converged = false;
    int it = 0;
    float los[POSE_MAX_MARKERS][3];
    float prev_step = 0.0f;
    while (it < (int)cfg->refine_max_iterations) {
        ++it;
        for (size_t k = 0; k < s->n; ++k) {
            corrected_centroid(p, r, t, s, k, &s->uc[k], &s->vc[k]);
            line_of_sight(&p->cam, s->uc[k], s->vc[k], los[k]);
            float c[3];
            apply(r, t, s->model[k], c);
            float along = los[k][0] * c[0] + los[k][1] * c[1] + los[k][2] * c[2];
            /* Weight 1 / (object-space sigma)^2: the centroid's angular error times range. */
            float sigma_mm = along * s->centroid_sigma[k] / p->cam.fx_px;
            s->weight[k] = 1.0f / (sigma_mm * sigma_mm);
        }
        float t_used[3] = {t[0], t[1], t[2]};
        if (cfg->refine_optimal_translation) {
            (void)optimal_translation(s, (const float(*)[3])los, r, t_used);
        }
        for (size_t k = 0; k < s->n; ++k) {
            float c[3];
            apply(r, t_used, s->model[k], c);
            float along = los[k][0] * c[0] + los[k][1] * c[1] + los[k][2] * c[2];
            for (int i = 0; i < 3; ++i) {
                s->point[k][i] = along * los[k][i];
            }
        }
        float r2[3][3];
        float t2[3];
        int err = pose_kabsch((const float(*)[3])s->model, (const float(*)[3])s->point, s->weight,
                              s->n, r2, t2);
        if (err != POSE_OK) {
            return err;
        }
        float dt = sqrtf((t2[0] - t[0]) * (t2[0] - t[0]) + (t2[1] - t[1]) * (t2[1] - t[1]) +
                         (t2[2] - t[2]) * (t2[2] - t[2]));
        float dtheta = pose_rotation_angle(r, r2) * 1000.0f; /* over a 1 m lever */
        memcpy(r, r2, sizeof r2);
        memcpy(t, t2, sizeof t2);
        /*
         * Stop on the change still to come, not on the last step: the iteration
         * converges linearly, often slowly (ratio q of successive steps near 1), and
         * then the remaining distance to the fixed point is step / (1 - q), far more
         * than the step itself. The relative floor is ~8 float ulps of |t|: the
         * steps of a converged iteration jitter at that level (4e-4 mm at 1 m).
         */
        float step = (dt > dtheta) ? dt : dtheta;
        float remaining = step;
        if (prev_step > 0.0f && step < prev_step) {
            remaining = step / (1.0f - step / prev_step);
        }
        prev_step = step;
        float tol = cfg->refine_tol_mm + 5e-7f * sqrtf(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
        if (remaining < tol) {
            *converged = true;
            break;
        }
    }
    return it;
}

/* Solves the symmetric positive definite 6x6 system h x = g by Cholesky; false if not SPD. */
static bool solve6(float h[6][6], const float g[6], float x[6]) {
    for (int i = 0; i < 6; ++i) {
        x[i] = 0.0f;
    }

    float l[6][6] = {{0.0f}};
    for (int i = 0; i < 6; ++i) {
        for (int j = 0; j <= i; ++j) {
            float sum = h[i][j];
            for (int k = 0; k < j; ++k) {
                sum -= l[i][k] * l[j][k];
            }
            if (i == j) {
                if (!(sum > 0.0f)) {
                    return false;
                }
                l[i][i] = sqrtf(sum);
            } else {
                l[i][j] = sum / l[j][j];
            }
        }
    }
    float y[6] = {0.0f};
    for (int i = 0; i < 6; ++i) {
        float sum = g[i];
        for (int k = 0; k < i; ++k) {
            sum -= l[i][k] * y[k];
        }
        y[i] = sum / l[i][i];
    }
    for (int i = 5; i >= 0; --i) {
        float sum = y[i];
        for (int k = i + 1; k < 6; ++k) {
            sum -= l[k][i] * x[k];
        }
        x[i] = sum / l[i][i];
    }
    return true;
}

/* r <- exp([w]x) r (Rodrigues), re-orthonormalised implicitly by the exact exponential. */
static void rotate_by(float r[3][3], const float w[3]) {
    float th = sqrtf(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    float a = 1.0f;
    float b = 0.5f;
    if (th > 1e-4f) {
        a = sinf(th) / th;
        b = (1.0f - cosf(th)) / (th * th);
    }
    float k[3][3] = {{0.0f, -w[2], w[1]}, {w[2], 0.0f, -w[0]}, {-w[1], w[0], 0.0f}};
    float e[3][3];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            float kk = k[i][0] * k[0][j] + k[i][1] * k[1][j] + k[i][2] * k[2][j];
            e[i][j] = ((i == j) ? 1.0f : 0.0f) + a * k[i][j] + b * kk;
        }
    }
    float out[3][3];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            out[i][j] = e[i][0] * r[0][j] + e[i][1] * r[1][j] + e[i][2] * r[2][j];
        }
    }
    memcpy(r, out, sizeof out);
}

/*
 * Range fusion (our extension, after the paper's refinement): the line-of-sight
 * refinement discards the measured ranges, which costs accuracy beyond ~2 m where
 * the bearings of a 0.4 m target barely constrain its tilt. This Gauss-Newton
 * polish minimises the full weighted error, image residuals over each blob's
 * modelled centroid error plus range residuals over its range standard error,
 * starting from the refined pose. Near range the bearings dominate and it
 * changes little. Returns the iterations taken (0 if the system was singular);
 * *converged tells whether the last step was below refine_tol_mm.
 */
static uint8_t fuse_ranges(const struct pose_pipeline *p, struct solve_set *s, float r[3][3],
                           float t[3], bool *converged) {
    const struct pose_camera *cam = &p->cam;
    uint8_t it = 0u;
    *converged = false;
    while (it < p->cfg.fuse_max_iterations) {
        float h[6][6] = {{0.0f}};
        float g[6] = {0.0f};
        for (size_t k = 0; k < s->n; ++k) {
            corrected_centroid(p, r, t, s, k, &s->uc[k], &s->vc[k]);
            float rp[3];
            const float zero[3] = {0.0f, 0.0f, 0.0f};
            apply(r, zero, s->model[k], rp);
            const float y[3] = {rp[0] + t[0], rp[1] + t[1], rp[2] + t[2]};
            if (!(y[2] > 0.0f)) {
                return it;
            }
            float dist = sqrtf(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
            /* Residual rows: u, v (normalised by sigma in px) and range (by its sigma). */
            float su = 1.0f / s->centroid_sigma[k];
            float sr = 1.0f / s->range_sigma[k];
            const float res[3] = {su * (cam->fx_px * y[0] / y[2] + cam->cx_px - s->uc[k]),
                                  su * (cam->fy_px * y[1] / y[2] + cam->cy_px - s->vc[k]),
                                  sr * (dist - s->range[k])};
            float dy[3][3] = {
                {su * cam->fx_px / y[2], 0.0f, -su * cam->fx_px * y[0] / (y[2] * y[2])},
                {0.0f, su * cam->fy_px / y[2], -su * cam->fy_px * y[1] / (y[2] * y[2])},
                {sr * y[0] / dist, sr * y[1] / dist, sr * y[2] / dist}};
            /* dy/dw = -[r p]x, dy/dt = I. */
            float rx[3][3] = {{0.0f, rp[2], -rp[1]}, {-rp[2], 0.0f, rp[0]}, {rp[1], -rp[0], 0.0f}};
            float jac[3][6];
            for (int row = 0; row < 3; ++row) {
                for (int c = 0; c < 3; ++c) {
                    jac[row][c] =
                        dy[row][0] * rx[0][c] + dy[row][1] * rx[1][c] + dy[row][2] * rx[2][c];
                    jac[row][c + 3] = dy[row][c];
                }
            }
            for (int a = 0; a < 6; ++a) {
                for (int row = 0; row < 3; ++row) {
                    g[a] -= jac[row][a] * res[row];
                    for (int b = 0; b < 6; ++b) {
                        h[a][b] += jac[row][a] * jac[row][b];
                    }
                }
            }
        }
        float step[6];
        if (!solve6(h, g, step)) {
            return it;
        }
        ++it;
        rotate_by(r, step);
        t[0] += step[3];
        t[1] += step[4];
        t[2] += step[5];
        float dt = sqrtf(step[3] * step[3] + step[4] * step[4] + step[5] * step[5]);
        float dw = sqrtf(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]) * 1000.0f;
        float tol = p->cfg.refine_tol_mm + 2e-6f * sqrtf(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
        if (dt < tol && dw < tol) {
            *converged = true;
            break;
        }
    }
    return it;
}

/* Normalised residual of match k under (r, t): image and range errors over their sigmas. */
static float match_chi(const struct pose_pipeline *p, struct solve_set *s, size_t k,
                       const float r[3][3], const float t[3]) {
    float uc;
    float vc;
    corrected_centroid(p, r, t, s, k, &uc, &vc);
    float c[3];
    apply(r, t, s->model[k], c);
    if (!(c[2] > 0.0f)) {
        return 1e30f;
    }
    float du = (p->cam.fx_px * c[0] / c[2] + p->cam.cx_px - uc) / s->centroid_sigma[k];
    float dv = (p->cam.fy_px * c[1] / c[2] + p->cam.cy_px - vc) / s->centroid_sigma[k];
    float dr = (sqrtf(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) - s->range[k]) / s->range_sigma[k];
    return sqrtf(du * du + dv * dv + dr * dr);
}

/*
 * Leave-one-out check (ours): with few matches a wrong one is absorbed by the fit
 * (a rotated pose explains it within the gates, seen at >= 5 m). Each match is
 * predicted from the pose fitted to all the others (a few fused Gauss-Newton
 * steps from the current pose); returns the match with the largest normalised
 * prediction error and that error in *chi.
 */
static size_t leave_one_out_worst(const struct pose_pipeline *p, const struct solve_set *s,
                                  const float r[3][3], const float t[3], float *chi) {
    size_t worst = s->n;
    *chi = 0.0f;
    for (size_t k = 0; k < s->n; ++k) {
        struct solve_set rest = *s;
        remove_entry(&rest, k);
        float r2[3][3];
        float t2[3];
        memcpy(r2, r, sizeof r2);
        memcpy(t2, t, sizeof t2);
        bool converged = false;
        (void)fuse_ranges(p, &rest, r2, t2, &converged);
        struct solve_set one = *s;
        float x = match_chi(p, &one, k, (const float(*)[3])r2, t2);
        if (x > *chi) {
            *chi = x;
            worst = k;
        }
    }
    return worst;
}

/* Initial SVD on the 3-D points with outlier rejection; returns POSE_OK or an error. */
static int initial_pose(const struct pose_pipeline *p, struct solve_set *s, float r[3][3],
                        float t[3], uint8_t *dropped) {
    const struct pose_match_config *m = &p->cfg.match;
    for (uint32_t round = 0; round <= MAX_GATE_ROUNDS; ++round) {
        for (size_t k = 0; k < s->n; ++k) {
            s->weight[k] = 1.0f / (s->sigma[k] * s->sigma[k] + 1.0f);
        }
        int err = pose_kabsch((const float(*)[3])s->model, (const float(*)[3])s->point, s->weight,
                              s->n, r, t);
        if (err != POSE_OK) {
            return err;
        }
        size_t worst = s->n;
        float worst_excess = 1.0f;
        for (size_t k = 0; k < s->n; ++k) {
            float c[3];
            apply(r, t, s->model[k], c);
            float d = sqrtf((c[0] - s->point[k][0]) * (c[0] - s->point[k][0]) +
                            (c[1] - s->point[k][1]) * (c[1] - s->point[k][1]) +
                            (c[2] - s->point[k][2]) * (c[2] - s->point[k][2]));
            float gate = m->tol_mm + m->tol_sigmas * s->sigma[k];
            if (d / gate > worst_excess) {
                worst_excess = d / gate;
                worst = k;
            }
        }
        if (worst == s->n || s->n <= 3u) {
            return POSE_OK;
        }
        remove_entry(s, worst);
        ++*dropped;
    }
    return POSE_OK;
}

int pose_solve(struct pose_pipeline *p, const struct pose_blob *blobs, const uint8_t *blob_idx,
               const uint8_t *marker_idx, size_t n, struct pose_result *out) {
    if (p == NULL || blobs == NULL || blob_idx == NULL || marker_idx == NULL || out == NULL ||
        n > POSE_MAX_MARKERS) {
        return POSE_ERR_INVALID;
    }
    struct solve_set s;
    s.n = n;
    float ranges[POSE_MAX_MARKERS];
    for (size_t k = 0; k < n; ++k) {
        if (marker_idx[k] >= p->n_markers || blob_idx[k] >= POSE_MAX_OBS) {
            return POSE_ERR_INVALID;
        }
        ranges[k] = blobs[blob_idx[k]].range_mm;
    }
    float med = median(ranges, n);
    for (size_t k = 0; k < n; ++k) {
        const struct pose_blob *b = &blobs[blob_idx[k]];
        const struct pose_marker *mk = &p->markers[marker_idx[k]];
        memcpy(s.model[k], mk->position_mm, sizeof s.model[k]);
        float range_sigma;
        float lateral;
        blob_point(p, b, med, s.point[k], &range_sigma, &lateral);
        s.sigma[k] = sqrtf(range_sigma * range_sigma + lateral * lateral);
        s.radius[k] = 0.5f * mk->diameter_mm;
        s.u[k] = b->u_px;
        s.v[k] = b->v_px;
        s.uc[k] = b->u_px;
        s.vc[k] = b->v_px;
        s.range[k] = b->range_mm;
        float se = blob_range_se(&p->cfg, b);
        s.range_sigma[k] = sqrtf(se * se + p->cfg.range_floor_mm * p->cfg.range_floor_mm);
        s.centroid_sigma[k] = b->centroid_sigma_px;
        s.blob[k] = blob_idx[k];
        s.marker[k] = marker_idx[k];
    }
    out->n_matches = 0u;
    if (n < 3u) {
        out->status = POSE_STATUS_NO_MATCH;
        return POSE_OK;
    }
    float r[3][3];
    float t[3];
    uint8_t dropped = 0u;
    int err = initial_pose(p, &s, r, t, &dropped);
    bool converged = false;
    int iterations = 0;
    bool gated = false;
    for (uint32_t round = 0; err == POSE_OK && round <= MAX_GATE_ROUNDS; ++round) {
        iterations = refine(p, &s, r, t, &converged);
        if (iterations < 0) {
            err = iterations;
            break;
        }
        if (p->cfg.fuse_range) {
            bool fused = false;
            out->fuse_iterations = fuse_ranges(p, &s, r, t, &fused);
            /* The refinement's bound is not a failure when the fused solution converged. */
            converged = converged || fused;
        }
        /* Final residuals: reprojection (px) and range along the line of sight (mm). */
        size_t worst = s.n;
        float worst_excess = 1.0f;
        for (size_t k = 0; k < s.n; ++k) {
            float c[3];
            apply(r, t, s.model[k], c);
            float du = p->cam.fx_px * c[0] / c[2] + p->cam.cx_px - s.uc[k];
            float dv = p->cam.fy_px * c[1] / c[2] + p->cam.cy_px - s.vc[k];
            float reproj = sqrtf(du * du + dv * dv);
            float dist = sqrtf(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
            float range_res = s.range[k] - dist;
            float range_gate = p->cfg.range_gate_sigmas * s.range_sigma[k];
            float excess = reproj / p->cfg.reproj_gate_px;
            if (fabsf(range_res) / range_gate > excess) {
                excess = fabsf(range_res) / range_gate;
            }
            if (excess > worst_excess) {
                worst_excess = excess;
                worst = k;
            }
        }
        if (worst == s.n && s.n >= 4u && p->cfg.loo_gate_sigmas > 0.0f) {
            float chi = 0.0f;
            size_t loo = leave_one_out_worst(p, &s, (const float(*)[3])r, t, &chi);
            if (chi > p->cfg.loo_gate_sigmas) {
                worst = loo;
            }
        }
        if (worst == s.n) {
            gated = true;
            break;
        }
        if (s.n <= 3u) {
            break;
        }
        remove_entry(&s, worst);
        ++dropped;
    }
    out->dropped_matches = dropped;
    out->refine_iterations = (uint16_t)((iterations > 0) ? iterations : 0);
    if (err == POSE_ERR_DEGENERATE) {
        out->status = POSE_STATUS_DEGENERATE;
        return POSE_OK;
    }
    if (err != POSE_OK) {
        out->status = POSE_STATUS_RESIDUAL;
        return POSE_OK;
    }
    memcpy(out->r, r, sizeof r);
    memcpy(out->t_mm, t, sizeof out->t_mm);
    /* Reflectors are seen only from the plate's front: its normal must face the camera. */
    bool facing = r[0][2] * t[0] + r[1][2] * t[1] + r[2][2] * t[2] < 0.0f;
    float sum_reproj = 0.0f;
    float sum_range = 0.0f;
    float sum_obj = 0.0f;
    for (size_t k = 0; k < s.n; ++k) {
        float c[3];
        apply(r, t, s.model[k], c);
        struct pose_match_info *mi = &out->matches[k];
        mi->blob = s.blob[k];
        mi->marker = s.marker[k];
        mi->u_px = s.uc[k];
        mi->v_px = s.vc[k];
        float du = p->cam.fx_px * c[0] / c[2] + p->cam.cx_px - s.uc[k];
        float dv = p->cam.fy_px * c[1] / c[2] + p->cam.cy_px - s.vc[k];
        mi->reproj_px = sqrtf(du * du + dv * dv);
        float dist = sqrtf(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        mi->range_res_mm = s.range[k] - dist;
        float e[3];
        line_of_sight(&p->cam, s.uc[k], s.vc[k], e);
        float along = e[0] * c[0] + e[1] * c[1] + e[2] * c[2];
        float ox = c[0] - along * e[0];
        float oy = c[1] - along * e[1];
        float oz = c[2] - along * e[2];
        sum_obj += ox * ox + oy * oy + oz * oz;
        sum_reproj += mi->reproj_px * mi->reproj_px;
        sum_range += mi->range_res_mm * mi->range_res_mm;
    }
    out->n_matches = (uint8_t)s.n;
    float inv_n = 1.0f / (float)s.n;
    out->reproj_rms_px = sqrtf(sum_reproj * inv_n);
    out->range_rms_mm = sqrtf(sum_range * inv_n);
    out->object_rms_mm = sqrtf(sum_obj * inv_n);
    if (!gated) {
        out->status = POSE_STATUS_RESIDUAL;
    } else if (!facing) {
        out->status = POSE_STATUS_IMPLAUSIBLE;
    } else if (s.n >= 4u && converged) {
        out->status = POSE_STATUS_OK;
    } else {
        out->status = POSE_STATUS_DEGRADED;
    }
    return POSE_OK;
}

int pose_process(struct pose_pipeline *p, const struct pose_frame *frame, struct pose_result *out,
                 uint16_t *bad_x, uint16_t *bad_y) {
    int err = pose_extract(p, frame, out, bad_x, bad_y);
    if (err != POSE_OK || out->status == POSE_STATUS_RUN_OVERFLOW) {
        return err;
    }
    if (out->n_blobs < 3u) {
        out->status = POSE_STATUS_FEW_BLOBS;
        return POSE_OK;
    }
    struct pose_workspace *ws = &p->ws;
    float ranges[POSE_MAX_OBS];
    for (size_t i = 0; i < out->n_blobs; ++i) {
        ranges[i] = out->blobs[i].range_mm;
    }
    float med = median(ranges, out->n_blobs);
    for (size_t i = 0; i < out->n_blobs; ++i) {
        blob_point(p, &out->blobs[i], med, ws->obs[i].point_mm, &ws->obs[i].range_sigma_mm,
                   &ws->obs[i].lateral_sigma_mm);
    }
    int matches = pose_match(&p->cfg.match, p->markers, p->n_markers, ws->obs, out->n_blobs,
                             &ws->match, ws->assignment, &out->anneal_steps);
    if (matches < 0) {
        return matches;
    }
    if (matches < 3) {
        out->status = POSE_STATUS_NO_MATCH;
        return POSE_OK;
    }
    uint8_t blob_idx[POSE_MAX_MARKERS];
    uint8_t marker_idx[POSE_MAX_MARKERS];
    size_t n = 0u;
    for (size_t i = 0; i < out->n_blobs && n < POSE_MAX_MARKERS; ++i) {
        if (ws->assignment[i] >= 0) {
            blob_idx[n] = (uint8_t)i;
            marker_idx[n] = (uint8_t)ws->assignment[i];
            ++n;
        }
    }
    return pose_solve(p, out->blobs, blob_idx, marker_idx, n, out);
}
