/* Reflector extraction (paper §3). The active pixel set is not copied: it is the
 * set of pixels whose raw gray is at least `cut_level` (the gray threshold, raised
 * by the cap when needed), so membership is a compare against the caller's frame
 * buffer. Pixels that also pass the nLoG threshold are stored as horizontal runs,
 * labelled by a bounded union-find over runs (no recursion), and each component's
 * statistics are accumulated as exact integer sums.
 */
#include <math.h>
#include <string.h>

#include "pose/pose.h"
#include "pose_internal.h"

#define NO_COMPONENT 0xFFu
#define HIST_BINS    64u

static uint16_t gray_at(const struct pose_frame *f, uint32_t x, uint32_t y) {
    return f->gray[(size_t)y * f->stride + x];
}

static uint16_t range_at(const struct pose_frame *f, uint32_t x, uint32_t y) {
    return f->range_mm[(size_t)y * f->stride + x];
}

void pose_nlog_kernel(struct pose_workspace *ws, float sigma_px) {
    /*
     * nLoG(x, y) = (1 / (pi sigma^4)) (1 - r^2 / (2 sigma^2)) exp(-r^2 / (2 sigma^2))
     * (paper Eqs. 12-14, negated so a bright blob responds positively), scaled by
     * sigma^2 (scale-normalised) and shifted to zero sum so a flat region gives 0.
     */
    int radius = (int)ceilf(3.0f * sigma_px);
    if (radius > POSE_NLOG_MAX_RADIUS) {
        radius = POSE_NLOG_MAX_RADIUS;
    }
    if (radius < 1) {
        radius = 1;
    }
    ws->nlog_radius = radius;
    float s2 = sigma_px * sigma_px;
    float sum = 0.0f;
    int size = 2 * radius + 1;
    for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
            float r2 = (float)(dx * dx + dy * dy);
            float k = (1.0f - r2 / (2.0f * s2)) * expf(-r2 / (2.0f * s2)) / (3.14159265f * s2);
            ws->nlog_kernel[dy + radius][dx + radius] = k;
            sum += k;
        }
    }
    float mean = sum / (float)(size * size);
    for (int i = 0; i < size; ++i) {
        for (int j = 0; j < size; ++j) {
            ws->nlog_kernel[i][j] -= mean;
        }
    }
}

/*
 * Active set and cap (paper §3.1.1): count pixels >= the gray threshold; if more
 * than active_cap, find by a two-level counting sort the lowest gray level whose
 * pixels and all brighter ones fit in the cap. Pixels tied at the level that
 * would overflow are all dropped, so the set never exceeds the cap.
 */
