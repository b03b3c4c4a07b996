/* Deterministic annealing matcher (paper §4.2-4.3). See pose_match.h for the
 * departures from the paper and why.
 */
#include "pose/pose_match.h"

#include <math.h>
#include <string.h>

/* Temperature steps: beta0 * rate^k <= beta_max bounds k; this caps it regardless. */
#define MATCH_MAX_STEPS 512u
/* Verification rounds after annealing: at most one match is dropped per round. */
#define MATCH_MAX_PRUNE POSE_MAX_OBS

void pose_match_config_default(struct pose_match_config *cfg) {
    /* 4 mm: disc depth bias and the perspective offset of blob centroids at 0.3-1 m. */
    cfg->tol_mm = 4.0f;
    cfg->tol_sigmas = 3.0f;
    /* beta0 = 0.5: at T = 2 every assignment with support is nearly equally likely. */
    cfg->beta0 = 0.5f;
    /* 10 % cooling per step: 46 steps from 0.5 to 40 (paper Eq. 33, its eta). */
    cfg->beta_rate = 1.1f;
    cfg->beta_max = 40.0f;
    /* An assignment needs support from more than one consistent partner. */
    cfg->slack_support = 1.2f;
    cfg->sinkhorn_iterations = 8u;
    cfg->accept_probability = 0.5f;
}

size_t pose_pair_index(size_t i, size_t j, size_t n) {
    if (i > j) {
        size_t tmp = i;
        i = j;
        j = tmp;
    }
    /* Row-major upper triangle without the diagonal. */
    return i * n - i * (i + 1u) / 2u + (j - i - 1u);
}

static float dist3(const float a[3], const float b[3]) {
    float dx = a[0] - b[0];
    float dy = a[1] - b[1];
    float dz = a[2] - b[2];
    return sqrtf(dx * dx + dy * dy + dz * dz);
}

/*
 * Standard error of the distance between two observations. A range error moves a
 * point along its line of sight e, which changes the distance by the component
 * of the pair's direction along e: pairs side by side at one range (the usual
 * case on a target facing the camera) are measured almost as well as the
 * bearings, even when the ranges are poor (first-order propagation).
 */
static float distance_sigma(const struct pose_match_obs *a, const struct pose_match_obs *b,
                            float d) {
    float var =
        a->lateral_sigma_mm * a->lateral_sigma_mm + b->lateral_sigma_mm * b->lateral_sigma_mm;
    if (!(d > 0.0f)) {
        return sqrtf(var + a->range_sigma_mm * a->range_sigma_mm +
                     b->range_sigma_mm * b->range_sigma_mm);
    }
    const struct pose_match_obs *pts[2] = {a, b};
    for (int k = 0; k < 2; ++k) {
        const float *q = pts[k]->point_mm;
        float n = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        float along = 0.0f;
        for (int i = 0; i < 3; ++i) {
            along += (a->point_mm[i] - b->point_mm[i]) * q[i];
        }
        float g = (n > 0.0f) ? along / (n * d) : 1.0f;
        var += g * g * pts[k]->range_sigma_mm * pts[k]->range_sigma_mm;
    }
    return sqrtf(var);
}

bool pose_match_config_valid(const struct pose_match_config *cfg) {
    return cfg->tol_mm >= 0.0f && cfg->tol_sigmas >= 0.0f && cfg->beta0 > 0.0f &&
           cfg->beta_rate > 1.0f && cfg->beta_max >= cfg->beta0 && cfg->slack_support >= 0.0f &&
           cfg->sinkhorn_iterations >= 1u && cfg->sinkhorn_iterations <= POSE_MATCH_MAX_SINKHORN &&
           cfg->accept_probability > 0.0f && cfg->accept_probability <= 1.0f;
}