static int find_cut_level(const struct pose_config *cfg, const struct pose_frame *f,
                          struct pose_workspace *ws, struct pose_result *out, uint16_t *bad_x,
                          uint16_t *bad_y) {
    uint32_t total = 0u;
    /* 64 coarse bins over 0..full scale. */
    uint32_t shift = 0u;
    while (((uint32_t)cfg->gray_full_scale >> shift) >= HIST_BINS && shift < 16u) {
        ++shift;
    }
    memset(ws->histogram, 0, sizeof ws->histogram);
    for (uint32_t y = 0; y < f->height; ++y) {
        for (uint32_t x = 0; x < f->width; ++x) {
            uint16_t g = gray_at(f, x, y);
            if (g > cfg->gray_full_scale) {
                if (bad_x != NULL) {
                    *bad_x = (uint16_t)x;
                }
                if (bad_y != NULL) {
                    *bad_y = (uint16_t)y;
                }
                return POSE_ERR_FRAME;
            }
            if (g >= cfg->gray_threshold) {
                ++ws->histogram[g >> shift];
                ++total;
            }
        }
    }
    out->cut_level = cfg->gray_threshold;
    out->active_pixels = total;
    out->capped_pixels = 0u;
    if (total <= cfg->active_cap) {
        return POSE_OK;
    }
    /* Coarse bin holding the cut: brighter bins fit, adding this one overflows. */
    uint32_t above = 0u;
    uint32_t bin = HIST_BINS;
    for (uint32_t b = HIST_BINS; b-- > 0u;) {
        if (above + ws->histogram[b] > cfg->active_cap) {
            bin = b;
            break;
        }
        above += ws->histogram[b];
    }
    /* bin < HIST_BINS is guaranteed since total > cap. Fine pass within it. */
    uint32_t lo = bin << shift;
    uint32_t width = 1u << shift;
    memset(ws->histogram, 0, sizeof ws->histogram);
    for (uint32_t y = 0; y < f->height; ++y) {
        for (uint32_t x = 0; x < f->width; ++x) {
            uint32_t g = gray_at(f, x, y);
            if (g >= cfg->gray_threshold && g >= lo && g < lo + width) {
                ++ws->histogram[g - lo];
            }
        }
    }
    uint32_t level = lo + width; /* all of this bin dropped unless some levels fit */
    for (uint32_t k = width; k-- > 0u;) {
        if (above + ws->histogram[k] > cfg->active_cap) {
            break;
        }
        above += ws->histogram[k];
        level = lo + k;
    }
    out->cut_level = (uint16_t)level;
    out->active_pixels = above;
    out->capped_pixels = total - above;
    return POSE_OK;
}

/* nLoG response at an active pixel; pixels outside the active set count as 0 (paper §3.1.2). */
static float nlog_response(const struct pose_workspace *ws, const struct pose_frame *f,
                           uint16_t cut, int x, int y) {
    int r = ws->nlog_radius;
    float acc = 0.0f;
    if (x >= r && y >= r && x + r < (int)f->width && y + r < (int)f->height) {
        /* Interior: the same sum in the same order without per-tap bounds checks. */
        for (int dy = -r; dy <= r; ++dy) {
            const uint16_t *row = &f->gray[(size_t)(y + dy) * f->stride + (size_t)(x - r)];
            const float *k = ws->nlog_kernel[dy + r];
            for (int dx = 0; dx <= 2 * r; ++dx) {
                uint16_t g = row[dx];
                if (g >= cut) {
                    acc += k[dx] * (float)g;
                }
            }
        }
        return acc;
    }
    for (int dy = -r; dy <= r; ++dy) {

        int yy = y + dy;
        if (yy < 0 || yy >= (int)f->height) {
            continue;
        }
        for (int dx = -r; dx <= r; ++dx) {
            int xx = x + dx;
            if (xx < 0 || xx >= (int)f->width) {
                continue;
            }
            uint16_t g = gray_at(f, (uint32_t)xx, (uint32_t)yy);
            if (g >= cut) {
                acc += ws->nlog_kernel[dy + r][dx + r] * (float)g;
            }
        }
    }
    return acc;
}

static uint16_t uf_find(struct pose_run *runs, uint16_t i) {
    /* Path halving; a chain is never longer than the number of runs. */
    for (uint32_t guard = 0; guard < POSE_MAX_RUNS && runs[i].link != i; ++guard) {
        runs[i].link = runs[runs[i].link].link;
        i = runs[i].link;
    }
    return i;
}

static void uf_union(struct pose_run *runs, uint16_t a, uint16_t b) {
    uint16_t ra = uf_find(runs, a);
    uint16_t rb = uf_find(runs, b);
    /* The earliest run stays root, so roots precede their members in raster order. */
    if (ra < rb) {
        runs[rb].link = ra;
    } else if (rb < ra) {
        runs[ra].link = rb;
    }
}

/* Second threshold and runs (paper §3.1.2 and §3.2); false when POSE_MAX_RUNS overflowed. */
static bool build_runs(const struct pose_config *cfg, const struct pose_frame *f,
                       struct pose_workspace *ws, struct pose_result *out) {
    uint32_t n = 0u;
    uint32_t kept = 0u;
    uint32_t prev_start = 0u;
    uint32_t prev_end = 0u;
    uint16_t cut = out->cut_level;
    for (uint32_t y = 0; y < f->height; ++y) {
        uint32_t row_start = n;
        bool open = false;
        for (uint32_t x = 0; x < f->width; ++x) {
            bool keep = false;
            float resp = 0.0f;
            if (gray_at(f, x, y) >= cut) {
                resp = nlog_response(ws, f, cut, (int)x, (int)y);
                keep = resp >= cfg->nlog_keep;
            }
            if (keep) {
                ++kept;
                if (open) {
                    ws->runs[n - 1u].x1 = (uint16_t)x;
                    if (resp > ws->runs[n - 1u].peak_response) {
                        ws->runs[n - 1u].peak_response = resp;
                    }
                } else {
                    if (n >= POSE_MAX_RUNS) {
                        out->runs = n;
                        out->kept_pixels = kept;
                        return false;
                    }
                    ws->runs[n].y = (uint16_t)y;
                    ws->runs[n].x0 = (uint16_t)x;
                    ws->runs[n].x1 = (uint16_t)x;
                    ws->runs[n].link = (uint16_t)n;
                    ws->runs[n].peak_response = resp;
                    ++n;
                    open = true;
                }
            } else {
                open = false;
            }
        }
        /* 8-connectivity with the previous row: x ranges overlapping within one pixel. */
        uint32_t p = prev_start;
        for (uint32_t r = row_start; r < n; ++r) {
            for (; p < prev_end; ++p) {
                if ((uint32_t)ws->runs[p].x1 + 1u >= ws->runs[r].x0) {
                    break;
                }
            }
            for (uint32_t q = p; q < prev_end; ++q) {
                if (ws->runs[q].x0 > (uint32_t)ws->runs[r].x1 + 1u) {
                    break;
                }
                uf_union(ws->runs, (uint16_t)r, (uint16_t)q);
            }
        }
        if (row_start < n) {
            prev_start = row_start;
            prev_end = n;
        } else {
            prev_start = n;
            prev_end = n;
        }
    }
    out->runs = n;
    out->kept_pixels = kept;
    return true;
}

static void accumulate(const struct pose_frame *f, struct pose_workspace *ws, uint32_t n_runs,
                       uint16_t weight_floor) {
    for (uint32_t i = 0; i < n_runs; ++i) {
        uint8_t c = ws->run_component[i];
        if (c == NO_COMPONENT) {
            continue;
        }
        struct pose_component *comp = &ws->components[c];
        const struct pose_run *run = &ws->runs[i];
        if (run->peak_response > comp->peak_response) {
            comp->peak_response = run->peak_response;
        }
        if (run->x0 == 0u || (uint32_t)run->x1 + 1u >= f->width || run->y == 0u ||
            (uint32_t)run->y + 1u >= f->height) {
            comp->touches_border = true;
        }
        int64_t dy = (int64_t)run->y - (int64_t)comp->y_origin;
        for (uint32_t x = run->x0; x <= run->x1; ++x) {
            uint16_t g = gray_at(f, x, run->y);
            int64_t w = (int64_t)g - (int64_t)weight_floor;
            int64_t dx = (int64_t)x - (int64_t)comp->x_origin;
            ++comp->pixels;
            if (g > comp->gray_max) {
                comp->gray_max = g;
            }
            comp->w += (uint64_t)w;
            comp->wx += w * dx;
            comp->wy += w * dy;
            comp->wxx += w * dx * dx;
            comp->wyy += w * dy * dy;
            comp->wxy += w * dx * dy;
            uint16_t d = range_at(f, x, run->y);
            if (d > 0u) {
                if (comp->range_count == 0u) {
                    comp->range_ref = d;
                }
                int64_t dd = (int64_t)d - (int64_t)comp->range_ref;
                comp->range_sum += dd;
                comp->range_sq_sum += dd * dd;
                ++comp->range_count;
                comp->range_w += (uint64_t)w;
                comp->range_w2 += (uint64_t)(w * w);
                comp->range_wsum += w * dd;
            }
        }
    }
}