/* Tukey biweight of the distance mismatch: 1 at agreement, 0 beyond the tolerance. */
static uint8_t compatibility(float d_obs, float d_marker, float tol) {
    float e = (d_obs - d_marker) / tol;
    float e2 = e * e;
    if (!(e2 < 1.0f)) {
        return 0u;
    }
    float c = (1.0f - e2) * (1.0f - e2);
    return (uint8_t)(c * 255.0f + 0.5f);
}

static void build_tables(const struct pose_match_config *cfg, const struct pose_marker *markers,
                         size_t n_markers, const struct pose_match_obs *obs, size_t n_obs,
                         struct pose_match_work *work) {
    for (size_t a = 0; a < n_markers; ++a) {
        for (size_t b = a + 1u; b < n_markers; ++b) {
            work->marker_dist[pose_pair_index(a, b, n_markers)] =
                dist3(markers[a].position_mm, markers[b].position_mm);
        }
    }
    size_t n_marker_pairs = n_markers * (n_markers - 1u) / 2u;
    for (size_t i = 0; i < n_obs; ++i) {
        for (size_t j = i + 1u; j < n_obs; ++j) {
            float d = dist3(obs[i].point_mm, obs[j].point_mm);
            float tol = cfg->tol_mm + cfg->tol_sigmas * distance_sigma(&obs[i], &obs[j], d);
            if (!(tol > 0.0f)) {
                tol = 1e-3f;
            }
            size_t ij = pose_pair_index(i, j, n_obs);
            for (size_t ab = 0; ab < n_marker_pairs; ++ab) {
                work->compat[ij][ab] = compatibility(d, work->marker_dist[ab], tol);
            }
        }
    }
}

/*
 * Support Q_ia = sum_{j != i} sum_{b != a} M_jb C(i,a,j,b) (paper Eq. 34 with the
 * compatibility as benefit). C depends only on the unordered pairs {i,j}, {a,b}.
 */
static void compute_support(size_t n_markers, size_t n_obs, struct pose_match_work *work) {
    for (size_t i = 0; i < n_obs; ++i) {
        for (size_t a = 0; a < n_markers; ++a) {
            work->q[i][a] = 0.0f;
        }
    }
    const float scale = 1.0f / 255.0f;
    for (size_t i = 0; i < n_obs; ++i) {
        for (size_t j = i + 1u; j < n_obs; ++j) {
            const uint8_t *row = work->compat[pose_pair_index(i, j, n_obs)];
            for (size_t a = 0; a < n_markers; ++a) {
                for (size_t b = a + 1u; b < n_markers; ++b) {
                    uint8_t c8 = row[pose_pair_index(a, b, n_markers)];
                    if (c8 == 0u) {
                        continue;
                    }
                    float c = (float)c8 * scale;
                    /* i->a with j->b, and i->b with j->a: both use d_ij vs D_ab. */
                    work->q[i][a] += c * work->m[j][b];
                    work->q[j][b] += c * work->m[i][a];
                    work->q[i][b] += c * work->m[j][a];
                    work->q[j][a] += c * work->m[i][b];
                }
            }
        }
    }
}

/* Alternating row / column normalisation with slack row n_obs and slack column n_markers. */
static void sinkhorn(size_t n_markers, size_t n_obs, uint8_t iterations,
                     struct pose_match_work *work) {
    for (uint8_t it = 0; it < iterations; ++it) {
        for (size_t i = 0; i < n_obs; ++i) {
            float sum = 0.0f;
            for (size_t a = 0; a <= n_markers; ++a) {
                sum += work->m[i][a];
            }
            if (sum > 0.0f) {
                for (size_t a = 0; a <= n_markers; ++a) {
                    work->m[i][a] /= sum;
                }
            }
        }
        for (size_t a = 0; a < n_markers; ++a) {
            float sum = 0.0f;
            for (size_t i = 0; i <= n_obs; ++i) {
                sum += work->m[i][a];
            }
            if (sum > 0.0f) {
                for (size_t i = 0; i <= n_obs; ++i) {
                    work->m[i][a] /= sum;
                }
            }
        }
    }
    /* Finish on rows so each observation's probabilities (with slack) sum to one (Eq. 31). */
    for (size_t i = 0; i < n_obs; ++i) {
        float sum = 0.0f;
        for (size_t a = 0; a <= n_markers; ++a) {
            sum += work->m[i][a];
        }
        if (sum > 0.0f) {
            for (size_t a = 0; a <= n_markers; ++a) {
                work->m[i][a] /= sum;
            }
        }
    }
}