/* Second moments of a component about its centroid; lambda1 >= lambda2. */
static void component_moments(const struct pose_component *c, float *mx, float *my, float *cxx,
                              float *cyy, float *cxy, float *l1, float *l2) {
    float w = (float)c->w;
    *mx = (float)c->wx / w;
    *my = (float)c->wy / w;
    *cxx = (float)c->wxx / w - *mx * *mx;
    *cyy = (float)c->wyy / w - *my * *my;
    *cxy = (float)c->wxy / w - *mx * *my;
    float half_tr = 0.5f * (*cxx + *cyy);
    float diff = 0.5f * (*cxx - *cyy);
    float root = sqrtf(diff * diff + *cxy * *cxy);
    *l1 = half_tr + root;
    *l2 = half_tr - root;
    if (*l2 < 0.0f) {
        *l2 = 0.0f;
    }
}

/*
 * Ellipse confirmation: a documented simplification of the paper's §3.3 (edge
 * map, curvature-predictive linking, line segments, ElliFit). A filled ellipse
 * with semi-axes a, b has second moments a^2/4 and b^2/4 along its axes, so the
 * moment ellipse scaled by 2 is the blob's own outline. The blob is confirmed as
 * an ellipse when (1) its rim points (the outer ends of its runs) lie on that
 * outline within a tolerance and (2) its pixel area matches pi a b. Merged
 * blobs, crescents and glints with straight or concave edges fail; tilted discs
 * of any eccentricity pass. Blobs below ellipse_min_pixels cannot be judged.
 */
static bool ellipse_confirm(const struct pose_config *cfg, const struct pose_workspace *ws,
                            uint32_t n_runs, uint8_t c_index) {
    const struct pose_component *c = &ws->components[c_index];
    if (c->pixels < cfg->ellipse_min_pixels || c->pixels < cfg->shape_min_pixels) {
        return true;
    }
    float mx;
    float my;
    float cxx;
    float cyy;
    float cxy;
    float l1;
    float l2;
    component_moments(c, &mx, &my, &cxx, &cyy, &cxy, &l1, &l2);
    if (!(l2 > 0.0f)) {
        return false;
    }
    float a = 2.0f * sqrtf(l1);
    float b = 2.0f * sqrtf(l2);
    float area = 3.14159265f * a * b;
    /* Pixels at least cut-level bright extend about half a pixel beyond the weighted outline. */
    float area_ratio = (float)c->pixels / (3.14159265f * (a + 0.5f) * (b + 0.5f));
    if (fabsf(area_ratio - 1.0f) > cfg->ellipse_area_tolerance + 1.0f / b) {
        return false;
    }
    (void)area;
    /* Inverse covariance, scaled so the outline is rho = 1. */
    float det = cxx * cyy - cxy * cxy;
    if (!(det > 0.0f)) {
        return false;
    }
    float ixx = cyy / (4.0f * det);
    float iyy = cxx / (4.0f * det);
    float ixy = -cxy / (4.0f * det);
    float tol = cfg->ellipse_rim_tolerance + 0.75f / b;
    uint32_t on = 0u;
    uint32_t total = 0u;
    for (uint32_t i = 0; i < n_runs; ++i) {
        if (ws->run_component[i] != c_index) {
            continue;
        }
        const struct pose_run *run = &ws->runs[i];
        float y = (float)((int32_t)run->y - (int32_t)c->y_origin) - my;
        const float xs[2] = {(float)((int32_t)run->x0 - (int32_t)c->x_origin) - 0.5f - mx,
                             (float)((int32_t)run->x1 - (int32_t)c->x_origin) + 0.5f - mx};
        for (int k = 0; k < 2; ++k) {
            float x = xs[k];
            float rho = sqrtf(ixx * x * x + 2.0f * ixy * x * y + iyy * y * y);
            ++total;
            if (fabsf(rho - 1.0f) <= tol) {
                ++on;
            }
        }
    }
    return total > 0u && (float)on >= cfg->ellipse_rim_fraction * (float)total;
}

static void label_components(struct pose_workspace *ws, struct pose_result *out, uint32_t n_runs) {
    uint32_t n_comp = 0u;
    uint32_t lost = 0u;
    for (uint32_t i = 0; i < n_runs; ++i) {
        uint16_t root = uf_find(ws->runs, (uint16_t)i);
        if (root == i) {
            ++out->components;
            if (n_comp < POSE_MAX_COMPONENTS) {
                struct pose_component *c = &ws->components[n_comp];
                memset(c, 0, sizeof *c);
                c->x_origin = ws->runs[i].x0;
                c->y_origin = ws->runs[i].y;
                c->peak_response = ws->runs[i].peak_response;
                ws->run_component[i] = (uint8_t)n_comp;
                ++n_comp;
            } else {
                ws->run_component[i] = NO_COMPONENT;
                ++lost;
            }
        } else {
            /* root < i: already labelled. */
            ws->run_component[i] = ws->run_component[root];
        }
    }
    out->components_lost = (uint16_t)lost;
}

int pose_extract_frame(struct pose_pipeline *p, const struct pose_frame *f, struct pose_result *out,
                       uint16_t *bad_x, uint16_t *bad_y, uint8_t *n_components) {
    const struct pose_config *cfg = &p->cfg;
    struct pose_workspace *ws = &p->ws;
    *n_components = 0u;
    int err = find_cut_level(cfg, f, ws, out, bad_x, bad_y);
    if (err != POSE_OK) {
        return err;
    }
    if (!build_runs(cfg, f, ws, out)) {
        out->status = POSE_STATUS_RUN_OVERFLOW;
        return POSE_OK;
    }
    uint32_t n_runs = out->runs;
    label_components(ws, out, n_runs);
    uint32_t n_comp = (uint32_t)out->components - out->components_lost;
    /* Weights: gray above (cut - 1), so a member's weight falls continuously to 1 at the cut. */
    uint16_t floor = (uint16_t)(out->cut_level > 0u ? out->cut_level - 1u : 0u);
    accumulate(f, ws, n_runs, floor);

    uint32_t accepted = 0u;
    for (uint32_t c = 0; c < n_comp; ++c) {
        struct pose_component *comp = &ws->components[c];
        float mx;
        float my;
        float cxx;
        float cyy;
        float cxy;
        float l1;
        float l2;
        component_moments(comp, &mx, &my, &cxx, &cyy, &cxy, &l1, &l2);
        float ratio = (l1 > 0.0f) ? sqrtf(l2 / l1) : 1.0f;
        comp->axis_ratio = ratio;
        if (comp->pixels < cfg->blob_min_pixels || comp->pixels > cfg->blob_max_pixels) {
            comp->reject = POSE_REJECT_SIZE;
        } else if (comp->gray_max < cfg->gray_peak || comp->peak_response < cfg->nlog_peak) {
            comp->reject = POSE_REJECT_DIM;
        } else if (comp->range_count == 0u) {
            comp->reject = POSE_REJECT_NO_RANGE;
        } else if (comp->touches_border) {
            comp->reject = POSE_REJECT_BORDER;

        } else if (comp->pixels >= cfg->shape_min_pixels && ratio < cfg->min_axis_ratio) {
            comp->reject = POSE_REJECT_ECCENTRIC;
        } else {
            comp->reject = POSE_REJECT_NONE;
            ++accepted;
        }
    }
    /* Ellipse confirmation only when the count disagrees with the catalog (paper §3.3). */
    if (accepted != p->n_markers) {
        for (uint32_t c = 0; c < n_comp; ++c) {
            struct pose_component *comp = &ws->components[c];
            if (comp->reject != POSE_REJECT_NONE && comp->reject != POSE_REJECT_ECCENTRIC) {
                continue;
            }
            comp->ellipse_checked = true;
            comp->ellipse_ok = ellipse_confirm(cfg, ws, n_runs, (uint8_t)c);
            if (comp->reject == POSE_REJECT_NONE && !comp->ellipse_ok) {
                comp->reject = POSE_REJECT_NOT_ELLIPSE;
            } else if (comp->reject == POSE_REJECT_ECCENTRIC && comp->ellipse_ok &&
                       comp->pixels >= cfg->ellipse_min_pixels &&
                       comp->axis_ratio >= cfg->readmit_min_axis_ratio) {

                comp->reject = POSE_REJECT_NONE; /* a steeply tilted disc: supplement */
            }
        }
    }
    /* Output: accepted blobs, heaviest first, at most POSE_MAX_OBS. */
    out->n_blobs = 0u;
    for (uint32_t round = 0; round < n_comp; ++round) {
        uint32_t best = n_comp;
        uint64_t best_w = 0u;
        for (uint32_t c = 0; c < n_comp; ++c) {
            const struct pose_component *comp = &ws->components[c];
            if (comp->reject == POSE_REJECT_NONE && (best == n_comp || comp->w > best_w)) {
                best = c;
                best_w = comp->w;
            }
        }
        if (best == n_comp) {
            break;
        }
        struct pose_component *comp = &ws->components[best];
        if (out->n_blobs >= POSE_MAX_OBS) {
            comp->reject = POSE_REJECT_CAPACITY;
            continue;
        }
        comp->reject = POSE_REJECT_COUNT; /* taken: excluded from later rounds */
        float mx;
        float my;
        float cxx;
        float cyy;
        float cxy;
        float l1;
        float l2;
        component_moments(comp, &mx, &my, &cxx, &cyy, &cxy, &l1, &l2);
        struct pose_blob *b = &out->blobs[out->n_blobs++];
        b->u_px = (float)comp->x_origin + mx;
        b->v_px = (float)comp->y_origin + my;
        float n = (float)comp->range_count;
        float mean_dev = (float)comp->range_sum / n;
        b->range_mean_mm = (float)comp->range_ref + mean_dev;
        /*
         * The paper's Eq. 20 weighs member pixels equally. A partly covered edge
         * pixel also returns light from the plate 100-150 mm behind, which pulls the
         * mean long (a few mm at 2 m, ~20 mm at 5 m where small markers are all
         * edge); weighting members by their centroid weight (coverage) halves that.
         */
        float wsum = (float)comp->range_w;
        b->range_mm = (float)comp->range_ref + (float)comp->range_wsum / wsum;
        float var = (float)comp->range_sq_sum / n - mean_dev * mean_dev;
        float sample_var = (comp->range_count > 1u && var > 0.0f) ? var * n / (n - 1.0f) : 0.0f;
        /* Standard error of a weighted mean: sigma * sqrt(sum w^2) / sum w. */
        b->range_se_mm = sqrtf(sample_var * (float)comp->range_w2) / wsum;
        float one = cfg->centroid_sigma_one_px;
        float fl = cfg->centroid_sigma_floor_px;
        b->centroid_sigma_px = sqrtf(fl * fl + one * one / (float)comp->pixels);
        b->weight = (float)comp->w;
        b->pixels = comp->pixels;
        b->axis_ratio = (l1 > 0.0f) ? sqrtf(l2 / l1) : 1.0f;
        b->peak_response = comp->peak_response;
        b->ellipse_checked = comp->ellipse_checked;
        b->ellipse_ok = comp->ellipse_ok;
    }
    for (uint32_t c = 0; c < n_comp; ++c) {
        struct pose_component *comp = &ws->components[c];
        if (comp->reject == POSE_REJECT_COUNT) {
            comp->reject = POSE_REJECT_NONE;
        }
        ++out->rejected[comp->reject];
    }
    *n_components = (uint8_t)n_comp;
    return POSE_OK;
}