static uint8_t pair_compat(const struct pose_match_work *work, size_t i, size_t j, size_t a,
                           size_t b, size_t n_obs, size_t n_markers) {
    return work->compat[pose_pair_index(i, j, n_obs)][pose_pair_index(a, b, n_markers)];
}

int pose_match(const struct pose_match_config *cfg, const struct pose_marker *markers,
               size_t n_markers, const struct pose_match_obs *obs, size_t n_obs,
               struct pose_match_work *work, int8_t *assignment, uint16_t *iterations) {
    if (cfg == NULL || markers == NULL || obs == NULL || work == NULL || assignment == NULL ||
        n_markers < 2u || n_markers > POSE_MAX_MARKERS || n_obs > POSE_MAX_OBS ||
        !pose_match_config_valid(cfg)) {

        return POSE_ERR_INVALID;
    }
    for (size_t i = 0; i < n_obs; ++i) {
        assignment[i] = -1;
    }
    if (iterations != NULL) {
        *iterations = 0u;
    }
    if (n_obs < 2u) {
        return 0;
    }
    build_tables(cfg, markers, n_markers, obs, n_obs, work);

    /* High temperature: uniform assignment over markers and slack (paper Eq. 37). */
    float uniform = 1.0f / (float)(n_markers + 1u);
    for (size_t i = 0; i <= n_obs; ++i) {
        for (size_t a = 0; a <= n_markers; ++a) {
            work->m[i][a] = uniform;
        }
    }
    float beta = cfg->beta0;
    uint16_t steps = 0u;
    while (beta <= cfg->beta_max && steps < MATCH_MAX_STEPS) {
        /*
         * The slack's support scales with the current confidence of the assignment
         * (mean over observations of their largest probability). Q_ia sums
         * probabilities, so while M is still diffuse every Q is a fraction of its
         * final value; a fixed slack would win at that stage and every observation
         * would freeze into the slack (seen with 9 observations at 2 m).
         */
        float confidence = 0.0f;
        for (size_t i = 0; i < n_obs; ++i) {
            float best = 0.0f;
            for (size_t a = 0; a < n_markers; ++a) {
                best = (work->m[i][a] > best) ? work->m[i][a] : best;
            }
            confidence += best;
        }
        float slack = cfg->slack_support * confidence / (float)n_obs;
        compute_support(n_markers, n_obs, work);
        /* Gibbs weights exp(beta * Q) (Eq. 35), shifted by the largest exponent to stay finite. */
        float qmax = slack;
        for (size_t i = 0; i < n_obs; ++i) {
            for (size_t a = 0; a < n_markers; ++a) {
                if (work->q[i][a] > qmax) {
                    qmax = work->q[i][a];
                }
            }
        }
        for (size_t i = 0; i < n_obs; ++i) {
            for (size_t a = 0; a < n_markers; ++a) {
                work->m[i][a] = expf(beta * (work->q[i][a] - qmax));
            }
            work->m[i][n_markers] = expf(beta * (slack - qmax));
        }
        for (size_t a = 0; a <= n_markers; ++a) {
            work->m[n_obs][a] = expf(beta * (slack - qmax));
        }
        sinkhorn(n_markers, n_obs, cfg->sinkhorn_iterations, work);
        beta *= cfg->beta_rate;
        ++steps;
    }
    if (iterations != NULL) {
        *iterations = steps;
    }

    /* Read off a one-to-one assignment, most probable first. */
    bool marker_used[POSE_MAX_MARKERS] = {false};
    int matches = 0;
    for (size_t round = 0; round < n_obs; ++round) {
        float best = cfg->accept_probability;
        size_t bi = n_obs;
        size_t ba = n_markers;
        for (size_t i = 0; i < n_obs; ++i) {
            if (assignment[i] >= 0) {
                continue;
            }
            for (size_t a = 0; a < n_markers; ++a) {
                if (!marker_used[a] && work->m[i][a] >= best) {
                    best = work->m[i][a];
                    bi = i;
                    ba = a;
                }
            }
        }
        if (bi == n_obs) {
            break;
        }
        assignment[bi] = (int8_t)ba;
        marker_used[ba] = true;
        ++matches;
    }

    /*
     * Verification: the matches must agree pairwise. Annealing can leave a
     * spurious point assigned to an unseen marker when it happens to agree with
     * two or three of the others (about 4 % of frames with four markers and two
     * spurious points at 0.5 mm noise). Drop the match with the most
     * disagreements (ties: the least total compatibility) until none is left, so
     * the result is a set of mutually consistent matches. Bounded: one match per
     * round.
     */
    for (size_t round = 0; round < MATCH_MAX_PRUNE && matches >= 2; ++round) {
        size_t worst = n_obs;
        int worst_conflicts = 0;
        uint32_t worst_total = 0u;
        for (size_t i = 0; i < n_obs; ++i) {
            if (assignment[i] < 0) {
                continue;
            }
            int conflicts = 0;
            uint32_t total = 0u;
            for (size_t j = 0; j < n_obs; ++j) {
                if (j == i || assignment[j] < 0) {
                    continue;
                }
                uint8_t c = pair_compat(work, i, j, (size_t)assignment[i], (size_t)assignment[j],
                                        n_obs, n_markers);
                total += c;
                if (c == 0u) {
                    ++conflicts;
                }
            }
            if (conflicts > worst_conflicts ||
                (conflicts > 0 && conflicts == worst_conflicts && total < worst_total)) {
                worst = i;
                worst_conflicts = conflicts;
                worst_total = total;
            }
        }
        if (worst == n_obs) {
            break;
        }
        assignment[worst] = -1;
        --matches;
    }
    /*
     * Completion: an observation left out (annealing can end undecided between
     * markers while a spurious point held one of them) is added when exactly one
     * unused marker agrees with every accepted match. Ambiguous ones stay out.
     */
    for (size_t round = 0; round < n_obs && matches >= 2; ++round) {
        size_t add_i = n_obs;
        size_t add_a = n_markers;
        uint32_t add_total = 0u;
        for (size_t i = 0; i < n_obs; ++i) {
            if (assignment[i] >= 0) {
                continue;
            }
            size_t candidates = 0u;
            size_t cand_a = n_markers;
            uint32_t cand_total = 0u;
            for (size_t a = 0; a < n_markers; ++a) {
                bool used = false;
                bool agrees = true;
                uint32_t total = 0u;
                for (size_t j = 0; j < n_obs && agrees; ++j) {
                    if (assignment[j] < 0) {
                        continue;
                    }
                    if ((size_t)assignment[j] == a) {
                        used = true;
                        break;
                    }
                    uint8_t c = pair_compat(work, i, j, a, (size_t)assignment[j], n_obs, n_markers);
                    agrees = c > 0u;
                    total += c;
                }
                if (!used && agrees) {
                    ++candidates;
                    cand_a = a;
                    cand_total = total;
                }
            }
            if (candidates == 1u && cand_total > add_total) {
                add_i = i;
                add_a = cand_a;
                add_total = cand_total;
            }
        }
        if (add_i == n_obs) {
            break;
        }
        assignment[add_i] = (int8_t)add_a;
        ++matches;
    }
    return matches;
}
